//! The embedded default scene (`assets/default.treelight`) is the project the code in
//! `default_scene.rs` makes. `TREELIGHT_REGENERATE=1 cargo test -p treelight --test default_scene`
//! writes the file again after the code changed.

use bevy::asset::AssetPlugin;
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use std::path::Path;
use treelight::camera::OrbitCamera;
use treelight::default_scene::{DEFAULT_PROJECT, spawn_default_scene};
use treelight::edit::{EditHistory, EditRequests};
use treelight::import::SourceCatalog;
use treelight::project::{ProjectState, capture_project, read_project_str, write_project};
use treelight::scene_id::SceneIndex;
use treelight::selection::Selection;

#[test]
fn the_embedded_default_scene_is_what_the_code_makes() {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin::default(),
        MeshPlugin,
        TransformPlugin,
    ))
    .init_asset::<StandardMaterial>()
    .init_resource::<SceneIndex>()
    .init_resource::<EditHistory>()
    .init_resource::<EditRequests>()
    .init_resource::<Selection>()
    .init_resource::<SourceCatalog>()
    .init_resource::<ProjectState>()
    .add_systems(Startup, spawn_default_scene);
    app.world_mut()
        .spawn((OrbitCamera::default(), Transform::default()));
    app.update();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/default.treelight");
    let (made, unsaved) = capture_project(app.world_mut(), &file);
    assert!(unsaved.is_empty(), "{unsaved:?}");
    if std::env::var("TREELIGHT_REGENERATE").as_deref() == Ok("1") {
        write_project(&file, &made).unwrap();
        return;
    }
    let embedded = read_project_str(DEFAULT_PROJECT, &file).unwrap();
    assert_eq!(
        embedded, made,
        "assets/default.treelight is out of date: run TREELIGHT_REGENERATE=1 cargo test -p treelight --test default_scene"
    );
}
