//! The scene as the document keeps it, above values and files: notices and events, the hierarchy,
//! placement, the sky panorama, and imported scenes parsed, converted and spawned as entities.

pub mod convert;
pub mod environment;
pub mod hierarchy;
pub mod notice;
pub mod outbox;
pub mod parsed;
pub mod placement;
pub mod share;
pub mod spawn;
