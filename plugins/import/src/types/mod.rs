//! Errors and the memory budget every reader charges.

pub(crate) mod budget;
pub(crate) mod error;
