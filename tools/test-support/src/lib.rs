//! What the workspace's test binaries share: where the shared test scenes are, a small seeded
//! generator, and a global allocator that counts live bytes and their peak.

pub mod counting;
mod xorshift;

pub use xorshift::Xorshift;

use std::path::PathBuf;

/// The folder of the shared test scenes, `../shared/scenes` beside the repository.
pub fn shared_scenes() -> PathBuf {
    // This crate lies two folders below the repository's root.
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes"
    ))
}

/// A file of the shared test scenes, by its path there (`obj/sibenik.obj`). Fails, naming the
/// path, when it is not there: the tests that read it never pass without it.
pub fn shared_scene(path: &str) -> PathBuf {
    let file = shared_scenes().join(path);
    assert!(
        file.exists(),
        "{} is missing: the tests read the scenes in ../shared/scenes, beside the repository",
        file.display()
    );
    file
}
