//! # treelight_scene
//!
//! [`SceneBvhPlugin`] keeps one global BVH of every mesh entity in a Bevy world, for ray picking and for
//! path tracing. The main thread only turns world changes into commands; a background worker builds
//! each mesh's bBVH in parallel and inserts it into the tree, so the main thread never waits.
//!
//! Watched: entities gaining [`Mesh3d`] (also when the asset finishes loading later), edits of mesh
//! assets, [`GlobalTransform`] changes, visibility, removal and despawn. Entities showing the same
//! mesh asset share its triangles in the tree, each one instance node (with its own material). Published: the [`SceneBvh`]
//! resource, with the tree, its version, stats and [`SceneBvh::cast_ray`].

// Every public item says what it is for: the crate is meant to be used from other apps.
#![warn(missing_docs)]

mod chunks;
mod mesh;
pub mod packed;
mod picking;
pub mod priority;
mod refine;
mod shading;
mod worker;

pub use mesh::{
    GeometryCopy, MeshGeometry, MeshPositions, MeshSkip, mesh_geometry, mesh_triangles,
};
pub use picking::SceneBvhPickingPlugin;
pub use shading::{MeshShading, ShadingVertices};
/// The engine's named policies, which [`SceneBvhConfig::preset`] takes.
pub use treelight_bvh::Preset;

use bevy::asset::AssetEvent;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::InheritedVisibility;
use bevy::math::Ray3d;
use bevy::prelude::*;
use bevy::transform::TransformSystems;
use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, RwLock, RwLockReadGuard};
use std::time::{Duration, Instant};
use treelight_bvh::glam::Affine3A;
use treelight_bvh::{Bvh, BvhError, ChangeSet, GroupId, Hit, Ray};
use worker::{Command, Shared, WorkerConfig};

/// Settings of [`SceneBvhPlugin`].
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
    /// triangles (Bevy's [`Mesh::take_gpu_data`]: the asset keeps its bounds, as a mesh whose
    /// data went to the render world does). For apps that neither rasterise their meshes nor read
    /// their vertices again, such as a headless render: a scene is then held once, in the tree,
    /// not twice. A further entity of a freed mesh shares the triangles already traced; one that
    /// would need them copied again (its mesh's traced entities all gone) is not traced, with a
    /// warning. Default `false`.
    pub release_traced_meshes: bool,
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
        }
    }
}

/// Keeps a global BVH of all mesh entities, built on a background worker.
#[derive(Default)]
pub struct SceneBvhPlugin {
    /// Settings.
    pub config: SceneBvhConfig,
}

impl Plugin for SceneBvhPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<NotTraced>();
        let policy = self.config.preset.policy();
        let shared = Arc::new(Shared {
            tree: RwLock::new(SceneTree {
                bvh: Bvh::new(policy.config),
                ..Default::default()
            }),
            stats: Mutex::new(SceneStats::default()),
            version: AtomicU64::new(0),
            pending: AtomicUsize::new(0),
            incoming: AtomicUsize::new(0),
            incoming_triangles: AtomicUsize::new(0),
            filling: AtomicBool::new(false),
            active: AtomicBool::new(false),
            failure: Mutex::new(None),
            refine_failure: Arc::new(Mutex::new(None)),
        });
        let (tx, rx) = std::sync::mpsc::channel();
        let worker_shared = shared.clone();
        let cfg = WorkerConfig {
            bake_after: self.config.bake_after,
            idle_tick: self.config.idle_tick,
            idle_updates: policy.idle,
            chunks: self.config.chunks,
            nice: self.config.worker_nice,
        };
        let worker_threads = self.config.worker_threads;
        let fill_nice = self.config.fill_nice;
        std::thread::Builder::new()
            .name("treelight-scene-bvh".into())
            .spawn(move || {
                // The worker's parallel builds run on a pool of its own at the fill's priority,
                // its background work on a thread of its own lower down (the pools' threads
                // take their nice from the app's, so both are built before this thread lowers
                // itself).
                let threads = match worker_threads {
                    0 => std::thread::available_parallelism()
                        .map_or(1, |n| n.get().saturating_sub(1).max(1)),
                    n => n,
                };
                let pool = |name: &'static str, threads: usize, nice: i32| {
                    rayon::ThreadPoolBuilder::new()
                        .thread_name(move |i| format!("treelight-{name}-{i}"))
                        .num_threads(threads)
                        .start_handler(move |_| priority::lower_current_thread(nice))
                        .build()
                        .ok()
                };
                let fill = pool("bvh", threads, fill_nice);
                let background = pool("bvh-idle", 1, cfg.nice);
                priority::lower_current_thread(fill_nice);
                // A bug in the worker stops the tree's updates, not the app: the panic is kept
                // for the app to report (SceneBvh::worker_failure).
                let shared = worker_shared.clone();
                let ran = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    let run = || worker::run(worker_shared, rx, cfg, background.as_ref());
                    match &fill {
                        Some(pool) => pool.install(run),
                        None => run(),
                    }
                }));
                if let Err(payload) = ran {
                    let why = panic_message(&*payload);
                    error!("the scene BVH worker stopped: {why}");
                    *shared.failure.lock().unwrap_or_else(|p| p.into_inner()) = Some(why);
                }
            })
            .expect("cannot start the scene BVH worker thread");
        app.insert_resource(SceneBvh {
            shared,
            sender: Mutex::new(tx),
            version: 0,
            stats: SceneStats::default(),
            waiting: HashMap::new(),
            traced: HashSet::new(),
            degenerate: HashSet::new(),
            copying: HashMap::new(),
            sent_mesh: HashMap::new(),
            mesh_senders: HashMap::new(),
            followers: HashMap::new(),
            orphans: Vec::new(),
            copy_order: Vec::new(),
            eye: None,
            budget: self.config.main_thread_budget,
            share: self.config.main_thread_share,
            last_frame: Duration::ZERO,
            prepared: HashMap::new(),
            handed_over: 0,
            release: self.config.release_traced_meshes,
            to_release: Vec::new(),
            released: 0,
        })
        .add_systems(
            PostUpdate,
            (
                track_world,
                release_traced_meshes.run_if(|scene: Res<SceneBvh>| !scene.to_release.is_empty()),
                publish,
            )
                .chain()
                .in_set(SceneBvhSystems)
                .after(TransformSystems::Propagate)
                // This frame's asset edits are seen this frame: none is missed by a copy handed
                // over before it.
                .after(bevy::asset::AssetEventSystems)
                // A mesh spawned this frame is seen with this frame's visibility (before it, as
                // hidden, so not sent for a frame: the scene looked idle with it unsent).
                .after(bevy::camera::visibility::VisibilitySystems::VisibilityPropagate),
        );
    }
}

