//! What editing costs the main thread, and how soon the traced scene follows an edit: the editor's
//! command path and `SceneBvhPlugin` in a headless app (no window, no UI, no renderer).
//!
//! 1. A gizmo drag, as the viewport sends it: one live preview of a new transform per frame, then
//!    the commit. Per frame: the main-thread time of the whole frame (the edit systems, Bevy's
//!    transform propagation, the scene plugin) and of the scene plugin's systems alone; after the
//!    last drag event, the time until the tree holds the object at its new place (what the next
//!    path-traced frame uploads). For a 1M-triangle mesh and for a 100-part assembly (100 meshes of
//!    10k triangles under one root, the root dragged).
//! 2. Undo of a delete, and a duplicate, of the 1M-triangle mesh: the time from the request until
//!    the tree holds the triangles again (idle, every triangle in).
//!
//! Run: `cargo bench -p treelight_document --bench edit_frames` (release). Prints markdown tables.

use bevy::prelude::*;
use std::time::{Duration, Instant};
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::EditRequest;
use treelight_document::edit::history::EditRequests;
use treelight_document::values::object::SceneId;
use treelight_document::values::object::SceneIndex;
use treelight_document::values::object::SceneObject;
use treelight_scene::{SceneBvh, SceneBvhConfig, SceneBvhSystems};

mod support {
    pub mod drag;
}
use support::drag::{FRAME, median};

#[derive(Resource, Default)]
struct PluginClock {
    started: Option<Instant>,
    spent: Duration,
}

fn start_clock(mut c: ResMut<PluginClock>) {
    c.started = Some(Instant::now());
}

fn stop_clock(mut c: ResMut<PluginClock>) {
    if let Some(t) = c.started.take() {
        c.spent = t.elapsed();
    }
}

fn app() -> App {
    // The editor's own headless app (the one `--save` runs), timed around the scene plugin.
    let mut app = treelight_document::app::headless_app(SceneBvhConfig {
        preset: treelight_scene::Preset::Balanced,
        ..default()
    });
    app.init_resource::<PluginClock>().add_systems(
        PostUpdate,
        (
            start_clock.before(SceneBvhSystems),
            stop_clock.after(SceneBvhSystems),
        ),
    );
    app
}

/// Runs frames until the tree is idle with `triangles` triangles; returns the time taken.
fn settle(app: &mut App, triangles: u32) -> Duration {
    let start = Instant::now();
    loop {
        app.update();
        let scene = app.world().resource::<SceneBvh>();
        let stats = scene.stats();
        if scene.is_idle() && stats.triangles == triangles && stats.pending == 0 {
            return start.elapsed();
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "the tree did not settle"
        );
    }
}

/// Runs frames until the tree is idle with `triangles` triangles placed by `entities` entities.
fn settle_traced(app: &mut App, triangles: u32, entities: usize) -> Duration {
    let start = Instant::now();
    loop {
        app.update();
        let scene = app.world().resource::<SceneBvh>();
        if scene.is_idle()
            && scene.stats().triangles == triangles
            && scene.read_blocking().entity_groups.len() == entities
        {
            return start.elapsed();
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "the tree did not settle"
        );
    }
}

/// A UV sphere of about `triangles` triangles.
fn sphere(triangles: u32) -> (Mesh, u32) {
    let stacks = ((triangles as f32 / 4.0).sqrt().round() as u32).max(3);
    let sectors = triangles / (2 * (stacks - 1));
    let mesh = Sphere::new(0.5).mesh().uv(sectors, stacks);
    let n = mesh.indices().map_or(0, |i| i.len() as u32 / 3);
    (mesh, n)
}

fn spawn_mesh(app: &mut App, mesh: Mesh, at: Vec3, parent: Option<Entity>) -> (Entity, SceneId) {
    let world = app.world_mut();
    let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial::default());
    let mut e = world.spawn((
        Name::new("part"),
        SceneObject,
        Mesh3d(mesh),
        MeshMaterial3d(material),
        Transform::from_translation(at),
    ));
    if let Some(p) = parent {
        e.insert(ChildOf(p));
    }
    let e = e.id();
    (e, *world.get::<SceneId>(e).unwrap())
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}

fn tree_holds_everything(app: &App, triangles: u32) -> bool {
    let scene = app.world().resource::<SceneBvh>();
    scene.is_idle() && scene.stats().triangles == triangles
}

/// One drag of `id` over `frames` frames at 60 Hz; returns per-frame (frame ms, plugin ms), the
/// time from the first drag event until the tree first holds a moved position, and from the last
/// drag event until the tree holds the final one.
fn drag(
    app: &mut App,
    id: SceneId,
    frames: u32,
    triangles: u32,
) -> (Vec<f64>, Vec<f64>, Option<Duration>, Duration) {
    let e = app.world().resource::<SceneIndex>().entity(id).unwrap();
    let start = *app.world().get::<Transform>(e).unwrap();
    let mut plugin_ms = Vec::new();
    let first = Instant::now();
    let mut first_follow = None;
    let at = |k: u32| {
        let mut t = start;
        t.translation.x += 0.02 * k as f32;
        t.rotation = Quat::from_rotation_y(0.01 * k as f32);
        t
    };
    let frames = support::drag::drag(app, id, frames, at, |app| {
        plugin_ms.push(app.world().resource::<PluginClock>().spent.as_secs_f64() * 1e3);
        // Caught up with this frame's move before the next frame's arrives?
        if first_follow.is_none() && tree_holds_everything(app, triangles) {
            first_follow = Some(first.elapsed());
        }
    });
    // The commit lands where the last preview was; wait (frames still at 60 Hz) until the tree
    // has it.
    while !tree_holds_everything(app, triangles) {
        let t = Instant::now();
        app.update();
        std::thread::sleep(FRAME.saturating_sub(t.elapsed()));
    }
    (
        frames.frame_ms,
        plugin_ms,
        first_follow,
        frames.commit.elapsed(),
    )
}

