//! Starting the worker: the state it shares with the main thread, its thread and its two pools.

use crate::types::config::SceneBvhConfig;
use crate::types::panics::panic_message;
use crate::types::priority;
use crate::types::tree::{SceneStats, SceneTree};
use crate::worker::main_loop::{Command, Shared, WorkerConfig, run};
use bevy::log::error;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, RwLock};
use treelight_bvh::Bvh;

/// Starts the worker thread with an empty tree: the state it shares, and where to send it
/// commands.
pub(crate) fn start_worker(config: &SceneBvhConfig) -> (Arc<Shared>, Sender<Command>) {
    let policy = config.preset.policy();
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
        bake_after: config.bake_after,
        idle_tick: config.idle_tick,
        idle_updates: policy.idle,
        chunks: config.chunks,
        nice: config.worker_nice,
    };
    let worker_threads = config.worker_threads;
    let fill_nice = config.fill_nice;
    std::thread::Builder::new()
        .name("treelight-scene-bvh".into())
        .spawn(move || {
            // The worker's parallel builds run on a pool of its own at the fill's priority, its
            // background work on a thread of its own lower down (the pools' threads take their
            // nice from the app's, so both are built before this thread lowers itself).
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
            // A bug in the worker stops the tree's updates, not the app: the panic is kept for
            // the app to report (SceneBvh::worker_failure).
            let shared = worker_shared.clone();
            let ran = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                let work = || run(worker_shared, rx, cfg, background.as_ref());
                match &fill {
                    Some(pool) => pool.install(work),
                    None => work(),
                }
            }));
            if let Err(payload) = ran {
                let why = panic_message(&*payload);
                error!("the scene BVH worker stopped: {why}");
                *shared.failure.lock().unwrap_or_else(|p| p.into_inner()) = Some(why);
            }
        })
        .expect("cannot start the scene BVH worker thread");
    (shared, tx)
}
