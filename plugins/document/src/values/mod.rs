//! The document's values, the lowest layer: ids, transforms, materials, lights, shapes, the look
//! and camera, each plain data with its checks; they name nothing above them.

pub mod camera;
pub mod light;
pub mod look;
pub mod map_transforms;
pub mod material;
pub mod object;
pub mod primitive;
pub mod transform;
