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

//! The crate's layers, lowest first: `types` (the settings, the tree, rays, meshes as the worker
//! takes them), `worker` (the thread that keeps the tree), `world` (the resource, the systems that
//! follow the world, picking). This file holds the plugin, which starts the worker.

mod types;
mod worker;
mod world;

/// The engine's named policies, which [`SceneBvhConfig::preset`] takes.
pub use treelight_bvh::Preset;
pub use types::config::SceneBvhConfig;
pub use types::hit::{SceneHit, cast_on, cast_on_filtered};
pub use types::mesh::{
    GeometryCopy, MeshGeometry, MeshPositions, MeshSkip, mesh_geometry, mesh_triangles,
};
pub use types::shading::{MeshShading, ShadingVertices};
pub use types::tree::{SceneChanges, SceneStats, SceneTree};
pub use types::{packed, priority};
pub use world::picking::SceneBvhPickingPlugin;
pub use world::scene_bvh::SceneBvh;
pub use world::track::NotTraced;

use bevy::prelude::*;
use bevy::transform::TransformSystems;
use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize};
use std::sync::{Arc, Mutex, RwLock};
use std::time::Duration;
use treelight_bvh::Bvh;
use types::panics::panic_message;
use worker::main_loop::{Shared, WorkerConfig};
use world::track::{publish, release_traced_meshes, track_world};

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
                    let run =
                        || worker::main_loop::run(worker_shared, rx, cfg, background.as_ref());
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

/// The plugin's main-thread systems (in `PostUpdate`, after transform propagation): turning the
/// frame's world changes into worker commands, and publishing the worker's figures. Order against it
/// to see this frame's [`SceneBvh`] figures, or to measure what the plugin costs a frame.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SceneBvhSystems;
