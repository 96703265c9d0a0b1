//! The shell's shape: its modules form no circle, and its three layers hold. `core` names no
//! feature; each feature (input, viewport, panels, assets, files) names `core` and itself, never
//! another feature; the workspace above them may name any.

use std::path::Path;

const EDITOR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/src/editor");

#[test]
fn no_shell_modules_form_a_circle() {
    treelight_fence::assert_no_circles(Path::new(EDITOR), "editor");
}

#[test]
fn features_name_core_and_never_each_other() {
    treelight_fence::assert_peers_apart(
        Path::new(EDITOR),
        "editor",
        &[
            &["core"],
            &["input", "viewport", "panels", "assets", "files"],
            &["workspace"],
        ],
    );
}

#[test]
fn every_shell_module_lies_in_a_layer() {
    let folders = [
        "core",
        "input",
        "viewport",
        "panels",
        "assets",
        "files",
        "workspace",
    ];
    for entry in std::fs::read_dir(EDITOR).unwrap().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let name = name.trim_end_matches(".rs");
        assert!(
            name == "mod" || folders.contains(&name),
            "src/editor/{name} lies outside the shell's layers {folders:?}"
        );
    }
}
