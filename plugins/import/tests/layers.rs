//! The import crate's layers hold: each folder of `src` names only the folders below it (`types`,
//! `files`, `scene`, `formats`, `environment`, lowest first), never the crate's root (whose
//! re-exports are for users), and no two modules name each other, even through others.

use std::path::Path;

const SRC: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/src");

#[test]
fn no_layer_names_one_above_it() {
    treelight_fence::assert_layers(
        Path::new(SRC),
        "",
        &["types", "files", "scene", "formats", "environment"],
    );
}

#[test]
fn no_modules_form_a_circle() {
    treelight_fence::assert_no_circles(Path::new(SRC), "");
}
