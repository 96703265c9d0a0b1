//! Optimisation of a built tree: update batches, the post-pass and its bounded steps, treelet
//! restructuring, reclustering of the top.

pub(crate) mod idle_step;
pub(crate) mod post_pass;
pub(crate) mod recluster;
pub(crate) mod treelet;
pub(crate) mod update;