/// A panic's message, when it has one.
pub(crate) fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic without a message".into()
    }
}

/// The plugin's main-thread systems (in `PostUpdate`, after transform propagation): turning the
/// frame's world changes into worker commands, and publishing the worker's figures. Order against it
/// to see this frame's [`SceneBvh`] figures, or to measure what the plugin costs a frame.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SceneBvhSystems;

/// Figures about the tree, refreshed every frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneStats {
    /// Triangles in the tree.
    pub triangles: u32,
    /// Inner nodes.
    pub inner_nodes: u32,
    /// SAH cost (Eq. 1, c_T = c_I = 1 by default).
    pub sah_cost: f32,
    /// Meshes still being copied out of the world, plus commands sent but not yet applied.
    pub pending: usize,
    /// Triangles per second (millions) of the last batch of inserted meshes, build included.
    pub insertion_mtris_per_s: f64,
    /// From sending the last mesh to its appearance in the tree.
    pub last_latency: Duration,
    /// Still meshes whose binned build the worker has replaced in idle time by a full-sweep SAH
    /// build of the same triangles, so far.
    pub meshes_refined: u64,
    /// Heap bytes the tree holds ([`Bvh::memory_bytes`]), as of the last cost.
    pub tree_bytes: usize,
    /// Heap bytes of the groups' normals and texture coordinates ([`SceneTree::shading`]), each
    /// shared set once, as of the last cost.
    pub shading_bytes: usize,
}

/// The tree and the entity each group belongs to.
#[derive(Default)]
pub struct SceneTree {
    /// The global BVH.
    pub bvh: Bvh,
    /// Which entity each group is.
    pub group_entity: HashMap<GroupId, Entity>,
    /// Which groups each traced entity is: one, or one per chunk of a mesh that entered the tree in
    /// spatial chunks ([`SceneBvhConfig::chunks`]).
    pub entity_groups: HashMap<Entity, Vec<GroupId>>,
    /// Each group's normals and texture coordinates, in the order of its triangles
    /// ([`Bvh::group_triangles`]).
    pub shading: HashMap<GroupId, Arc<MeshShading>>,
    /// Groups inserted since a renderer last took the changes (bounded by the live groups: removed
    /// ones leave the set).
    fresh_groups: HashSet<GroupId>,
    /// Groups re-laid since a renderer last asked (a mesh rebuilt by another builder), each with
    /// the group it replaced.
    relaid_groups: HashMap<GroupId, GroupId>,
    /// The mesh asset each traced entity shows, and the entities showing each: entities with the
    /// same mesh share its triangles in the tree ([`Bvh::insert_instance`]).
    entity_mesh: HashMap<Entity, AssetId<Mesh>>,
    mesh_entities: HashMap<AssetId<Mesh>, Vec<Entity>>,
    /// Entities holding an older version of their mesh than the last one sent (the asset was
    /// edited, and their own new version is on its way): never a source for others.
    stale: HashSet<Entity>,
}

impl SceneTree {
    /// Heap bytes of the tree's arrays and of the groups' shading (each shared set once).
    pub fn memory_bytes(&self) -> (usize, usize) {
        // Shading shared by groups (instances, re-laid groups) counts once, and vertex arrays
        // shared by a mesh's chunks once.
        let (mut sets, mut vertex_sets) = (HashSet::new(), HashSet::new());
        let shading = self
            .shading
            .values()
            .filter(|s| sets.insert(Arc::as_ptr(s)))
            .map(|s| {
                let (vertices, at) = s.vertex_bytes();
                s.corner_bytes() + if vertex_sets.insert(at) { vertices } else { 0 }
            })
            .sum();
        (self.bvh.memory_bytes().total(), shading)
    }

    pub(crate) fn bind(
        &mut self,
        e: Entity,
        g: GroupId,
        shading: Arc<MeshShading>,
        mesh: AssetId<Mesh>,
    ) {
        self.group_entity.insert(g, e);
        self.entity_groups.entry(e).or_default().push(g);
        self.shading.insert(g, shading);
        self.fresh_groups.insert(g);
        match self.entity_mesh.insert(e, mesh) {
            Some(old) if old == mesh => {}
            old => {
                if let Some(old) = old {
                    self.unlist(e, old);
                }
                self.mesh_entities.entry(mesh).or_default().push(e);
            }
        }
        self.stale.remove(&e);
    }

    fn unlist(&mut self, e: Entity, mesh: AssetId<Mesh>) {
        if let Some(list) = self.mesh_entities.get_mut(&mesh) {
            list.retain(|&x| x != e);
            if list.is_empty() {
                self.mesh_entities.remove(&mesh);
            }
        }
    }

    /// The groups entity `e` is in the tree (none if it is not traced).
    pub fn groups_of(&self, e: Entity) -> &[GroupId] {
        self.entity_groups.get(&e).map_or(&[], Vec::as_slice)
    }

    /// Whether any of `e`'s triangles are in the tree.
    pub fn is_traced(&self, e: Entity) -> bool {
        self.entity_groups.contains_key(&e)
    }

