//! # treelight_bvh
//!
//! Incremental BVH construction for ray tracing (Bittner, Hapala, Havran 2015), with the editing,
//! traversal and export an interactive editor needs. No Bevy: glam, rayon and a hasher only.
//!
//! * Build by insertion: [`Bvh::insert_triangles`] (Incr / IncrU, chosen by [`BvhConfig`]),
//!   [`Bvh::insert_triangles_parallel_search`] (IncrUP), [`Bvh::insert_triangles_block_parallel`] and
//!   [`BlockStream`] (IncrUPB); references by [`Bvh::build_top_down`] ([`TopDown`]).
//! * Edit: groups ([`Bvh::insert_group`], [`Bvh::set_group_transform`], [`Bvh::bake_group`],
//!   [`Bvh::remove_group`]), copies sharing a group's triangles ([`Bvh::insert_instance`],
//!   [`Bvh::hit_group`]), triangles ([`Bvh::remove_triangles`], [`Bvh::set_triangles`]);
//!   [`Bvh::reserve`] ahead of an edit whose latency matters.
//! * Query: [`Bvh::closest_hit`], [`Bvh::any_hit`], [`Bvh::overlapping_triangles`].
//! * Export: [`Bvh::take_changes`] for GPUs, with the path tracer's 4-wide records laid out and kept
//!   in step by [`WideRecords`] (or [`Bvh::gpu_node`], binary); [`Bvh::write_tlbvh`] for files.
//! * Choose a whole policy by name: [`Preset`] (`fast`, `balanced`, `best`) and its [`Policy`].
//! * Check: [`Bvh::validate`], [`Bvh::sah_cost`].

// Every public item says what it is for: the crate is meant to be used from other apps.
#![warn(missing_docs)]

mod config;
mod edit;
mod error;
mod export;
mod incremental;
mod optimize;
mod preset;
mod query;
pub mod top_down;
mod tree;

/// Deterministic numbers in [0, 1) for unit tests (xorshift64): the same sequence on every machine
/// and with no dependency to keep in step.
#[cfg(test)]
pub(crate) fn test_random(mut seed: u64) -> impl FnMut() -> f32 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32
    }
}

pub use config::{BvhConfig, Inefficiency};
pub use edit::group::{GroupId, PreparedGroup, is_traceable_transform};
pub use edit::pieces::{MeshPieces, PieceRule, Refinement};
pub use error::BvhError;
pub use export::change::ChangeSet;
pub use export::compressed::{GpuCompressedBinaryNode, GpuCompressedNode};
pub use export::depth_first::DepthFirstLayout;
pub use export::gpu::{GpuInstance, GpuLayout, GpuNode, GpuTriangle};
pub use export::positions::{
    GpuIndexedTriangle, GpuPosition, PositionChanges, PositionPool, PositionSource,
};
pub use export::records::{RecordChanges, WideRecords};
pub use export::runs::RunAllocator;
pub use export::tlbvh::{FileBvh, FileNode, MAGIC, read_tlbvh};
pub use export::wide::{GpuWideNode, WideLayout};
pub use glam;
pub use incremental::incr_upb::{BlockStream, batch_coherence, coherent_batches, crowding};
pub use incremental::insert::coherence;
pub use optimize::idle_step::OptimizeCursor;
pub use optimize::post_pass::{PostMoves, PostPass, PostPassReport, TreeletSweep};
pub use preset::{IdleUpdates, IdleWork, Insertion, Policy, Preset};
pub use query::ray::{Hit, Ray, RayData};
pub use query::traverse::TraversalStats;
pub use top_down::{BuiltTree, TopDown};
pub use tree::aabb::Aabb;
pub use tree::bvh::{Bvh, Instance};
pub use tree::cost::TreeStats;
pub use tree::ids::{TriangleIds, TriangleIdsIter};
pub use tree::memory::MemoryBytes;
pub use tree::node::{InnerNode, MAX_INDEX, NONE, NodeKind, NodeRef};
pub use tree::scratch::SearchScratch;
pub use tree::triangle::{MAX_COORDINATE, Triangle, validate_triangles};
