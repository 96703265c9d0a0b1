//! The scene formats: glTF (with its compressed meshes and its materials), OBJ and PLY.

pub(crate) mod gltf_compressed;
pub(crate) mod gltf_scene;
pub(crate) mod material;
pub(crate) mod obj_scene;
pub(crate) mod ply_scene;
