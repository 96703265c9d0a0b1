//! What the worker and the main thread share: the settings, the tree and its figures, rays on it,
//! the meshes' triangles and shading as the worker takes them, and the threads' priorities.

pub(crate) mod config;
pub(crate) mod hit;
pub(crate) mod mesh;
pub mod packed;
pub(crate) mod panics;
pub(crate) mod parked;
pub mod priority;
pub(crate) mod shading;
pub(crate) mod tree;
