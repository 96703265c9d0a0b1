//! Hands the memory a large change freed back to the system. glibc's allocator keeps freed memory
//! in its per-thread arenas, so after an import (its parse, the worker's temporaries and idle-time
//! rebuilds, the upload's staging) the editor stays as large as at the import's peak. Once the
//! scene's memory has moved by at least [`TRIM_AFTER`] bytes, or its worker has rebuilt meshes,
//! or the path tracer's kernel has been compiled (with a cold shader cache llvmpipe's compiler
//! leaves 300 to 600 MiB freed in the heap), and then the scene has held still with nothing
//! pending, a background thread asks glibc to return its free pages (`malloc_trim`), which keeps
//! allocation as fast as before; a different global allocator returns memory too, but copies where
//! glibc's `realloc` remaps, and a growing BVH reallocates its arrays many times. Blocks of
//! 128 KiB and more never wait for a trim: [`tune_malloc`] keeps them in mappings of their own.

use bevy::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use treelight_render::PathTracerStats;
use treelight_scene::SceneBvh;

use crate::editor::core::resident::resident_bytes;
use crate::editor::core::rest::{Activity, ActivitySources};

/// How much the scene's own memory (the tree, its shading records, the path tracer's buffers) must
/// have changed since the last trim, either way, for another.
pub const TRIM_AFTER: u64 = 32 << 20;

/// The shortest time between two looks at the scene's figures.
const LOOK_EVERY: Duration = Duration::from_secs(1);

/// The same while new geometry is on its way into the tree, so that trims can keep up with
/// [`TRIM_EVERY_WHILE_FILLING`] (a look costs a few atomic reads).
const LOOK_EVERY_WHILE_FILLING: Duration = Duration::from_millis(250);

/// While the scene keeps changing (the worker's idle-time rebuilds of a large import take
/// minutes), the time between trims.
const TRIM_EVERY_WHILE_BUSY: Duration = Duration::from_secs(10);

/// While new geometry is on its way into the tree (an import's fill), the time between trims:
/// what the fill has freed (the parse's buffers, the meshes' copies once the worker has built
/// them, a headless render's mesh data) would otherwise stay resident until it ends, at the
/// process's peak. An 8M-triangle fill frees about 60 MiB a second that a trim gives back (10 to
/// 30 ms of the allocator's locks a trim), so every 2 s held 120 to 170 MiB at the fill's end.
const TRIM_EVERY_WHILE_FILLING: Duration = Duration::from_millis(500);

/// Returns freed memory to the system after large changes to the scene (Linux with glibc; elsewhere
/// the system's allocator is left to its own policy and the plugin adds nothing).
pub struct HeapTrimPlugin;

impl Plugin for HeapTrimPlugin {
    fn build(&self, app: &mut App) {
        if cfg!(all(target_os = "linux", target_env = "gnu")) {
            app.init_resource::<HeapTrim>()
                .add_systems(Last, trim_after_large_changes.in_set(ActivitySources));
        }
    }
}

/// What the last trim saw, and whether one is running.
#[derive(Resource, Default)]
pub struct HeapTrim {
    /// The scene's figures at the last trim.
    trimmed_at: SceneMemory,
    /// The scene's figures at the last look.
    seen: SceneMemory,
    /// When the figures were last looked at.
    looked: Option<Instant>,
    /// When the last trim started.
    trimmed: Option<Instant>,
    /// Set while a trim runs on its thread.
    running: Arc<AtomicBool>,
}

/// What a trim is decided on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct SceneMemory {
    /// The tree's, its shading's and the path tracer's buffers' bytes.
    bytes: u64,
    /// Meshes the worker has rebuilt in idle time so far (each rebuild frees a mesh's old tree).
    rebuilt: u64,
    /// Bytes the path tracer has uploaded so far: each upload passes through staging memory that
    /// is freed once the GPU has it (the worker's idle-time bakes and rebuilds upload much).
    uploaded: u64,
    /// Waits for a trace kernel that have ended
    /// ([`treelight_render::PathTracerFigures::kernels_prepared`]).
    kernels: u64,
}

