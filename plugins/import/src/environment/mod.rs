//! Sky panoramas: Radiance HDR and OpenEXR, shrunk as they are read.

pub(crate) mod panorama;
pub(crate) mod radiance;
