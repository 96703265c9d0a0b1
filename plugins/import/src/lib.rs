//! # treelight_import
//!
//! Reads scene files into plain meshes with world transforms, for the editor (which turns them into
//! Bevy entities) and for the benchmark (which turns them into triangles). Every failure names the
//! file and the problem; nothing outside the opened file and the buffers beside it is read.

// Every public item says what it is for: the crate is meant to be used from other apps.
#![warn(missing_docs)]

// The layers, lowest first: `types` (errors, the memory budget), `files` (the one opener),
// `scene` (what a reader returns, textures, UV sets), `formats` (glTF, OBJ, PLY and materials),
// `environment` (panoramas). This file dispatches by extension and re-exports.

mod environment;
mod files;
mod formats;
mod scene;
mod types;

use std::path::Path;

pub use environment::panorama::{
    EnvironmentImage, MAX_ENVIRONMENT_FILE, MAX_ENVIRONMENT_SIDE, MAX_ENVIRONMENT_WIDTH,
    coordinates_of, direction_of, read_environment, read_environment_with,
};
pub use files::sandbox::file_kind;
pub use formats::gltf_scene::load_gltf;
pub use formats::obj_scene::load_obj;
pub use formats::ply_scene::load_ply;
pub use scene::imported::{
    ImportedAlphaMode, ImportedCamera, ImportedLight, ImportedLightKind, ImportedMaterial,
    ImportedMesh, ImportedNode, ImportedScene, MeshGeometry,
};
pub use scene::texture::{
    ImportedTexture, MAX_TEXTURE_SIDE, TextureRef, UV_IDENTITY, WrapMode, uv_transform,
};
pub use types::budget::{BUDGET_VARIABLE, ImportOptions, available_memory, default_memory_budget};
pub use types::error::{ImportError, MAX_ELEMENTS};

/// Loads a scene by its extension: `.gltf`, `.glb`, `.obj` or `.ply`, within the default memory
/// budget ([`ImportOptions::default`]).
pub fn load_scene(path: &Path) -> Result<ImportedScene, ImportError> {
    load_scene_with(path, &ImportOptions::default())
}

/// Loads a scene by its extension, as [`load_scene`], with the given options.
pub fn load_scene_with(path: &Path, options: &ImportOptions) -> Result<ImportedScene, ImportError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut budget = types::budget::Budget::new(path, options);
    match ext.as_deref() {
        Some("gltf") | Some("glb") => formats::gltf_scene::read_gltf(path, &mut budget),
        Some("obj") => formats::obj_scene::read_obj(path, &mut budget),
        Some("ply") => formats::ply_scene::read_ply(path, &mut budget),
        _ => Err(ImportError::new(
            path,
            "unsupported file type (expected .gltf, .glb, .obj or .ply)",
        )),
    }
}
