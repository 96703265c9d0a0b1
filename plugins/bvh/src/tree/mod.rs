//! The tree's storage: flat arrays indexed by `u32`, the primitive edits every builder is made of, and
//! its measures and checks.

pub(crate) mod aabb;
pub(crate) mod bvh;
pub(crate) mod corners;
pub(crate) mod cost;
pub(crate) mod flags;
pub(crate) mod ids;
pub(crate) mod memory;
pub(crate) mod node;
pub(crate) mod scratch;
pub(crate) mod triangle;
pub(crate) mod validate;
pub(crate) mod vertices;
