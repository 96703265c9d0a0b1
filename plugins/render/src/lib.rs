//! # treelight_render
//!
//! The path-traced view of what `treelight_scene` tracks. This crate holds the camera settings
//! ([`PathTraced`]), the incremental upload plan that turns the engine's change sets into buffer writes
//! ([`UploadPlan`]), and the WGSL traversal kernel ([`PATHTRACE_WGSL`]).

mod upload;

pub use upload::{
    BufferKind, BufferWrite, UploadPlan, grown_capacity, instance_bytes, node_bytes, triangle_bytes,
};

use bevy::prelude::*;

/// The WGSL source of the traversal and path-tracing kernels (shared with the workspace's `shaders/`).
pub const PATHTRACE_WGSL: &str = include_str!("../../../shaders/pathtrace.wgsl");

/// What a path-traced camera shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum DebugView {
    /// The converged path-traced image.
    #[default]
    PathTraced,
    /// Surface base colour at the primary hit.
    Albedo,
    /// Shading normal at the primary hit.
    Normals,
    /// A colour per primary-hit triangle id.
    TriangleId,
    /// Nodes visited per primary ray: the tree's quality at a glance.
    Heatmap,
}

impl DebugView {
    /// The view's index as the shader reads it.
    pub fn shader_index(self) -> u32 {
        self as u32
    }
}

/// Turns a Bevy 3D camera into a live path-traced view.
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
pub struct PathTraced {
    /// Bounces after the primary hit.
    pub max_bounces: u32,
    /// Samples per pixel added each frame.
    pub samples_per_frame: u32,
    /// What to show.
    pub view: DebugView,
}

impl Default for PathTraced {
    fn default() -> Self {
        Self {
            max_bounces: 4,
            samples_per_frame: 1,
            view: DebugView::PathTraced,
        }
    }
}
