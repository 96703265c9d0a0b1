//! What opening, saving and autosaving cost: the editor's import path and project files in its
//! headless app (the one `--save` runs; no window, UI or renderer).
//!
//! 1. Import of the sample assemblies and of a generated 1M-triangle assembly (100 parts of 10k
//!    triangles in a 10 × 10 grid): from the request until the tree holds the first part (what the
//!    next path-traced frame shows) and all of it; the main thread's frame time (median and 99th
//!    percentile, frames paced at 60 Hz) during the import, next to the same figures idle, and the
//!    99th percentile less the time the main thread waited, runnable, for a core. Each
//!    file is imported five times (fresh apps): the times are medians, the frames pooled. Then the
//!    same frame figures for the 2 s after each import, while still meshes are rebuilt.
//! 2. Save and autosave of that 100-part project after 100 moves: the save's time and size, and the
//!    main thread's share of an autosave (capturing the project; the write runs on its own thread).
//!
//! Run: `cargo bench -p treelight_document --bench projects` (release). Prints markdown tables.

use bevy::prelude::*;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::command::TransformValue;
use treelight_document::edit::history::EditRequest;
use treelight_document::edit::history::EditRequests;
use treelight_document::import::jobs::TracingImports;
use treelight_document::import::parse::PendingImports;
use treelight_document::project::capture::capture_project;
use treelight_document::project::capture::save_project;
use treelight_document::project::format::write_project;
use treelight_document::values::object::SceneId;
use treelight_scene::SceneBvhConfig;

#[path = "../tests/support/assembly.rs"]
mod assembly;
use assembly::generated_assembly;

const FRAME: Duration = Duration::from_micros(16_667);
/// Frames (at 60 Hz) followed after each import: 2 s.
const AFTER_FRAMES: usize = 120;
/// Imports of each file, their frames pooled.
const REPEATS: usize = 5;

fn shared(rel: &str) -> PathBuf {
    treelight_test_support::shared_scene(rel)
}

fn app() -> App {
    let mut app = treelight_document::app::headless_app(SceneBvhConfig::default());
    // The editor's camera looks at the grid's near corner, as after framing it.
    app.world_mut().spawn((
        Camera3d::default(),
        Transform::from_xyz(-3.0, 4.0, 4.0).looking_at(Vec3::new(3.0, 0.0, -3.0), Vec3::Y),
    ));
    app
}

/// How long the calling thread has waited, runnable, for a core since it started (Linux's
/// schedstat); zero where the system does not say.
fn runqueue_wait() -> Duration {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse().ok())
        .map_or(Duration::ZERO, Duration::from_nanos)
}

/// One frame's main-thread time, and the part of it the main thread spent runnable but waiting
/// for a core (the scheduler's, not the app's).
#[derive(Clone, Copy)]
struct Frame {
    spent: Duration,
    waited: Duration,
}

/// Runs one frame and paces it to 60 Hz.
fn frame(app: &mut App) -> Frame {
    let waited_before = runqueue_wait();
    let start = Instant::now();
    app.update();
    let spent = start.elapsed();
    let waited = runqueue_wait().saturating_sub(waited_before);
    if let Some(rest) = FRAME.checked_sub(spent) {
        std::thread::sleep(rest);
    }
    Frame { spent, waited }
}

fn spent(frames: &[Frame]) -> Vec<Duration> {
    frames.iter().map(|f| f.spent).collect()
}

/// The frames without their waits for a core.
fn on_core(frames: &[Frame]) -> Vec<Duration> {
    frames
        .iter()
        .map(|f| f.spent.saturating_sub(f.waited))
        .collect()
}

fn percentile(v: &[Duration], q: f64) -> f64 {
    let mut ms: Vec<f64> = v.iter().map(|d| d.as_secs_f64() * 1e3).collect();
    ms.sort_by(f64::total_cmp);
    ms[((ms.len() - 1) as f64 * q).round() as usize]
}

struct ImportFigures {
    triangles: u64,
    parts: usize,
    first: Duration,
    all: Duration,
    frames: Vec<Frame>,
    /// Frames in the seconds after the import.
    after: Vec<Frame>,
    /// Meshes rebuilt by full sweep by the end of those.
    refined: u64,
}

/// Imports `file` into a fresh app and follows it until the tree holds all of it.
fn import(file: &Path) -> (App, ImportFigures) {
    let mut app = app();
    for _ in 0..30 {
        frame(&mut app);
    }
    let started = Instant::now();
    app.world_mut()
        .resource_mut::<PendingImports>()
        .start(file.to_owned());
    let (mut first, mut frames, mut seen) = (None, Vec::new(), false);
    let (mut triangles, mut parts) = (0, 0);
    loop {
        frames.push(frame(&mut app));
        let jobs = app.world().resource::<TracingImports>();
        if let Some(job) = jobs.jobs.first() {
            seen = true;
            triangles = job.total();
            parts = job.meshes.len();
            if first.is_none() && job.traced > 0 {
                first = Some(started.elapsed());
            }
        } else if seen {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(600),
            "never imported"
        );
    }
    let all = started.elapsed();
    // Then the idle time after it, while the worker rebuilds the still meshes by full sweep.
    let after: Vec<Frame> = (0..AFTER_FRAMES).map(|_| frame(&mut app)).collect();
    let refined = app
        .world()
        .resource::<treelight_scene::SceneBvh>()
        .stats()
        .meshes_refined;
    (
        app,
        ImportFigures {
            triangles,
            parts,
            first: first.unwrap_or(all),
            all,
            frames,
            after,
            refined,
        },
    )
}