    /// `e` brought new triangles for `mesh`: every other entity's are an older version.
    pub(crate) fn supersede(&mut self, e: Entity, mesh: AssetId<Mesh>) {
        if let Some(list) = self.mesh_entities.get(&mesh) {
            self.stale.extend(list.iter().copied().filter(|x| *x != e));
        }
    }

    /// Traces `e` with the triangles an entity of the same mesh brought (`e` itself among them:
    /// its new instance is made before its old group goes, so the triangles never lapse). On
    /// failure `e` is not traced.
    pub(crate) fn share(
        &mut self,
        e: Entity,
        mesh: AssetId<Mesh>,
        transform: Affine3A,
    ) -> Result<(), BvhError> {
        // Another entity's current version first, else `e`'s own, else whatever there is.
        let holders: Vec<Entity> = self.mesh_entities.get(&mesh).cloned().unwrap_or_default();
        let fresh = |x: &Entity| !self.stale.contains(x);
        let sources: Vec<GroupId> = holders
            .iter()
            .filter(|x| **x != e && fresh(x))
            .chain(holders.iter().filter(|x| **x == e && fresh(x)))
            .chain(holders.iter())
            .find_map(|x| self.entity_groups.get(x))
            .cloned()
            .unwrap_or_default();
        if sources.is_empty() {
            self.remove_entity(e);
            return Err(BvhError::UnknownGroup);
        }
        // One instance per group of the source (one per chunk of a chunked mesh).
        let mut made: Vec<(GroupId, GroupId)> = Vec::with_capacity(sources.len());
        let failed = self.bvh.batch(|bvh| {
            for &source in &sources {
                match bvh.insert_instance(source, transform) {
                    Ok(g) => made.push((g, source)),
                    Err(err) => return Some(err),
                }
            }
            None
        });
        if let Some(err) = failed {
            for (g, _) in made {
                // Made just now by this tree, so removal cannot fail.
                let _ = self.bvh.remove_group(g);
            }
            self.remove_entity(e);
            return Err(err);
        }
        self.remove_entity(e);
        for (g, source) in made {
            let shading = self.shading.get(&source).cloned().unwrap_or_default();
            self.bind(e, g, shading, mesh);
        }
        Ok(())
    }

    pub(crate) fn remove_entity(&mut self, e: Entity) {
        self.stale.remove(&e);
        if let Some(mesh) = self.entity_mesh.remove(&e) {
            self.unlist(e, mesh);
        }
        for g in self.entity_groups.remove(&e).unwrap_or_default() {
            self.drop_group(g);
        }
    }

    /// Removes some of `e`'s groups (an older version of its mesh, once all chunks of the new one
    /// are in); `e` stays traced by the rest.
    pub(crate) fn remove_groups(&mut self, e: Entity, old: &[GroupId]) {
        if let Some(list) = self.entity_groups.get_mut(&e) {
            list.retain(|g| !old.contains(g));
            if list.is_empty() {
                self.remove_entity(e);
            }
        }
        for &g in old {
            if self.group_entity.get(&g) == Some(&e) {
                self.drop_group(g);
            }
        }
    }

    /// `e`'s group `old` was swapped in the tree for `new` ([`Bvh::swap_group`]): the same
    /// triangles in the same order, so the same shading and mesh.
    pub(crate) fn replace_group(&mut self, e: Entity, old: GroupId, new: GroupId) {
        let shading = self.shading.get(&old).cloned().unwrap_or_default();
        self.forget_group(old);
        if let Some(list) = self.entity_groups.get_mut(&e) {
            list.retain(|g| *g != old);
        }
        if let Some(&mesh) = self.entity_mesh.get(&e) {
            self.bind(e, new, shading, mesh);
            // The same triangles, laid out anew: their shading moves with them, no hit changes.
            if self.fresh_groups.remove(&new) {
                let was = self.relaid_groups.remove(&old).unwrap_or(old);
                self.relaid_groups.insert(new, was);
            }
        }
    }

    /// Forgets what this tree keeps about group `g` (the engine's tree is the caller's).
    fn forget_group(&mut self, g: GroupId) {
        self.group_entity.remove(&g);
        self.shading.remove(&g);
        self.fresh_groups.remove(&g);
        self.relaid_groups.remove(&g);
    }

    fn drop_group(&mut self, g: GroupId) {
        self.forget_group(g);
        // The handle came from this tree, so removal cannot fail.
        let _ = self.bvh.remove_group(g);
    }

    /// The entity owning triangle `t` (the one whose mesh brought it, while it is traced; entities
    /// of the same mesh share it: see [`SceneTree::entity_of_hit`]).
    pub fn entity_of_triangle(&self, t: u32) -> Option<Entity> {
        self.bvh
            .triangle_group(t)
            .and_then(|g| self.group_entity.get(&g).copied())
    }

    /// The entity a ray hit: the one whose instance it reached the triangle through.
    pub fn entity_of_hit(&self, hit: &Hit) -> Option<Entity> {
        self.bvh
            .hit_group(hit)
            .and_then(|g| self.group_entity.get(&g).copied())
    }
}

/// What changed in the tree since a renderer last asked ([`SceneBvh::try_take_changes`]).
#[derive(Clone, Debug, Default)]
pub struct SceneChanges {
    /// The engine's change set: node ranges, triangles written and removed, instances.
    pub bvh: ChangeSet,
    /// Groups inserted since then, still alive, by slot: their triangles' shading data must be
    /// uploaded ([`SceneTree::shading`]).
    pub fresh_groups: Vec<GroupId>,
    /// Groups re-laid since then (a still mesh rebuilt by a better builder: the same triangles in
    /// new slots), by slot, each with the group it replaced: their shading must be uploaded again,
    /// but no hit changed.
    pub relaid_groups: Vec<(GroupId, GroupId)>,
    /// The tree's version these changes bring a copy up to ([`SceneBvh::version`]; at most one
    /// behind, never ahead, when the worker has just written).
    pub version: u64,
}

