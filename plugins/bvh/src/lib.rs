//! # treelight_bvh
//!
//! Incremental BVH construction for ray tracing (Bittner, Hapala, Havran 2015), with the editing,
//! traversal and export an interactive editor needs. No Bevy: glam and rayon only.
//!
//! * Build by insertion: [`Bvh::insert_triangles`] (Incr / IncrU, chosen by [`BvhConfig`]),
//!   [`Bvh::insert_triangles_parallel_search`] (IncrUP), [`Bvh::insert_triangles_block_parallel`] and
//!   [`BlockStream`] (IncrUPB); references by [`Bvh::build_top_down`] ([`TopDown`]).
//! * Edit: groups ([`Bvh::insert_group`], [`Bvh::set_group_transform`], [`Bvh::bake_group`],
//!   [`Bvh::remove_group`]), triangles ([`Bvh::remove_triangles`], [`Bvh::set_triangles`]);
//!   [`Bvh::reserve`] ahead of an edit whose latency matters.
//! * Query: [`Bvh::closest_hit`], [`Bvh::any_hit`], [`Bvh::overlapping_triangles`].
//! * Export: [`Bvh::gpu_node`] and [`Bvh::take_changes`] for GPUs, [`Bvh::write_tlbvh`] for files.
//! * Check: [`Bvh::validate`], [`Bvh::sah_cost`].

// Every public item says what it is for: the crate is meant to be used from other apps.
#![warn(missing_docs)]

mod aabb;
mod block;
pub mod build;
mod bvh;
mod change;
mod config;
mod error;
mod export;
mod gpu;
mod group;
mod insert;
mod node;
mod parallel;
mod quality;
mod ray;
mod recluster;
mod rotate;
mod search;
mod traverse;
mod treelet;
mod triangle;
mod update;

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

pub use aabb::Aabb;
pub use block::{BlockStream, batch_coherence, coherent_batches, crowding};
pub use build::{BuiltTree, TopDown};
pub use bvh::{Bvh, Instance};
pub use change::ChangeSet;
pub use config::{BatchBvh, BvhConfig, Inefficiency};
pub use error::BvhError;
pub use export::{FileBvh, FileNode, MAGIC, read_tlbvh};
pub use glam;
pub use gpu::{GpuInstance, GpuNode, GpuTriangle};
pub use group::{GroupId, PreparedGroup};
pub use insert::coherence;
pub use node::{InnerNode, MAX_INDEX, NONE, NodeKind, NodeRef};
pub use quality::TreeStats;
pub use ray::{Hit, Ray, RayData};
pub use search::SearchScratch;
pub use traverse::TraversalStats;
pub use triangle::{MAX_COORDINATE, Triangle, validate_triangles};
pub use update::{OptimizeCursor, PostMoves, PostPass, PostPassReport, TreeletSweep};
