//! Editing a built tree: groups kept whole or baked, triangle removal and refit.

pub(crate) mod group;
pub(crate) mod induced;
pub(crate) mod pieces;
pub(crate) mod shared;