/// A ray hit on the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// The entity hit.
    pub entity: Entity,
    /// The triangle hit (the tree's id).
    pub triangle: u32,
    /// Distance along the ray (the ray's direction is unit length).
    pub distance: f32,
    /// World-space hit point.
    pub point: Vec3,
    /// Unit geometric normal, facing the ray.
    pub normal: Vec3,
}

/// The global BVH of the world's meshes, kept in sync by [`SceneBvhPlugin`].
#[derive(Resource)]
pub struct SceneBvh {
    shared: Arc<Shared>,
    sender: Mutex<Sender<Command>>,
    version: u64,
    stats: SceneStats,
    /// Entities whose mesh asset has not loaded yet, by asset.
    waiting: HashMap<AssetId<Mesh>, Vec<Entity>>,
    /// Entities sent to the worker (so moves and removals of others are not sent).
    traced: HashSet<Entity>,
    /// Mesh entities placed by a transform no group can take (scaled to zero, as exporters hide
    /// nodes): not traced, and never the one whose copy of a mesh others share, until they move
    /// to a transform that can be traced.
    degenerate: HashSet<Entity>,
    /// Meshes being copied out of the world, a budget's worth per frame.
    copying: HashMap<Entity, MeshCopy>,
    /// The mesh whose triangles the worker has (or will have) for each entity, and how many
    /// entities sent each mesh: a further entity of that mesh shares them instead of copying.
    sent_mesh: HashMap<Entity, AssetId<Mesh>>,
    mesh_senders: HashMap<AssetId<Mesh>, usize>,
    /// Entities waiting for another entity's copy of the same mesh, with their latest transform.
    followers: HashMap<Entity, Follower>,
    /// Followers whose leader stopped copying: looked at again at the end of the frame.
    orphans: Vec<Entity>,
    /// This frame's order of the copies: nearest the camera first.
    copy_order: Vec<Entity>,
    /// Where the first active 3D camera is this frame: the worker inserts a huge mesh's chunks
    /// nearest it first.
    eye: Option<Vec3>,
    budget: Duration,
    /// [`SceneBvhConfig::main_thread_share`].
    share: f32,
    /// How long the last frame took.
    last_frame: Duration,
    /// Geometry made off the main thread for mesh assets ([`SceneBvh::prepare`]), taken by the
    /// first entity of each that is traced.
    prepared: HashMap<AssetId<Mesh>, GeometryCopy>,
    /// Meshes sent to the worker as handed over, with no copy.
    handed_over: u64,
    /// [`SceneBvhConfig::release_traced_meshes`].
    release: bool,
    /// Meshes sent to the worker this frame whose vertex data is to be freed.
    to_release: Vec<AssetId<Mesh>>,
    /// Meshes whose vertex data was freed.
    released: u64,
}

/// An entity whose mesh is being copied for another: it is sent as an instance once that copy is.
struct Follower {
    mesh: AssetId<Mesh>,
    name: String,
    transform: bevy::math::Affine3A,
    started: Instant,
}

/// A mesh entity whose triangles are being copied for the worker.
struct MeshCopy {
    mesh: AssetId<Mesh>,
    name: String,
    transform: bevy::math::Affine3A,
    started: Instant,
    copy: GeometryCopy,
    /// Whether `copy` was handed over whole ([`SceneBvh::prepare`]) and is still taken to be the
    /// asset's (cleared when its sizes are not).
    handed_over: bool,
}

/// Array elements (vertex attributes or indices) copied between looks at the clock: memory copies of
/// a few tens of microseconds.
const COPY_CHUNK: usize = 16 * 1024;

impl SceneBvh {
    /// Hands over a whole copy of `mesh`'s arrays ([`GeometryCopy::whole`]), made elsewhere from
    /// the same asset (an importer can make it on its own thread as it makes the asset): the first
    /// entity showing `mesh` that is traced sends it to the worker in the frame it is seen,
    /// instead of copying the asset out of the world a budget's worth a frame. A large import
    /// then fills the tree at the worker's pace, not the frame rate's. Taken once (further
    /// entities of the mesh share its triangles); dropped when the asset is modified or removed
    /// first, and replaced by a copy of the asset when its sizes are not the asset's. While every
    /// entity of the asset is hidden it waits here, until one is shown or the asset is dropped.
    pub fn prepare(&mut self, mesh: AssetId<Mesh>, copy: GeometryCopy) {
        self.prepared.insert(mesh, copy);
    }

    /// How many meshes were sent to the worker as [`SceneBvh::prepare`] handed them over, with
    /// no copy out of the world.
    pub fn meshes_handed_over(&self) -> u64 {
        self.handed_over
    }

    /// How many mesh assets had their vertex data freed once traced
    /// ([`SceneBvhConfig::release_traced_meshes`]).
    pub fn meshes_released(&self) -> u64 {
        self.released
    }

    /// Version of the tree, raised by every change the worker applies.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Figures about the tree as of this frame.
    pub fn stats(&self) -> SceneStats {
        self.stats
    }

