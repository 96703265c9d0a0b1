//! The scene on the GPU: extraction of the tree's changes (streamed in rounds when large), what
//! it leaves for the render world, staging, the texture layers and the
//! scene's buffers and bind group.

pub(crate) mod extract;
pub(crate) mod gpu_scene;
pub(crate) mod pending;
pub(crate) mod staging;
pub(crate) mod texture_layers;
