//! What a reader returns: the scene, its textures, and the UV sets a material reads.

pub(crate) mod imported;
pub(crate) mod texture;
pub(crate) mod uv_sets;
