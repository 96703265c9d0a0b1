//! Imports without a window: each request is its own job, named by its root's id from the request
//! to the tree, so imports opened in the same frame (two of one file, one of another) are all made
//! and all followed into the tree.

use bevy::prelude::*;
use std::path::Path;
use treelight_document::import::jobs::TracingImports;
use treelight_document::import::parse::PendingImports;
use treelight_document::notice::Notices;

#[test]
fn imports_opened_in_one_frame_are_all_made_and_traced() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes/gltf");
    let file = scenes.join("BoxTextured-glTF/BoxTextured.gltf");
    let other = scenes.join("Box_Draco.glb");
    let mut app = treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    {
        let mut pending = app.world_mut().resource_mut::<PendingImports>();
        pending.start(file.clone());
        pending.start(file.clone());
        pending.start(other.clone());
    }
    let start = std::time::Instant::now();
    let traced = |app: &App| {
        app.world()
            .resource::<Notices>()
            .0
            .iter()
            .filter(|n| n.text.contains("is in the tree"))
            .count()
    };
    while traced(&app) < 3 {
        assert!(
            start.elapsed().as_secs() < 60,
            "imports traced: {}; following: {}",
            traced(&app),
            app.world().resource::<TracingImports>().jobs.len()
        );
        app.update();
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let roots: Vec<String> = app
        .world_mut()
        .query::<(&Name, &treelight_document::object::SceneId)>()
        .iter(app.world())
        .filter(|(n, _)| n.as_str() == "BoxTextured.gltf")
        .map(|(_, id)| id.to_string())
        .collect();
    assert_eq!(roots.len(), 2, "{roots:?}");
    assert_eq!(app.world().resource::<TracingImports>().jobs.len(), 0);
}