fn main() {
    println!("## Editing: main-thread time per frame during a drag, and time until traced\n");
    println!(
        "| scene | frames (60 Hz) | frame median (ms) | frame max (ms) | plugin median (ms) | first drag event to tree following (ms) | last drag event to tree ready (ms) |"
    );
    println!("|---|---|---|---|---|---|---|");

    // A 1M-triangle mesh.
    let mut app = app();
    let (mesh, big) = sphere(1_000_000);
    let (_, id) = spawn_mesh(&mut app, mesh, Vec3::ZERO, None);
    let load = settle(&mut app, big);
    let ms =
        |d: Option<Duration>| d.map_or("never".into(), |d| format!("{:.0}", d.as_secs_f64() * 1e3));
    // Twice: the first drag of a still mesh takes it out of the baked tree into an instance.
    for run in ["first drag", "second drag"] {
        let (f, p, follow, ready) = drag(&mut app, id, 60, big);
        println!(
            "| one mesh, {big} triangles, {run} | 60 | {:.2} | {:.2} | {:.3} | {} | {:.1} |",
            median(f.clone()),
            max(&f),
            median(p),
            ms(follow),
            ready.as_secs_f64() * 1e3
        );
    }

    // A 100-part assembly of 10k-triangle meshes, dragged by its root.
    let mut asm = app_with_assembly();
    let (root_id, parts_triangles) = (asm.1, asm.2);
    for run in ["first drag", "second drag"] {
        let (f, p, follow, ready) = drag(&mut asm.0, root_id, 60, parts_triangles);
        println!(
            "| 100 parts under one root, {parts_triangles} triangles, {run} | 60 | {:.2} | {:.2} | {:.3} | {} | {:.1} |",
            median(f.clone()),
            max(&f),
            median(p),
            ms(follow),
            ready.as_secs_f64() * 1e3
        );
    }

    println!(
        "\n## Undo of a delete, and a duplicate, of a {big}-triangle mesh: time until the tree holds it\n"
    );
    println!("| edit | run 1 (ms) | run 2 (ms) | run 3 (ms) | median (ms) |");
    println!("|---|---|---|---|---|");
    println!(
        "(first load of the mesh: {:.0} ms)\n",
        load.as_secs_f64() * 1e3
    );
    let mut undo_delete = Vec::new();
    let mut duplicate = Vec::new();
    let mut duplicate_again = Vec::new();
    for _ in 0..3 {
        let request = |app: &mut App, r: EditRequest| {
            app.world_mut().resource_mut::<EditRequests>().0.push(r);
        };
        request(
            &mut app,
            EditRequest::Apply {
                command: EditCommand::Delete { ids: vec![id] },
                continuing: false,
            },
        );
        settle(&mut app, 0);
        request(&mut app, EditRequest::Undo);
        undo_delete.push(settle(&mut app, big).as_secs_f64() * 1e3);
        request(
            &mut app,
            EditRequest::Apply {
                command: EditCommand::Duplicate {
                    ids: vec![id],
                    copies: Vec::new(),
                },
                continuing: false,
            },
        );
        // The copy shares the mesh's triangles: the tree holds the same count, placed twice.
        duplicate.push(settle_traced(&mut app, big, 2).as_secs_f64() * 1e3);
        // A further copy, of a mesh already kept in object space for sharing.
        request(
            &mut app,
            EditRequest::Apply {
                command: EditCommand::Duplicate {
                    ids: vec![id],
                    copies: Vec::new(),
                },
                continuing: false,
            },
        );
        duplicate_again.push(settle_traced(&mut app, big, 3).as_secs_f64() * 1e3);
        request(&mut app, EditRequest::Undo);
        request(&mut app, EditRequest::Undo);
        settle_traced(&mut app, big, 1);
    }
    for (name, v) in [
        ("undo of a delete", &undo_delete),
        ("duplicate", &duplicate),
        ("a second duplicate", &duplicate_again),
    ] {
        println!(
            "| {name} | {:.0} | {:.0} | {:.0} | {:.0} |",
            v[0],
            v[1],
            v[2],
            median(v.clone())
        );
    }
}

fn app_with_assembly() -> (App, SceneId, u32) {
    let mut app = app();
    let root = app
        .world_mut()
        .spawn((
            Name::new("assembly"),
            SceneObject,
            Transform::default(),
            Visibility::default(),
        ))
        .id();
    let root_id = *app.world().get::<SceneId>(root).unwrap();
    let mut total = 0;
    for i in 0..100 {
        let (mesh, n) = sphere(10_000);
        total += n;
        let at = Vec3::new((i % 10) as f32, (i / 10) as f32, 0.0) * 1.2;
        spawn_mesh(&mut app, mesh, at, Some(root));
    }
    settle(&mut app, total);
    (app, root_id, total)
}