impl HeapTrim {
    /// Whether to trim now, the scene being `now` with `pending` changes on its worker (new
    /// geometry among them when `filling`), the last trim `since` ago: when its bytes have moved
    /// by [`TRIM_AFTER`], or as much was uploaded, or meshes were rebuilt since the last trim,
    /// and then: while a fill goes on, the last trim [`TRIM_EVERY_WHILE_FILLING`] ago; else with
    /// nothing pending, and nothing changed since the last look (the change's temporaries, the
    /// uploads' staging among them, are gone) or the last trim [`TRIM_EVERY_WHILE_BUSY`] ago.
    /// Edits (a part dragged for seconds) so trim no more often than before: a trim takes the
    /// allocator's locks for up to tens of milliseconds. Remembers a trim it answers yes to.
    fn due(
        &mut self,
        now: SceneMemory,
        pending: usize,
        filling: bool,
        since: Option<Duration>,
    ) -> bool {
        let moving = std::mem::replace(&mut self.seen, now) != now;
        let wait = if filling {
            TRIM_EVERY_WHILE_FILLING
        } else if pending > 0 {
            return false;
        } else if moving {
            TRIM_EVERY_WHILE_BUSY
        } else {
            Duration::ZERO
        };
        if !self.worth(now) || since.is_some_and(|t| t < wait) {
            return false;
        }
        self.trimmed_at = now;
        true
    }
}

impl HeapTrim {
    /// Whether the scene, being `now`, has moved far enough from the last trim for another.
    fn worth(&self, now: SceneMemory) -> bool {
        let last = self.trimmed_at;
        now.bytes.abs_diff(last.bytes) >= TRIM_AFTER
            || now.uploaded.saturating_sub(last.uploaded) >= TRIM_AFTER
            || now.rebuilt != last.rebuilt
            || now.kernels != last.kernels
    }
}

/// Looks at the scene's memory once a [`LOOK_EVERY`] and starts a trim on its own thread when
/// [`HeapTrim::due`] (and none is running).
fn trim_after_large_changes(
    mut trim: ResMut<HeapTrim>,
    scene: Res<SceneBvh>,
    tracer: Res<PathTracerStats>,
    mut activity: Option<ResMut<Activity>>,
) {
    let filling = scene.is_filling();
    let look_every = if filling {
        LOOK_EVERY_WHILE_FILLING
    } else {
        LOOK_EVERY
    };
    if trim.looked.is_some_and(|t| t.elapsed() < look_every) {
        return;
    }
    trim.looked = Some(Instant::now());
    let stats = scene.stats();
    let figures = tracer.figures();
    let now = SceneMemory {
        bytes: (stats.tree_bytes + stats.shading_bytes) as u64 + figures.scene_buffer_bytes,
        rebuilt: stats.meshes_refined,
        uploaded: figures.total_upload_bytes,
        kernels: figures.kernels_prepared,
    };
    let since = trim.trimmed.map(|t| t.elapsed());
    if trim.running.load(Ordering::Acquire) || !trim.due(now, stats.pending, filling, since) {
        // A trim worth making waits for the scene to hold still: a resting editor looks again.
        if trim.worth(now)
            && let Some(activity) = activity.as_mut()
        {
            activity.due_in(look_every);
        }
        return;
    }
    trim.trimmed = Some(Instant::now());
    trim.running.store(true, Ordering::Release);
    let running = trim.running.clone();
    let started = std::thread::Builder::new()
        .name("treelight heap trim".into())
        .spawn(move || {
            let before = resident_bytes();
            let started = Instant::now();
            release_free_memory();
            if let (Some(before), Some(after)) = (before, resident_bytes()) {
                info!(
                    "returned {} MiB of freed memory to the system in {:.0} ms ({} MiB resident)",
                    before.saturating_sub(after) >> 20,
                    started.elapsed().as_secs_f64() * 1e3,
                    after >> 20
                );
            }
            running.store(false, Ordering::Release);
        });
    if started.is_err() {
        trim.running.store(false, Ordering::Release);
    }
}

