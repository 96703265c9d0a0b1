//! Tracing the views: kernel warm-ups, each view's buffers and budget, the node that dispatches,
//! GPU timings and memory.

pub(crate) mod gpu_memory;
pub(crate) mod kernel_warmup;
pub(crate) mod node;
pub(crate) mod timing;
pub(crate) mod views;