    /// Why the worker stopped, if it has (a panic, with its message): the tree then no longer
    /// follows the world, and [`SceneBvh::is_idle`] stays false.
    pub fn worker_failure(&self) -> Option<String> {
        self.shared
            .failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// Why background refinement stopped, if it has (a panic); the tree keeps its first builds.
    pub fn refinement_failure(&self) -> Option<String> {
        self.shared
            .refine_failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// Makes the worker panic, as a bug in it would: how an app's tests check that it survives
    /// and reports one.
    #[doc(hidden)]
    pub fn crash_worker_for_tests(&self) {
        // A pending command like any other: the scene is not idle while it is on its way.
        self.send(Command::Crash);
    }

    /// Whether new geometry is on its way into the tree: meshes being copied out of the world, or
    /// sent to the worker (new or edited meshes, further entities sharing one) and not yet in.
    /// Moves and removals do not count. While an import streams in this holds for seconds, and
    /// each frame's new triangles change what a renderer shows anyway.
    pub fn is_filling(&self) -> bool {
        self.worker_failure().is_none()
            && (self.is_copying() || self.shared.incoming.load(Ordering::Acquire) > 0)
    }

    /// New triangles on their way into the tree: meshes being copied out of the world, and those
    /// sent to the worker and not yet in. What the tree is about to grow by, so that a renderer
    /// can size its buffers once for a whole import instead of growing them step by step (each
    /// step holding the old and the new buffer at once).
    pub fn incoming_triangles(&self) -> usize {
        let copying: usize = self.copying.values().map(|j| j.copy.triangles()).sum();
        copying + self.shared.incoming_triangles.load(Ordering::Acquire)
    }

    /// Whether meshes are still being copied out of the world, or entities sharing one wait for
    /// it: geometry the worker has not been sent yet.
    fn is_copying(&self) -> bool {
        !self.copying.is_empty() || !self.followers.is_empty()
    }

    /// Whether every change sent so far has been applied (never, once the worker has stopped).
    pub fn is_idle(&self) -> bool {
        !self.is_copying()
            && self.shared.pending.load(Ordering::Acquire) == 0
            && self.worker_failure().is_none()
    }

    /// Whether the worker has nothing left to do until the next change: every change applied
    /// ([`SceneBvh::is_idle`]) and no work of its own ahead (moved meshes to bake, update steps,
    /// rebuilds). An app that draws only when something changes (Bevy's reactive `WinitSettings`)
    /// keeps drawing while this is false: the tree still changes, and [`SceneBvh::version`] with it.
    pub fn is_resting(&self) -> bool {
        self.is_idle() && !self.shared.active.load(Ordering::Acquire)
    }

    /// Read access to the tree, unless the worker is writing to it right now (the main thread never
    /// waits: try again next frame), or has stopped: a worker that panicked may have left the
    /// tree half written, so it is published no more (picking and renderers see nothing new).
    pub fn try_read(&self) -> Option<RwLockReadGuard<'_, SceneTree>> {
        if self.worker_failure().is_some() {
            return None;
        }
        self.shared.tree.try_read().ok()
    }

    /// Read access, waiting for the worker if it is writing (for tests and tools, not for frames),
    /// even to a tree a stopped worker left.
    pub fn read_blocking(&self) -> RwLockReadGuard<'_, SceneTree> {
        self.shared.tree.read().unwrap_or_else(|p| p.into_inner())
    }

    /// Read access, waiting for the worker if it is writing (a click's pick must see the tree);
    /// `None` once the worker has stopped ([`SceneBvh::try_read`]).
    pub fn read_waiting(&self) -> Option<RwLockReadGuard<'_, SceneTree>> {
        if self.worker_failure().is_some() {
            return None;
        }
        self.shared.tree.read().ok()
    }

    /// The nearest hit of `ray` on the latest tree, or `None` if nothing is hit (or the worker holds
    /// the tree this instant).
    pub fn cast_ray(&self, ray: Ray3d) -> Option<SceneHit> {
        self.cast_ray_filtered(ray, |_| true)
    }

    /// The nearest hit on an entity that `accept` takes; others are seen through.
    pub fn cast_ray_filtered(
        &self,
        ray: Ray3d,
        accept: impl FnMut(Entity) -> bool,
    ) -> Option<SceneHit> {
        cast_on_filtered(&*self.try_read()?, ray, accept)
    }

    /// For a renderer that mirrors the tree on the GPU: takes what changed since its last call and
    /// hands it over with read access to the tree, so the records it reads agree with the change set.
    /// `everything` marks the whole tree changed first (a renderer's first call, or one that lost
    /// its copy). Returns `None`, and takes nothing, when the worker holds the tree this instant.
    ///
    /// There is one change log: the scene has one GPU mirror.
    pub fn try_take_changes<R>(
        &self,
        everything: bool,
        f: impl FnOnce(&SceneTree, &SceneChanges) -> R,
    ) -> Option<R> {
        // A worker that panicked may have left the tree half written: nothing more is taken.
        if self.worker_failure().is_some() {
            return None;
        }
        let mut tree = self.shared.tree.try_write().ok()?;
        if everything {
            tree.bvh.mark_all_changed();
            let all: Vec<GroupId> = tree.group_entity.keys().copied().collect();
            tree.fresh_groups.extend(all);
        }
        let mut fresh: Vec<GroupId> = tree.fresh_groups.drain().collect();
        fresh.sort_unstable_by_key(|g| g.index());
        let mut relaid: Vec<(GroupId, GroupId)> = tree.relaid_groups.drain().collect();
        relaid.sort_unstable_by_key(|g| g.0.index());
        let changes = SceneChanges {
            bvh: tree.bvh.take_changes(),
            fresh_groups: fresh,
            relaid_groups: relaid,
            // The worker raises the version once it has let the tree go: read under the lock,
            // this is never ahead of what the tree holds.
            version: self.shared.version.load(Ordering::Acquire),
        };
        Some(f(&tree, &changes))
    }

    /// Stops tracing `e`: the worker removes what it has of it. Nothing is sent for an entity the
    /// worker never heard of.
    fn untrace(&mut self, e: Entity) {
        self.followers.remove(&e);
        self.forget_mesh(e);
        if self.traced.remove(&e) {
            self.send(Command::Remove { entity: e });
        }
    }

    /// `e`'s triangles are going away (a removal, or a new version on its way).
    fn forget_mesh(&mut self, e: Entity) {
        if let Some(m) = self.sent_mesh.remove(&e)
            && let Some(n) = self.mesh_senders.get_mut(&m)
        {
            *n -= 1;
            if *n == 0 {
                self.mesh_senders.remove(&m);
            }
        }
    }

    fn remember_mesh(&mut self, e: Entity, mesh: AssetId<Mesh>) {
        self.sent_mesh.insert(e, mesh);
        *self.mesh_senders.entry(mesh).or_default() += 1;
    }

    /// Stops `e`'s copy, if any; entities that waited for it are looked at again.
    fn drop_copy(&mut self, e: Entity) {
        if let Some(job) = self.copying.remove(&e) {
            for f in self.followers_of(job.mesh) {
                self.followers.remove(&f);
                self.orphans.push(f);
            }
        }
    }

    /// The entities waiting for a copy of `mesh`.
    fn followers_of(&self, mesh: AssetId<Mesh>) -> Vec<Entity> {
        self.followers
            .iter()
            .filter(|(_, f)| f.mesh == mesh)
            .map(|(&f, _)| f)
            .collect()
    }

    /// Sends `e` as an instance of `mesh`, whose triangles the worker holds for another entity.
    fn send_instance(&mut self, e: Entity, follower: Follower) {
        self.traced.insert(e);
        self.remember_mesh(e, follower.mesh);
        self.send(Command::Instance {
            entity: e,
            mesh: follower.mesh,
            name: follower.name,
            transform: follower.transform,
            sent: follower.started,
        });
    }

    fn send(&self, c: Command) {
        let incoming = c.brings_geometry();
        let triangles = c.new_triangles();
        self.shared.pending.fetch_add(1, Ordering::AcqRel);
        self.shared
            .incoming_triangles
            .fetch_add(triangles, Ordering::AcqRel);
        if incoming {
            self.shared.incoming.fetch_add(1, Ordering::AcqRel);
        }
        if self
            .sender
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .send(c)
            .is_err()
        {
            self.shared.pending.fetch_sub(1, Ordering::AcqRel);
            self.shared
                .incoming_triangles
                .fetch_sub(triangles, Ordering::AcqRel);
            if incoming {
                self.shared.incoming.fetch_sub(1, Ordering::AcqRel);
            }
            error!("the scene BVH worker has stopped");
        }
    }
}