fn main() {
    let dir = std::env::temp_dir().join(format!("treelight-bench-projects-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (generated, _) = generated_assembly(&dir, 100, 71);

    // Idle frames for comparison: the default-sized app with nothing to do.
    let mut idle_app = app();
    let idle: Vec<Frame> = (0..300).map(|_| frame(&mut idle_app)).collect();
    println!("## Imports: until traced, and the main thread meanwhile\n");
    println!(
        "Idle frames (nothing imported): median {:.3} ms, p99 {:.3} ms; p99 less the main thread's wait for a core {:.3} ms.\n",
        percentile(&spent(&idle), 0.5),
        percentile(&spent(&idle), 0.99),
        percentile(&on_core(&idle), 0.99)
    );
    println!(
        "| file | parts | triangles | first part in the tree (ms) | all in the tree (ms) | frames | frame median (ms) | frame p99 (ms) | frame max (ms) | p99 less the wait for a core (ms) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let files = [
        (
            "FlightHelmet.gltf",
            shared("gltf/FlightHelmet/FlightHelmet.gltf"),
        ),
        ("CesiumMan.glb", shared("gltf/CesiumMan.glb")),
        ("pirate.glb (meshopt)", shared("gltf/pirate.glb")),
        ("sibenik.obj", shared("obj/sibenik.obj")),
        ("generated 100-part assembly", generated.clone()),
    ];
    let mut big = None;
    let mut afterwards = Vec::new();
    for (name, file) in files {
        // Each file is imported several times into fresh apps, its frames pooled, so that the
        // 99th percentile is not simply the worst frame of one import.
        let (mut firsts, mut alls, mut frames) = (Vec::new(), Vec::new(), Vec::new());
        let (mut after, mut refined) = (Vec::new(), 0);
        let (mut parts, mut triangles) = (0, 0);
        for _ in 0..REPEATS {
            // The previous app and its worker go first, so no two imports overlap.
            drop(big.take());
            std::thread::sleep(Duration::from_millis(300));
            let (app, f) = import(&file);
            firsts.push(f.first);
            alls.push(f.all);
            frames.extend(f.frames);
            after.extend(f.after);
            refined = f.refined;
            (parts, triangles) = (f.parts, f.triangles);
            big = Some(app);
        }
        println!(
            "| {name} | {parts} | {triangles} | {:.0} | {:.0} | {} | {:.3} | {:.3} | {:.3} | {:.3} |",
            percentile(&firsts, 0.5),
            percentile(&alls, 0.5),
            frames.len(),
            percentile(&spent(&frames), 0.5),
            percentile(&spent(&frames), 0.99),
            percentile(&spent(&frames), 1.0),
            percentile(&on_core(&frames), 0.99)
        );
        afterwards.push((name, refined, after));
    }
    println!(
        "\n## The {} s after each import: idle, while the worker rebuilds still meshes by full sweep\n",
        AFTER_FRAMES / 60
    );
    println!(
        "| file | meshes rebuilt | frames | frame median (ms) | frame p99 (ms) | frame max (ms) | p99 less the wait for a core (ms) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, refined, after) in &afterwards {
        println!(
            "| {name} | {refined} | {} | {:.3} | {:.3} | {:.3} | {:.3} |",
            after.len(),
            percentile(&spent(after), 0.5),
            percentile(&spent(after), 0.99),
            percentile(&spent(after), 1.0),
            percentile(&on_core(after), 0.99)
        );
    }

    // The 100-part project after 100 moves.
    let mut app = big.unwrap();
    let ids: Vec<SceneId> = {
        let world = app.world_mut();
        let mut q = world.query_filtered::<&SceneId, With<Mesh3d>>();
        q.iter(world).copied().collect()
    };
    for (k, id) in ids.iter().enumerate() {
        app.world_mut()
            .resource_mut::<EditRequests>()
            .0
            .push(EditRequest::Apply {
                command: EditCommand::SetTransform {
                    id: *id,
                    transform: TransformValue::from(Transform::from_xyz(k as f32, 1.0, 0.0)),
                },
                continuing: false,
            });
    }
    app.update();
    let project = dir.join("assembly.treelight");
    let mut saves = Vec::new();
    let mut captures = Vec::new();
    let mut writes = Vec::new();
    for _ in 0..20 {
        let t = Instant::now();
        save_project(app.world_mut(), &project).unwrap();
        saves.push(t.elapsed());
        let t = Instant::now();
        let (file, _) = capture_project(app.world_mut(), &project);
        captures.push(t.elapsed());
        let t = Instant::now();
        write_project(&dir.join("recovery.treelight"), &file).unwrap();
        writes.push(t.elapsed());
    }
    let size = std::fs::metadata(&project).unwrap().len();
    println!("\n## Save and autosave of the 100-part project after 100 moves\n");
    println!("| what | median (ms) | max (ms) |");
    println!("|---|---|---|");
    for (what, v) in [
        ("save (capture, write, rename)", &saves),
        ("autosave, main thread (capture)", &captures),
        ("autosave, its own thread (write, rename)", &writes),
    ] {
        println!(
            "| {what} | {:.3} | {:.3} |",
            percentile(v, 0.5),
            percentile(v, 1.0)
        );
    }
    println!(
        "\nProject file: {size} bytes for {} objects.",
        ids.len() + 1
    );
    std::fs::remove_dir_all(&dir).ok();
}
