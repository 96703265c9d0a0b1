//! The panorama sky: its texels, importance-sampling table and GPU copy.

pub(crate) mod environment;
