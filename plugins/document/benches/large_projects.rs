//! A project over an assembly of many nodes: one 12-triangle mesh placed by N top-level nodes
//! (default 1,000,000; the first argument sets it), in the document's headless app (the one
//! `--save` runs: no window, UI or renderer).
//!
//! Times: the import (parse and spawn, until the objects are in the world), the save of the
//! unedited project, 100 edits (moves, renames, hidings, deletions), the save after them, and the
//! opening of that project in a fresh app (its source parsed and spawned again, the edits and ids
//! applied); the files' sizes. Checks that the reopened scene has the edited objects' values.
//!
//! Run: `cargo bench -p treelight_document --bench large_projects [-- N]` (release). Prints a
//! markdown table.

use bevy::prelude::*;
use std::time::Instant;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::{EditRequest, apply_request};
use treelight_document::project::capture::save_project;
use treelight_document::project::restore::open_project;
use treelight_document::values::object::{SceneId, SceneIndex};
use treelight_scene::SceneBvhConfig;

#[path = "../tests/support/assembly.rs"]
mod assembly;

fn headless() -> App {
    treelight_document::app::headless_app(SceneBvhConfig::default())
}

fn edit(app: &mut App, command: EditCommand) {
    apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command,
            continuing: false,
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
}

fn main() {
    let copies: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    let dir = std::env::temp_dir().join(format!("treelight-large-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = assembly::placed_assembly(&dir, copies);
    let source_bytes = std::fs::metadata(&file).unwrap().len();

    let mut app = headless();
    let t = Instant::now();
    let scene = treelight_import::load_scene(&file).unwrap();
    let parse = t.elapsed();
    treelight_document::scene::spawn::spawn_scene_in_world(
        app.world_mut(),
        &file,
        &scene,
        &mut Default::default(),
        true,
        &[],
    )
    .unwrap();
    let import = t.elapsed();
    let objects = app.world().resource::<SceneIndex>().len();

    let unedited = dir.join("unedited.treelight");
    let t = Instant::now();
    save_project(app.world_mut(), &unedited).unwrap();
    let save_unedited = t.elapsed();

    // 100 edits spread over the assembly: 70 moves, 10 renames, 10 hidings, 10 deletions.
    let id_of = |app: &mut App, name: &str| {
        let world = app.world_mut();
        let mut q = world.query::<(&Name, &SceneId)>();
        q.iter(world)
            .find(|(n, _)| n.as_str() == name)
            .map(|(_, id)| *id)
            .unwrap()
    };
    let step = copies / 100;
    let names: Vec<String> = (0..100).map(|k| format!("box {}", k * step)).collect();
    let ids: Vec<SceneId> = names.iter().map(|n| id_of(&mut app, n)).collect();
    let t = Instant::now();
    for (k, &id) in ids.iter().enumerate() {
        let command = match k % 10 {
            0 => EditCommand::Rename {
                id,
                name: format!("renamed {k}"),
            },
            1 => EditCommand::SetVisible { id, visible: false },
            2 => EditCommand::Delete { ids: vec![id] },
            _ => EditCommand::SetTransform {
                id,
                transform: Transform::from_xyz(k as f32, 5.0, 0.0).into(),
            },
        };
        edit(&mut app, command);
    }
    let edits = t.elapsed();
    let edited = dir.join("edited.treelight");
    let t = Instant::now();
    save_project(app.world_mut(), &edited).unwrap();
    let save_edited = t.elapsed();
    drop(app);

    let mut fresh = headless();
    let t = Instant::now();
    open_project(fresh.world_mut(), &edited).unwrap();
    let open = t.elapsed();
    // The reopened scene has the edits and the ids.
    let index = fresh.world().resource::<SceneIndex>();
    assert_eq!(index.len(), objects - 10, "objects after reopening");
    for (k, &id) in ids.iter().enumerate() {
        let e = index.entity(id);
        match k % 10 {
            2 => assert!(e.is_none(), "deleted {id} came back"),
            3.. => {
                let t = fresh.world().get::<Transform>(e.unwrap()).unwrap();
                assert_eq!(t.translation, Vec3::new(k as f32, 5.0, 0.0));
            }
            _ => assert!(e.is_some()),
        }
    }
    let size = |p: &std::path::Path| std::fs::metadata(p).unwrap().len();
    println!(
        "\n## A project over {copies} placed nodes ({objects} objects, a {:.1} MB source)\n",
        source_bytes as f64 / 1e6
    );
    println!("| step | time (s) | file |");
    println!("|---|---|---|");
    let row = |what: &str, d: std::time::Duration, file: String| {
        println!("| {what} | {:.2} | {file} |", d.as_secs_f64());
    };
    row("import: parse", parse, String::new());
    row("import: parse and spawn", import, String::new());
    row(
        "save, unedited",
        save_unedited,
        format!("{} bytes", size(&unedited)),
    );
    row("100 edits", edits, String::new());
    row(
        "save after 100 edits",
        save_edited,
        format!("{} bytes", size(&edited)),
    );
    row("open that project in a fresh app", open, String::new());
    std::fs::remove_dir_all(&dir).ok();
}
