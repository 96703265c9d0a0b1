//! The kernels: their WGSL sources, shader handles, bind group layouts and pipelines.

pub(crate) mod pipelines;
pub(crate) mod sources;
