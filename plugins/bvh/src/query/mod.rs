//! Rays and what they ask of the tree: closest and any hit, box overlap.

pub(crate) mod ray;
pub(crate) mod traverse;
