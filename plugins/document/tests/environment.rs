//! The sky panorama in the document: set by a command and taken back by undo, read on its own
//! thread, saved in projects relative to their folder (so a moved folder keeps it), and a broken
//! file named in a notice while the scene keeps its flat sky.

#[path = "support/world.rs"]
mod world;

use bevy::prelude::*;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::{EditRequest, apply_request};
use treelight_document::project::capture::save_project;
use treelight_document::project::format::read_project;
use treelight_document::project::restore::open_project;
use treelight_document::scene::environment::{LoadedEnvironment, SceneEnvironment};
use treelight_document::scene::notice::Notices;
use world::{editor_world, fresh_dir};

fn temp(name: &str) -> PathBuf {
    fresh_dir("sky", name)
}

/// A `w × h` Radiance HDR file of one colour per half (flat scanlines, as the format allows).
fn write_hdr(path: &Path, w: u32, h: u32) {
    let mut out = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for _y in 0..h {
        for x in 0..w {
            // Mantissas over exponent 129 (values up to 2): orange on the left, blue on the right.
            out.extend(if x < w / 2 {
                [200, 100, 30, 129]
            } else {
                [30, 60, 200, 129]
            });
        }
    }
    std::fs::write(path, out).unwrap();
}

fn apply(app: &mut App, request: EditRequest) {
    apply_request(app.world_mut(), request).unwrap_or_else(|e| panic!("{e}"));
    app.update();
}

fn set(environment: SceneEnvironment) -> EditRequest {
    EditRequest::Apply {
        command: EditCommand::SetEnvironment { environment },
        continuing: false,
    }
}

/// Updates until the panorama's read has ended.
fn settle(app: &mut App) {
    let start = Instant::now();
    loop {
        app.update();
        if !app.world().resource::<LoadedEnvironment>().loading() {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "the panorama never loaded"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The loaded panorama's size, if one is loaded.
fn loaded_size(app: &App) -> Option<UVec2> {
    let handle = app.world().resource::<LoadedEnvironment>().image.clone()?;
    Some(app.world().resource::<Assets<Image>>().get(&handle)?.size())
}

#[test]
fn a_panorama_set_by_command_loads_and_undo_takes_it_back() {
    let dir = temp("command");
    let sky = dir.join("sky.hdr");
    write_hdr(&sky, 32, 16);
    let mut app = editor_world();
    app.update();
    assert_eq!(loaded_size(&app), None);
    apply(
        &mut app,
        set(SceneEnvironment {
            image: Some(sky.clone()),
            rotation_degrees: 30.0,
            ..default()
        }),
    );
    settle(&mut app);
    assert_eq!(loaded_size(&app), Some(UVec2::new(32, 16)));
    // The image holds the file's radiance: orange on the left.
    let handle = app
        .world()
        .resource::<LoadedEnvironment>()
        .image
        .clone()
        .unwrap();
    let image = app
        .world()
        .resource::<Assets<Image>>()
        .get(&handle)
        .unwrap();
    let left = image.get_color_at(2, 2).unwrap().to_linear();
    assert!(left.red > left.green && left.green > left.blue, "{left:?}");
    // A turn is a step of its own; undoing it, then the panorama, leaves the flat sky.
    apply(
        &mut app,
        set(SceneEnvironment {
            image: Some(sky.clone()),
            rotation_degrees: 90.0,
            ..default()
        }),
    );
    assert_eq!(
        app.world().resource::<SceneEnvironment>().rotation_degrees,
        90.0
    );
    apply(&mut app, EditRequest::Undo);
    assert_eq!(
        app.world().resource::<SceneEnvironment>().rotation_degrees,
        30.0
    );
    apply(&mut app, EditRequest::Undo);
    settle(&mut app);
    assert_eq!(
        *app.world().resource::<SceneEnvironment>(),
        SceneEnvironment::default()
    );
    assert_eq!(loaded_size(&app), None);
    // Redo reads it again.
    apply(&mut app, EditRequest::Redo);
    settle(&mut app);
    assert_eq!(loaded_size(&app), Some(UVec2::new(32, 16)));
    // A file that is not a panorama is refused by the command's check.
    let bad = apply_request(
        app.world_mut(),
        set(SceneEnvironment {
            image: Some(dir.join("scene.glb")),
            ..default()
        }),
    );
    assert!(bad.is_err(), "{bad:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_project_keeps_its_panorama_beside_it_when_the_folder_moves() {
    let dir = temp("project");
    let skies = dir.join("skies");
    std::fs::create_dir_all(&skies).unwrap();
    write_hdr(&skies.join("noon.hdr"), 16, 8);
    let mut app = editor_world();
    app.update();
    let environment = SceneEnvironment {
        image: Some(skies.join("noon.hdr")),
        rotation_degrees: -45.0,
        intensity: 2500.0,
        shown: false,
    };
    apply(&mut app, set(environment.clone()));
    settle(&mut app);
    let path = dir.join("scene.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let saved = read_project(&path).unwrap();
    assert_eq!(
        saved.environment,
        Some(SceneEnvironment {
            image: Some(PathBuf::from("skies/noon.hdr")),
            ..environment.clone()
        })
    );
    // The folder moves: the project finds its panorama in the new place.
    let moved = temp("project-moved");
    std::fs::remove_dir_all(&moved).ok();
    std::fs::rename(&dir, &moved).unwrap();
    let mut fresh = editor_world();
    open_project(fresh.world_mut(), &moved.join("scene.treelight")).unwrap();
    settle(&mut fresh);
    assert_eq!(
        *fresh.world().resource::<SceneEnvironment>(),
        SceneEnvironment {
            image: Some(moved.join("skies/noon.hdr")),
            ..environment
        }
    );
    assert_eq!(loaded_size(&fresh), Some(UVec2::new(16, 8)));
    // A project without a panorama leaves none behind.
    let mut plain = editor_world();
    plain.update();
    let plain_path = moved.join("plain.treelight");
    save_project(plain.world_mut(), &plain_path).unwrap();
    assert_eq!(read_project(&plain_path).unwrap().environment, None);
    open_project(fresh.world_mut(), &plain_path).unwrap();
    settle(&mut fresh);
    assert_eq!(
        *fresh.world().resource::<SceneEnvironment>(),
        SceneEnvironment::default()
    );
    assert_eq!(loaded_size(&fresh), None);
    std::fs::remove_dir_all(&moved).ok();
}

#[test]
fn a_broken_panorama_is_a_notice_naming_it_and_the_scene_keeps_its_sky() {
    let dir = temp("broken");
    let sky = dir.join("broken.hdr");
    std::fs::write(
        &sky,
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n\x01",
    )
    .unwrap();
    let mut app = editor_world();
    app.update();
    apply(
        &mut app,
        set(SceneEnvironment {
            image: Some(sky.clone()),
            ..default()
        }),
    );
    settle(&mut app);
    assert_eq!(loaded_size(&app), None);
    let notices = &app.world().resource::<Notices>().0;
    assert!(
        notices
            .iter()
            .any(|n| n.text.contains("broken.hdr") && n.text.contains("sky panorama")),
        "{notices:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
