//! The paper's use case in the document's headless app (the editor's command path and
//! `SceneBvhPlugin`; no window, UI or renderer): a generated assembly of bumpy tiles (default 400
//! parts of 30,258 triangles, 12.1M; `PARTSxROWS` sets it) imported as the editor imports a file
//! (parsed on a background task, then one import command), then one part moved and the move undone.
//!
//! Times: the parse (from the request until the import's objects are in the world), then from the
//! parse's end until the tree holds its first triangles and all of them; for a 60-frame gizmo drag
//! of one part (at 60 Hz: previews, then the commit) the main thread's frame times, and the time
//! from the last drag event until a ray cast on the tree finds the part where it was dropped; for
//! the undo of that move, the time until the ray finds it back in its place. Two moves and undos:
//! the first takes a still part out of the baked tree.
//!
//! Run: `cargo bench -p treelight_document --bench large_edits --profile dev [-- PARTSxROWS]`.
//! The 12.1M default needs about 10 GB and minutes.

use bevy::math::Ray3d;
use bevy::prelude::*;
use std::time::{Duration, Instant};
use treelight_document::edit::history::{EditRequest, EditRequests};
use treelight_document::import::parse::PendingImports;
use treelight_document::values::object::SceneObject;
use treelight_scene::{SceneBvh, SceneBvhConfig};

#[path = "../tests/support/assembly.rs"]
mod assembly;
mod support {
    pub mod drag;
}
use support::drag::{FRAME, median};

/// Runs frames at 60 Hz until `done` holds; the time it took.
fn until(app: &mut App, what: &str, mut done: impl FnMut(&mut App) -> bool) -> Duration {
    let start = Instant::now();
    loop {
        let t = Instant::now();
        app.update();
        if done(app) {
            return start.elapsed();
        }
        assert!(start.elapsed() < Duration::from_secs(900), "never: {what}");
        std::thread::sleep(FRAME.saturating_sub(t.elapsed()));
    }
}

/// The distance at which a ray straight down from 5 units above `(x, z)` meets `part`, if it meets
/// it first.
fn part_at(app: &App, part: Entity, x: f32, z: f32) -> Option<f32> {
    let ray = Ray3d::new(Vec3::new(x, 5.0, z), Dir3::NEG_Y);
    // Waits for the worker's write lock, if it holds it: that is part of the time.
    let scene = app.world().resource::<SceneBvh>();
    let hit = treelight_scene::cast_on(&scene.read_blocking(), ray)?;
    (hit.entity == part).then_some(hit.distance)
}

/// Frames at 60 Hz from now until `done` holds, checked before each: 0 when it holds already.
fn frames_until(app: &mut App, what: &str, mut done: impl FnMut(&mut App) -> bool) -> u32 {
    let mut frames = 0;
    while !done(app) {
        let t = Instant::now();
        app.update();
        frames += 1;
        assert!(frames < 60 * 600, "never: {what}");
        std::thread::sleep(FRAME.saturating_sub(t.elapsed()));
    }
    frames
}

