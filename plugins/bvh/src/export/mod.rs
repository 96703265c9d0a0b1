//! The tree for others: GPU node records and the change log that keeps a GPU copy in step, and the
//! TLBVH1 file.

pub(crate) mod change;
pub(crate) mod compressed;
pub(crate) mod depth_first;
pub(crate) mod gpu;
pub(crate) mod positions;
pub(crate) mod records;
pub(crate) mod runs;
pub(crate) mod tlbvh;
pub(crate) mod wide;
