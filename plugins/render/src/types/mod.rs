//! What the render layers share: GPU record layouts, buffer kinds and their parts, the frame
//! budget's tiles, the camera component and the figures reported to the main world.

pub(crate) mod bindings;
pub(crate) mod budget;
pub(crate) mod emitters;
pub(crate) mod energy;
pub(crate) mod figures;
pub(crate) mod identity;
pub(crate) mod map_transforms;
pub(crate) mod parts;
pub(crate) mod records;
pub(crate) mod shading;
pub(crate) mod upload;
pub(crate) mod vertex_pool;
pub(crate) mod view;