/// Closest hit on a tree, with entity and world-space geometry.
pub fn cast_on(tree: &SceneTree, ray: Ray3d) -> Option<SceneHit> {
    let hit = tree
        .bvh
        .closest_hit(&Ray::new(ray.origin, Vec3::from(ray.direction)))?;
    scene_hit(tree, ray, hit)
}

/// Closest hit on a tree on an entity that `accept` takes; the others are seen through, however
/// close to an accepted surface they lie (an object resting on a floor, say).
pub fn cast_on_filtered(
    tree: &SceneTree,
    ray: Ray3d,
    mut accept: impl FnMut(Entity) -> bool,
) -> Option<SceneHit> {
    let hit = tree
        .bvh
        .closest_hit_where(&Ray::new(ray.origin, Vec3::from(ray.direction)), |h| {
            tree.entity_of_hit(h).is_some_and(&mut accept)
        })?;
    scene_hit(tree, ray, hit)
}

fn scene_hit(tree: &SceneTree, ray: Ray3d, hit: Hit) -> Option<SceneHit> {
    let dir = Vec3::from(ray.direction);
    let entity = tree.entity_of_hit(&hit)?;
    let tri = tree.bvh.hit_world_triangle(&hit)?;
    let n = tri.normal().normalize_or_zero();
    Some(SceneHit {
        entity,
        triangle: hit.triangle,
        distance: hit.t,
        point: ray.origin + dir * hit.t,
        normal: if n.dot(dir) > 0.0 { -n } else { n },
    })
}

type MeshEntity<'a> = (
    Entity,
    &'a Mesh3d,
    &'a GlobalTransform,
    Option<&'a InheritedVisibility>,
    Option<&'a Name>,
);

/// Keeps a mesh entity out of the scene BVH, and so out of ray picking and every renderer that
/// traces the tree: an app's own helpers (gizmo handles, icons, drag ghosts, thumbnails) carry it.
/// Adding it to a traced entity removes the entity from the tree; removing it puts the entity back.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Component, Default)]
pub struct NotTraced;

