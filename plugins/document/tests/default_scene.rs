//! The embedded default scene (`assets/default.treelight`) is the project the code in
//! `default_scene.rs` makes. `TREELIGHT_REGENERATE=1 cargo test -p treelight_document --test default_scene`
//! writes the file again after the code changed.

use bevy::prelude::*;
use std::path::Path;
use treelight_document::default_scene::DEFAULT_PROJECT;
use treelight_document::default_scene::spawn_default_scene;
use treelight_document::project::capture::capture_project;
use treelight_document::project::format::read_project_str;
use treelight_document::project::format::write_project;
use treelight_document::scene::outbox::{CameraValue, DocumentView};

#[test]
fn the_embedded_default_scene_is_what_the_code_makes() {
    // The editor's headless app, with the default scene spawned from code.
    let mut app = treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    app.add_systems(Startup, spawn_default_scene);
    app.insert_resource(DocumentView(Some(CameraValue::default())));
    app.update();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/default.treelight");
    let (made, unsaved) = capture_project(app.world_mut(), &file);
    assert!(unsaved.is_empty(), "{unsaved:?}");
    if std::env::var("TREELIGHT_REGENERATE").as_deref() == Ok("1") {
        write_project(&file, &made).unwrap();
        return;
    }
    let embedded = read_project_str(DEFAULT_PROJECT, &file).unwrap();
    assert_eq!(
        embedded, made,
        "assets/default.treelight is out of date: run TREELIGHT_REGENERATE=1 cargo test -p treelight_document --test default_scene"
    );
}
