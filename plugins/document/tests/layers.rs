//! The document's layers hold: `values`, `files`, `scene`, `edit`, `import`, `project`,
//! `default_scene`, `app`, lowest first, each naming only those below it (never the crate's root),
//! and no two modules name each other, even through others.

use std::path::Path;

const SRC: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/src");

#[test]
fn no_layer_names_one_above_it() {
    treelight_fence::assert_layers(
        Path::new(SRC),
        "",
        &[
            "values",
            "files",
            "scene",
            "edit",
            "import",
            "project",
            "default_scene",
            "app",
        ],
    );
}

#[test]
fn no_modules_form_a_circle() {
    treelight_fence::assert_no_circles(Path::new(SRC), "");
}
