//! What the document's tests start from: the editor's headless world and fresh folders.
#![allow(dead_code)]

use bevy::prelude::*;
use std::path::PathBuf;
use treelight_document::scene::outbox::{CameraValue, DocumentView};

/// The editor's headless app (the one `--save` runs), with the editor's starting view to save.
pub fn editor_world() -> App {
    let mut app = treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    app.insert_resource(DocumentView(Some(CameraValue::default())));
    app
}

/// An empty folder for one test: `treelight-{kind}-{name}-{process}` in the temporary folder.
pub fn fresh_dir(kind: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("treelight-{kind}-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Updates until the scene BVH holds what the world shows and its worker is idle.
pub fn settle_tree(app: &mut App) {
    let start = std::time::Instant::now();
    for _ in 0..3 {
        app.update();
    }
    loop {
        app.update();
        if app
            .world()
            .resource::<treelight_scene::SceneBvh>()
            .is_idle()
        {
            app.update();
            return;
        }
        assert!(
            start.elapsed() < std::time::Duration::from_secs(60),
            "the BVH did not settle"
        );
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}