/// Turns this frame's world changes into worker commands.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn track_world(
    mut scene: ResMut<SceneBvh>,
    meshes: Res<Assets<Mesh>>,
    mut asset_events: MessageReader<AssetEvent<Mesh>>,
    changed_mesh: Query<
        MeshEntity,
        (
            Or<(Changed<Mesh3d>, Changed<InheritedVisibility>)>,
            Without<NotTraced>,
        ),
    >,
    moved: Query<
        (Entity, &GlobalTransform),
        (Changed<GlobalTransform>, With<Mesh3d>, Without<NotTraced>),
    >,
    all: Query<MeshEntity, Without<NotTraced>>,
    bounds: Query<(&GlobalTransform, Option<&Aabb>)>,
    cameras: Query<(&Camera, &GlobalTransform), With<Camera3d>>,
    opted_out: Query<Entity, Added<NotTraced>>,
    mut opted_in: RemovedComponents<NotTraced>,
    mut removed: RemovedComponents<Mesh3d>,
    time: Option<Res<Time<Real>>>,
) {
    let scene = &mut *scene;
    scene.last_frame = time.map_or(Duration::ZERO, |t| t.delta());
    let mut sent_now: HashSet<Entity> = HashSet::new();
    for e in removed.read().chain(opted_out.iter()) {
        for list in scene.waiting.values_mut() {
            list.retain(|&w| w != e);
        }
        scene.degenerate.remove(&e);
        scene.drop_copy(e);
        scene.untrace(e);
        sent_now.insert(e);
    }
    // Meshes that finished loading, for entities that were waiting on them.
    let mut ready: Vec<Entity> = Vec::new();
    for ev in asset_events.read() {
        if let AssetEvent::Added { id } | AssetEvent::LoadedWithDependencies { id } = ev
            && let Some(list) = scene.waiting.remove(id)
        {
            ready.extend(list);
        }
        if let AssetEvent::Modified { id } = ev {
            // Every entity of the mesh is sent again this frame (`Changed<Mesh3d>`): none of them
            // may share the old triangles.
            scene.sent_mesh.retain(|_, m| m != id);
            scene.mesh_senders.remove(id);
        }
        if let AssetEvent::Modified { id }
        | AssetEvent::Removed { id }
        | AssetEvent::Unused { id } = ev
        {
            // Geometry handed over for an older version, or for a mesh no one shows any more.
            scene.prepared.remove(id);
        }
    }
    for item in &changed_mesh {
        upsert(scene, &meshes, &mut sent_now, item);
    }
    // Entities that dropped the marker this frame are traced again (if they still have a mesh).
    ready.extend(opted_in.read());
    for e in ready {
        if let Ok(item) = all.get(e)
            && !sent_now.contains(&e)
        {
            upsert(scene, &meshes, &mut sent_now, item);
        }
    }
    // Entities whose leader's copy stopped: each becomes a leader or follows another.
    for e in std::mem::take(&mut scene.orphans) {
        if let Ok(item) = all.get(e) {
            upsert(scene, &meshes, &mut sent_now, item);
        }
    }
    for (e, gt) in &moved {
        // Into or out of a transform no group can take: traced again from scratch (or not).
        if scene.degenerate.contains(&e) == treelight_bvh::is_traceable_transform(&gt.affine()) {
            if !sent_now.contains(&e)
                && let Ok(item) = all.get(e)
            {
                upsert(scene, &meshes, &mut sent_now, item);
            }
            continue;
        }
        if let Some(job) = scene.copying.get_mut(&e) {
            // Not with the worker yet: it will get the latest transform with the triangles.
            job.transform = gt.affine();
        } else if let Some(f) = scene.followers.get_mut(&e) {
            f.transform = gt.affine();
        } else if !sent_now.contains(&e) && scene.traced.contains(&e) {
            scene.send(Command::Move {
                entity: e,
                transform: gt.affine(),
            });
        }
    }
    // Meshes nearest the (first active 3D) camera are copied, and so traced, first: a big
    // assembly fills the preview in from the front.
    scene.eye = cameras
        .iter()
        .filter(|(c, _)| c.is_active)
        .min_by_key(|(c, _)| c.order)
        .map(|(_, gt)| gt.translation());
    if scene.copying.len() > 1
        && let Some(eye) = scene.eye
    {
        let mut order: Vec<(f32, Entity)> = scene
            .copying
            .keys()
            .map(|&e| {
                let centre = bounds.get(e).map_or(Vec3::ZERO, |(gt, aabb)| {
                    gt.transform_point(aabb.map_or(Vec3::ZERO, |b| Vec3::from(b.center)))
                });
                (centre.distance_squared(eye), e)
            })
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        scene.copy_order = order.into_iter().map(|(_, e)| e).collect();
    } else {
        scene.copy_order = scene.copying.keys().copied().collect();
    }
    copy_meshes(scene, &meshes);
}

/// Copies meshes out of the world until the frame's budget is spent (at least one chunk), and sends
/// the complete ones to the worker.
fn copy_meshes(scene: &mut SceneBvh, meshes: &Assets<Mesh>) {
    if scene.copying.is_empty() {
        return;
    }
    let share = scene.last_frame.mul_f32(scene.share.clamp(0.0, 1.0));
    let deadline = Instant::now() + scene.budget.max(share);
    let order = std::mem::take(&mut scene.copy_order);
    // Meshes handed over whole go to the worker at once, nearest first, whatever the budget; one
    // whose sizes are not its asset's is copied as any other (the copy starts over).
    let mut finished: Vec<(Entity, Result<(), MeshSkip>)> = Vec::new();
    for &e in &order {
        if let Some(job) = scene.copying.get_mut(&e)
            && job.handed_over
        {
            if meshes
                .get(job.mesh)
                .is_some_and(|m| job.copy.is_whole_copy_of(m))
            {
                finished.push((e, Ok(())));
                scene.handed_over += 1;
            } else {
                job.handed_over = false;
            }
        }
    }
    'jobs: for &e in &order {
        let Some(job) = scene.copying.get_mut(&e) else {
            continue;
        };
        if job.handed_over {
            // Finished above.
            continue;
        }
        let copy = &mut job.copy;
        let Some(mesh) = meshes.get(job.mesh) else {
            // The asset went away; a new handle or a despawn will follow.
            finished.push((e, Err(MeshSkip::NoPositions)));
            continue;
        };
        loop {
            let before = copy.copied();
            match copy.copy(mesh, COPY_CHUNK) {
                Ok(true) => {
                    finished.push((e, Ok(())));
                    break;
                }
                // Its destination is still being made: the next mesh meanwhile.
                Ok(false) if copy.copied() == before => break,
                Ok(false) => {}
                Err(why) => {
                    finished.push((e, Err(why)));
                    break;
                }
            }
            if Instant::now() >= deadline {
                break 'jobs;
            }
        }
        if Instant::now() >= deadline {
            break;
        }
    }
    for (e, result) in finished {
        let Some(job) = scene.copying.remove(&e) else {
            continue;
        };
        let waiting = scene.followers_of(job.mesh);
        match result {
            Ok(()) => {
                scene.remember_mesh(e, job.mesh);
                if scene.release {
                    scene.to_release.push(job.mesh);
                }
                scene.send(Command::Copied {
                    entity: e,
                    mesh: job.mesh,
                    name: job.name,
                    copy: Box::new(job.copy),
                    transform: job.transform,
                    eye: scene.eye,
                    sent: job.started,
                });
                for f in waiting {
                    if let Some(follower) = scene.followers.remove(&f) {
                        scene.send_instance(f, follower);
                    }
                }
            }
            Err(why) => {
                warn!("entity {e} ('{}') is not traced: {why}", job.name);
                scene.untrace(e);
                for f in waiting {
                    if let Some(follower) = scene.followers.remove(&f) {
                        warn!("entity {f} ('{}') is not traced: {why}", follower.name);
                        scene.untrace(f);
                    }
                }
            }
        }
    }
}

