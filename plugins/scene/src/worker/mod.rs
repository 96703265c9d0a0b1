//! The worker thread: it takes the main thread's commands, builds each mesh's bBVH in parallel,
//! inserts, moves and removes groups, and refines still meshes in idle time.

pub(crate) mod chunks;
pub(crate) mod main_loop;
pub(crate) mod refine;
pub(crate) mod start;