/// The most malloc arenas glibc keeps: by default up to eight per core, one per thread that found
/// the others busy. Memory freed in one arena serves only the threads that allocate there, so with
/// the scene worker's pool, the refinement thread and Bevy's task pools each keeping arenas of their
/// own, a large import's rebuilds left hundreds of MiB resident in arenas no thread reused.
pub const MALLOC_ARENAS: i32 = 2;

/// The smallest block glibc's allocator serves from a mapping of its own (`M_MMAP_THRESHOLD`),
/// which goes back to the system the moment it is freed: glibc's own starting value, held there.
/// Left to itself glibc raises the threshold to the size of each mapped block freed, up to 32
/// MiB, so after the first large free the blocks of an import's fill and of the worker's
/// idle-time rebuilds (the meshes' copies, the builds' temporaries, the uploads' staging: tens of
/// KiB to tens of MiB each) come from the arenas and stay resident once freed until the next trim.
/// Held, with trims twice a second during a fill, the 8M fill's peak came down by 40 to 200 MiB.
pub const MALLOC_MMAP_THRESHOLD: i32 = 128 << 10;

/// The most blocks glibc keeps in mappings of their own at once (`M_MMAP_MAX`); past it, blocks
/// come from the arenas as before. Its default (65,536) is above the kernel's limit of mappings a
/// process may hold (65,530 by default), which Mesa's, the threads' and the files' mappings share:
/// a scene of many large meshes must not take them all.
pub const MALLOC_MMAP_MAX: i32 = 16_384;

/// Sets glibc's allocator up for the editor's work (Linux with glibc; elsewhere nothing): at most
/// [`MALLOC_ARENAS`] arenas, and blocks of [`MALLOC_MMAP_THRESHOLD`] bytes or more in mappings of
/// their own, up to [`MALLOC_MMAP_MAX`] of them. Call first thing in `main`, before any thread
/// starts; `MALLOC_ARENA_MAX`, `MALLOC_MMAP_THRESHOLD_` or `MALLOC_MMAP_MAX_` in the environment,
/// when set, still decides its own.
pub fn tune_malloc() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    for (variable, parameter, value) in [
        ("MALLOC_ARENA_MAX", libc::M_ARENA_MAX, MALLOC_ARENAS),
        (
            "MALLOC_MMAP_THRESHOLD_",
            libc::M_MMAP_THRESHOLD,
            MALLOC_MMAP_THRESHOLD,
        ),
        ("MALLOC_MMAP_MAX_", libc::M_MMAP_MAX, MALLOC_MMAP_MAX),
    ] {
        if std::env::var_os(variable).is_none() {
            // SAFETY: mallopt only sets the allocator's parameters; called before other threads
            // exist.
            unsafe {
                libc::mallopt(parameter, value);
            }
        }
    }
}

