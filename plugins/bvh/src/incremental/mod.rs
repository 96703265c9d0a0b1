//! The paper's incremental builders: insertion with the branch-and-bound search (Incr, IncrU), its
//! parallel search (IncrUP) and parallel batches (IncrUPB).

pub(crate) mod incr_up;
pub(crate) mod incr_upb;
pub(crate) mod insert;
pub(crate) mod search;
