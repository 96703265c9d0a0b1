//! The plugin's settings.

use std::time::Duration;
use treelight_bvh::Preset;

/// Settings of `SceneBvhPlugin`.
#[derive(Clone, Copy, Debug)]
pub struct SceneBvhConfig {
    /// How long a moved mesh must stay still before its group is baked back into the tree.
    pub bake_after: Duration,
    /// How often the idle worker wakes up to bake and run update rounds.
    pub idle_tick: Duration,
    /// Most main-thread time per frame spent copying new or edited meshes out of the world; a larger
    /// mesh is copied over several frames (at least one chunk of triangles per frame). Default 0.75 ms.
    pub main_thread_budget: Duration,
    /// The share of the last frame's time the copying may take instead, when that is more than
    /// `main_thread_budget`: at a low frame rate (a software adapter drawing a large scene) a fixed
    /// budget would copy a large assembly over minutes. Default 0.1, so the frame rate drops by at
    /// most a tenth while meshes are copied.
    pub main_thread_share: f32,
    /// The engine's policy by name: its configuration for the tree, and the global updates the
    /// worker runs in idle time after each edit ([`Preset::policy`]).
    pub preset: Preset,
    /// Which meshes enter the tree in spatial chunks, each a group of the same entity kept whole,
    /// nearest the camera first (the first of a huge mesh is traced long before its whole build would
    /// be done), and how big the chunks are: the engine's [`PieceRule`](treelight_bvh::PieceRule),
    /// by default meshes over 262,144 triangles in chunks of at most 65,536.
    pub chunks: treelight_bvh::PieceRule,
    /// How many nice steps below the app's threads the worker runs its background work (0: the
    /// same priority): bakes, the global updates after edits, and (as many steps again) the
    /// full-sweep rebuilds, so that on a busy machine the frame wins the cores from work nobody
    /// waits for. Default 10.
    pub worker_nice: i32,
    /// How many nice steps below the app's threads the worker takes in what a user waits for:
    /// meshes into the tree (their bBVH builds and insertion) and edits. Default 5: at 10, the
    /// fill of a large import on a machine with one core busy took the leftovers of a frame that
    /// a software adapter draws on the CPU, five times the fill's own CPU time in the wall clock
    /// (`cargo bench --bench fill`); at 0 the frames of the fill came at half the rate.
    pub fill_nice: i32,
    /// Threads in the worker's pool for its parallel builds; 0 (the default): one fewer than the
    /// machine's cores, at least one. The core left over keeps the frame's thread from waiting for a
    /// core while big imports build (on a busy core it can wait until the scheduler's next tick).
    pub worker_threads: usize,
    /// Whether a mesh asset's vertex data is freed in the main world once the worker holds its
    /// triangles (Bevy's [`Mesh::take_gpu_data`](bevy::mesh::Mesh::take_gpu_data): the asset
    /// keeps its bounds, as a mesh whose data went to the render world does). For apps that neither rasterise their meshes nor read
    /// their vertices again, such as a headless render: a scene is then held once, in the tree,
    /// not twice. A further entity of a freed mesh shares the triangles already traced; one that
    /// would need them copied again (its mesh's traced entities all gone) is not traced, with a
    /// warning. Default `false`.
    pub release_traced_meshes: bool,
    /// Whether a mesh asset's vertex data is kept compressed (losslessly: meshoptimizer's codecs)
    /// while the worker holds its triangles and no camera rasterises it (its
    /// `RenderAssetUsages` without `RENDER_WORLD`, as `treelight_render` holds meshes back while
    /// every camera is path traced), and put back before this plugin or a rasterising camera reads
    /// it: an editor keeps every mesh, at a fraction of the bytes. An app's own systems that read
    /// a mesh's vertices call `SceneBvh::restore_parked_mesh` first. Default `false`.
    pub park_meshes: bool,
}

impl Default for SceneBvhConfig {
    fn default() -> Self {
        Self {
            bake_after: Duration::from_millis(500),
            idle_tick: Duration::from_millis(50),
            main_thread_budget: Duration::from_micros(750),
            main_thread_share: 0.1,
            preset: Preset::Balanced,
            chunks: treelight_bvh::PieceRule::default(),
            worker_nice: 10,
            fill_nice: 5,
            worker_threads: 0,
            release_traced_meshes: false,
            park_meshes: false,
        }
    }
}
