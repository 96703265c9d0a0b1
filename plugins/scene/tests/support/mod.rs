//! What the scene plugin's tests and its frame-time bench share: a headless app (no window, no
//! renderer) running `SceneBvhPlugin`.

use bevy::asset::AssetPlugin;
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use treelight_scene::{SceneBvhConfig, SceneBvhPlugin};

/// Minimal plugins, assets, meshes and transforms, and the scene plugin with `config`.
pub fn headless_app(config: SceneBvhConfig) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin::default(),
        MeshPlugin,
        TransformPlugin,
        SceneBvhPlugin { config },
    ));
    app
}
