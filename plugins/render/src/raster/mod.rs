//! What the rasteriser is spared while every 3D camera is path traced.

pub(crate) mod raster_meshes;
pub(crate) mod raster_skip;
pub(crate) mod shadow_maps;
