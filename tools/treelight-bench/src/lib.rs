//! The benchmark's scene sources (files and the paper-style generators), shared with other
//! measurement tools in the workspace (the GPU ray benchmark of `treelight_render`), and the peer
//! libraries' builders, and the summaries of parameter sweeps.

// Every public item says what it is for: the crate is meant to be used from other apps.
#![warn(missing_docs)]

pub mod editor_tree;
pub mod peers;
pub mod rng;
pub mod scenes;
pub mod sweep;
