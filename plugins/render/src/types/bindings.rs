//! Binding numbers the scene's bind group and the kernels agree on, for the layers that need one
//! without the feature that fills it.

/// The panorama's group-0 bindings: the image, its sampler, the distribution.
pub const ENVIRONMENT_BINDINGS: [u32; 3] = [30, 31, 32];