fn main() {
    let (parts, rows) = std::env::args()
        .skip(1)
        .find_map(|a| {
            let (p, r) = a.split_once('x')?;
            Some((p.parse().ok()?, r.parse().ok()?))
        })
        .unwrap_or((400, 123));
    let dir = std::env::temp_dir().join(format!("treelight-large-edits-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (file, triangles) = assembly::generated_assembly(&dir, parts, rows);
    let triangles = triangles as u32;

    let mut app = treelight_document::app::headless_app(SceneBvhConfig::default());
    app.update();
    let start = Instant::now();
    app.world_mut()
        .resource_mut::<PendingImports>()
        .start(file.clone());
    let parse = until(&mut app, "the import's objects", |app| {
        let world = app.world_mut();
        world
            .query_filtered::<(), With<SceneObject>>()
            .iter(world)
            .count()
            > parts
    });
    let first = until(&mut app, "the first triangles", |app| {
        app.world().resource::<SceneBvh>().stats().triangles > 0
    });
    let all = first
        + until(&mut app, "every triangle", |app| {
            app.world().resource::<SceneBvh>().stats().triangles == triangles
        });
    let settled = until(&mut app, "the idle tree", |app| {
        app.world().resource::<SceneBvh>().is_idle()
    });
    println!(
        "{parts} parts of {} triangles, {triangles} in all ({:.0} MB of glTF and .bin)\n",
        2 * rows * rows,
        (std::fs::metadata(&file).unwrap().len()
            + std::fs::metadata(dir.join("assembly.bin")).unwrap().len()) as f64
            / 1e6
    );
    println!("| step | time (s) |");
    println!("|---|---|");
    println!(
        "| request to objects in the world (parse) | {:.2} |",
        parse.as_secs_f64()
    );
    println!(
        "| parse's end to first triangles in the tree | {:.2} |",
        first.as_secs_f64()
    );
    println!(
        "| parse's end to every triangle in the tree | {:.2} |",
        all.as_secs_f64()
    );
    println!(
        "| then until the worker is idle (bakes, refinements) | {:.1} |",
        settled.as_secs_f64()
    );
    println!(
        "| request to idle | {:.1} |\n",
        start.elapsed().as_secs_f64()
    );

    // The middle part: a tile 1 unit wide at (gx, 0, -gz) of a grid 1.2 apart.
    let p = parts / 2;
    let side = (parts as f32).sqrt().ceil() as usize;
    let (x, z) = (
        (p % side) as f32 * 1.2 + 0.5,
        -((p / side) as f32 * 1.2) + 0.5,
    );
    let name = format!("part {p}");
    let (part, id) = {
        let world = app.world_mut();
        let mut q = world.query::<(Entity, &Name, &treelight_document::values::object::SceneId)>();
        let (e, _, id) = q.iter(world).find(|(_, n, _)| n.as_str() == name).unwrap();
        (e, *id)
    };
    let rest = part_at(&app, part, x, z).unwrap_or_else(|| panic!("the ray misses {name}"));
    let start_transform = *app.world().get::<Transform>(part).unwrap();
    println!(
        "| {name} ({} triangles) | frame median (ms) | frame max (ms) | frames after the drag's last (the commit) until the tree has the part where dropped | ms from the commit's request | frames after the undo's until the part is back | ms from the undo's request |",
        2 * rows * rows
    );
    println!("|---|---|---|---|---|---|---|");
    for run in ["first move", "second move"] {
        let at = |k: u32| {
            let mut t = start_transform;
            t.translation.y += 3.0 * k as f32 / 60.0;
            t
        };
        let support::drag::DragFrames { frame_ms, commit } =
            support::drag::drag(&mut app, id, 60, at, |_| {});
        // Lifted 3 units (the last preview 2.95).
        let dropped = frames_until(&mut app, "the part where dropped", |app| {
            part_at(app, part, x, z).is_some_and(|d| (d - (rest - 3.0)).abs() < 0.01)
        });
        let dropped_ms = commit.elapsed().as_secs_f64() * 1e3;
        let max = frame_ms.iter().copied().fold(0.0, f64::max);
        let frame_median = median(frame_ms);
        app.world_mut()
            .resource_mut::<EditRequests>()
            .0
            .push(EditRequest::Undo);
        let undo = Instant::now();
        app.update();
        let back = frames_until(&mut app, "the part back", |app| {
            part_at(app, part, x, z).is_some_and(|d| (d - rest).abs() < 0.01)
        });
        println!(
            "| {run} | {frame_median:.2} | {max:.2} | {dropped} | {dropped_ms:.0} | {back} | {:.0} |",
            undo.elapsed().as_secs_f64() * 1e3
        );
        until(&mut app, "the idle tree", |app| {
            app.world().resource::<SceneBvh>().is_idle()
        });
    }
    std::fs::remove_dir_all(&dir).ok();
}
