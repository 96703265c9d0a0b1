//! The document core stays apart from the editor's shell: its manifest names no egui, dock, window
//! or winit crate, so nothing in it can draw or reach an editor's panels, and its app runs without
//! a window or a renderer.

use bevy::prelude::*;

/// The crates the manifest depends on and the features it asks of them: the names in its
/// dependency tables, and every quoted name inside them.
fn dependency_names(manifest: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut in_dependencies = false;
    for line in manifest.lines() {
        let line = line.split('#').next().unwrap_or_default().trim();
        if line.starts_with('[') {
            in_dependencies = line.contains("dependencies");
            continue;
        }
        if !in_dependencies || line.is_empty() {
            continue;
        }
        if let Some(key) = line.split(['=', '.', ' ']).next()
            && !key.starts_with('"')
            && !key.is_empty()
        {
            names.push(key.to_owned());
        }
        names.extend(line.split('"').skip(1).step_by(2).map(str::to_owned));
    }
    names
}

#[test]
fn the_manifest_names_no_ui_or_window_crate() {
    let manifest = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml"))
        .expect("the crate's manifest");
    let names = dependency_names(&manifest);
    assert!(names.iter().any(|n| n == "bevy"), "{names:?}");
    for name in &names {
        // The shell is the crate named `treelight`; the plugins and tools beside it
        // (`treelight_scene`, the tests' `treelight-fence`) are not.
        assert!(
            name != "treelight"
                && !["egui", "dock", "winit", "window"]
                    .iter()
                    .any(|shell| name.contains(shell)),
            "the document core depends on {name}"
        );
    }
}

#[test]
fn the_headless_app_runs_without_a_window_or_renderer() {
    let mut app = treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    app.add_systems(
        Startup,
        treelight_document::default_scene::open_default_scene,
    );
    app.finish();
    app.cleanup();
    for _ in 0..3 {
        app.update();
    }
    assert!(app.get_sub_app(bevy::render::RenderApp).is_none());
    let world = app.world_mut();
    let objects = world
        .query_filtered::<(), With<treelight_document::values::object::SceneObject>>()
        .iter(world)
        .count();
    assert!(objects > 0, "the default scene opened");
}