/// Frees the vertex data of the meshes sent to the worker this frame
/// ([`SceneBvhConfig::release_traced_meshes`]). Untracked: a freed mesh is not a changed one, so
/// nothing (this plugin included) takes it for new geometry.
fn release_traced_meshes(mut scene: ResMut<SceneBvh>, mut meshes: ResMut<Assets<Mesh>>) {
    let scene = &mut *scene;
    for id in scene.to_release.drain(..) {
        if let Some(mesh) = meshes.get_mut_untracked(id)
            && mesh.take_gpu_data().is_ok()
        {
            scene.released += 1;
        }
    }
}

/// Sends a mesh entity's current triangles, or a removal if it is hidden or untraceable, or parks it
/// until its asset loads.
fn upsert(
    scene: &mut SceneBvh,
    meshes: &Assets<Mesh>,
    sent_now: &mut HashSet<Entity>,
    (e, m, gt, vis, name): MeshEntity,
) {
    sent_now.insert(e);
    scene.drop_copy(e);
    scene.followers.remove(&e);
    // Whatever the worker holds of `e` is replaced (or removed) by what follows.
    scene.forget_mesh(e);
    if vis.is_some_and(|v| !v.get()) {
        scene.untrace(e);
        return;
    }
    // Never traced, and so never the holder of a mesh another entity would share.
    if !treelight_bvh::is_traceable_transform(&gt.affine()) {
        scene.untrace(e);
        scene.degenerate.insert(e);
        return;
    }
    scene.degenerate.remove(&e);
    let label = name.map_or_else(|| format!("{e}"), |n| n.as_str().to_owned());
    let Some(mesh) = meshes.get(&m.0) else {
        scene.waiting.entry(m.0.id()).or_default().push(e);
        return;
    };
    let follower = Follower {
        mesh: m.0.id(),
        name: label.clone(),
        transform: gt.affine(),
        started: Instant::now(),
    };
    if scene.mesh_senders.contains_key(&follower.mesh) {
        // Another entity of this mesh is traced: share its triangles.
        scene.send_instance(e, follower);
        return;
    }
    if scene.copying.values().any(|job| job.mesh == follower.mesh) {
        // Another entity's copy of this mesh is under way: wait for it rather than copy twice.
        scene.traced.insert(e);
        scene.followers.insert(e, follower);
        return;
    }
    let prepared = scene.prepared.remove(&follower.mesh);
    let handed_over = prepared.is_some();
    match prepared.map_or_else(|| GeometryCopy::new(mesh), Ok) {
        Ok(copy) => {
            // Traced from now on: a removal must reach the worker even if the copy never finishes.
            scene.traced.insert(e);
            scene.copying.insert(
                e,
                MeshCopy {
                    mesh: m.0.id(),
                    name: label,
                    transform: gt.affine(),
                    started: Instant::now(),
                    copy,
                    handed_over,
                },
            );
        }
        Err(why) => {
            warn!("entity {e} ('{label}') is not traced: {why}");
            scene.untrace(e);
        }
    }
}

/// Copies the worker's figures into the resource.
fn publish(mut scene: ResMut<SceneBvh>) {
    // The worker holds its idle work while meshes are still being copied to it.
    scene
        .shared
        .filling
        .store(scene.is_copying(), Ordering::Release);
    let version = scene.shared.version.load(Ordering::Acquire);
    let mut stats = *scene.shared.stats.lock().unwrap_or_else(|p| p.into_inner());
    stats.pending =
        scene.shared.pending.load(Ordering::Acquire) + scene.copying.len() + scene.followers.len();
    if scene.version != version || scene.stats != stats {
        scene.version = version;
        scene.stats = stats;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use treelight_bvh::Triangle;

    fn quad(z: f32) -> Vec<Triangle> {
        let v = |x: f32, y: f32| Vec3::new(x, y, z);
        vec![
            Triangle::new(v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0)),
            Triangle::new(v(0.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)),
        ]
    }

    #[test]
    fn shared_meshes_take_their_triangles_from_a_current_holder() {
        let mut world = World::new();
        let [a, b, c] = [(); 3].map(|_| world.spawn_empty().id());
        let mesh = AssetId::<Mesh>::default();
        let mut tree = SceneTree::default();
        let g = tree
            .bvh
            .insert_group(&quad(0.0), Affine3A::IDENTITY, false)
            .unwrap();
        tree.bind(a, g, Arc::default(), mesh);
        // The order proptest found: `a` is sent again as an instance before the first copy of its
        // mesh arrives, so it must share its own triangles.
        tree.share(a, mesh, Affine3A::from_translation(Vec3::X))
            .unwrap();
        tree.share(b, mesh, Affine3A::from_translation(Vec3::Y))
            .unwrap();
        assert_eq!(tree.bvh.triangle_count(), 2);
        assert_eq!(tree.entity_groups.len(), 2);
        tree.bvh.validate().unwrap();
        // The mesh edited: `a` brings new triangles; `b` still holds the old ones, and a new copy
        // shares `a`'s.
        let fresh = tree
            .bvh
            .insert_group(&quad(5.0), Affine3A::IDENTITY, false)
            .unwrap();
        tree.remove_entity(a);
        tree.bind(a, fresh, Arc::default(), mesh);
        tree.supersede(a, mesh);
        tree.share(c, mesh, Affine3A::IDENTITY).unwrap();
        let shared =
            |t: &SceneTree, e: Entity| t.bvh.shared_triangles(t.groups_of(e)[0]).unwrap().to_vec();
        assert_eq!(shared(&tree, c), shared(&tree, a));
        assert_ne!(shared(&tree, c), shared(&tree, b));
        tree.bvh.validate().unwrap();
    }
}
