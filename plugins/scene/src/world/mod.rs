//! The Bevy side: the resource apps read, the systems that follow the world, and ray picking.

pub(crate) mod parking;
pub(crate) mod picking;
pub(crate) mod scene_bvh;
pub(crate) mod track;