/// Returns the allocator's free pages to the system.
fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only takes the allocator's own locks; any thread may call it.
    unsafe {
        libc::malloc_trim(0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MIB: u64 = 1 << 20;
    /// A last trim a moment ago.
    const SOON: Option<Duration> = Some(Duration::from_millis(1500));

    fn at(mib: u64, rebuilt: u64) -> SceneMemory {
        SceneMemory {
            bytes: mib * MIB,
            rebuilt,
            uploaded: 0,
            kernels: 0,
        }
    }

    /// `scene` with `mib` uploaded since the start.
    fn with_uploads(scene: SceneMemory, mib: u64) -> SceneMemory {
        SceneMemory {
            uploaded: mib * MIB,
            ..scene
        }
    }

    #[test]
    fn a_trim_waits_for_a_large_change_to_hold_still_with_nothing_pending() {
        let mut t = HeapTrim::default();
        // An import's memory growing: no trim while it moves.
        assert!(!t.due(at(100, 0), 0, false, SOON));
        assert!(!t.due(at(400, 0), 3, false, SOON));
        // Still, but the worker has work pending.
        assert!(!t.due(at(400, 0), 3, false, SOON));
        // Still and done: trimmed once.
        assert!(t.due(at(400, 0), 0, false, SOON));
        assert!(!t.due(at(400, 0), 0, false, SOON));
        // A small edit does not trim again.
        assert!(!t.due(at(410, 0), 0, false, SOON));
        assert!(!t.due(at(410, 0), 0, false, SOON));
        // Idle-time rebuilds do, once they stop.
        assert!(!t.due(at(410, 5), 0, false, SOON));
        assert!(!t.due(at(410, 9), 0, false, SOON));
        assert!(t.due(at(410, 9), 0, false, SOON));
        // A large deletion does, once it holds still.
        assert!(!t.due(at(100, 9), 0, false, SOON));
        assert!(t.due(at(100, 9), 0, false, SOON));
        assert!(!t.due(at(100, 9), 0, false, SOON));
        // Uploads of re-laid records, the scene's size unchanged: once they stop, and only when
        // they came to much.
        let uploaded = |mib| with_uploads(at(100, 9), mib);
        assert!(!t.due(uploaded(10), 0, false, SOON));
        assert!(!t.due(uploaded(10), 0, false, SOON));
        assert!(!t.due(uploaded(60), 0, false, SOON));
        assert!(t.due(uploaded(60), 0, false, SOON));
    }

    #[test]
    fn a_compiled_kernel_is_trimmed_after_once_the_scene_holds_still() {
        let mut t = HeapTrim::default();
        assert!(t.due(at(100, 0), 0, false, None));
        let compiled = |n: u64| SceneMemory {
            kernels: n,
            ..at(100, 0)
        };
        // The scene unchanged, a kernel's compile ended: trimmed once it holds still.
        assert!(!t.due(compiled(1), 0, false, SOON));
        assert!(t.due(compiled(1), 0, false, SOON));
        assert!(!t.due(compiled(1), 0, false, SOON));
        // Not while the worker has work pending.
        assert!(!t.due(compiled(2), 0, false, SOON));
        assert!(!t.due(compiled(2), 1, false, SOON));
        assert!(t.due(compiled(2), 0, false, SOON));
    }

    #[test]
    fn a_scene_busy_for_long_is_trimmed_every_while() {
        let mut t = HeapTrim::default();
        let long = Some(TRIM_EVERY_WHILE_BUSY);
        // Rebuilds going on: not while the last trim is recent, then once it is not.
        assert!(!t.due(at(400, 1), 0, false, SOON));
        assert!(!t.due(at(400, 2), 0, false, SOON));
        assert!(t.due(at(400, 3), 0, false, long));
        assert!(!t.due(at(400, 4), 0, false, SOON));
        // Nor with the worker's queue full.
        assert!(!t.due(at(400, 5), 2, false, long));
        // The first trim has no last one to wait for.
        assert!(HeapTrim::default().due(at(400, 1), 0, false, None));
    }

    #[test]
    fn a_fill_is_trimmed_twice_a_second_and_edits_no_more_than_before() {
        let mut t = HeapTrim::default();
        let every = Some(TRIM_EVERY_WHILE_FILLING);
        // A trim during the fill a moment ago.
        let soon = Some(TRIM_EVERY_WHILE_FILLING / 2);
        assert!(t.due(at(100, 0), 0, false, None));
        // Meshes on their way into the tree: not while the last trim is recent.
        assert!(!t.due(at(200, 0), 40, true, soon));
        assert!(!t.due(at(300, 0), 30, true, soon));
        // Then every while, however much is still pending.
        assert!(t.due(at(400, 0), 20, true, every));
        assert!(!t.due(at(500, 0), 10, true, soon));
        assert!(t.due(at(600, 0), 5, true, every));
        // Not for a fill too small to be worth one.
        assert!(!t.due(at(610, 0), 5, true, every));
        // Once it is over and holds still: the rest of what it freed.
        assert!(!t.due(at(650, 0), 0, false, SOON));
        assert!(t.due(at(650, 0), 0, false, SOON));
        // Edits with moves pending (a part dragged), no new geometry: not while they go on,
        // however long since the last trim.
        let uploaded = |mib| with_uploads(at(650, 0), mib);
        assert!(!t.due(uploaded(100), 2, false, every));
        assert!(!t.due(uploaded(200), 1, false, Some(TRIM_EVERY_WHILE_BUSY)));
        assert!(!t.due(uploaded(300), 1, false, every));
    }
}
