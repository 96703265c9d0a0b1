//! The flat layout a GPU traverses, and the change log that lets a renderer upload only what changed.
//!
//! Inner node `i` becomes record `i` of 64 bytes holding both children's boxes and tagged references
//! (the [`NodeRef`] encoding: two high bits of kind). Leaves need no record: a child reference of kind
//! leaf is a triangle id. Freed slots are written as records with null children.

use crate::tree::node::{FREE, NodeRef};
use crate::{Bvh, ChangeSet};
use bytemuck::{Pod, Zeroable};
use glam::Affine3A;

/// One inner node for the GPU: two child boxes, 64 bytes, 16-byte aligned fields.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuNode {
    /// Left child's box minimum.
    pub a_min: [f32; 3],
    /// Left child reference.
    pub a_ref: u32,
    /// Left child's box maximum.
    pub a_max: [f32; 3],
    /// Right child reference.
    pub b_ref: u32,
    /// Right child's box minimum.
    pub b_min: [f32; 3],
    /// Padding (the GPU traverses with a stack and needs no parent links).
    pub pad0: u32,
    /// Right child's box maximum.
    pub b_max: [f32; 3],
    /// Padding to 64 bytes.
    pub pad1: u32,
}

/// One triangle for the GPU: three vertices, 36 bytes, no padding. A renderer that keeps each
/// group's vertices once reads [`crate::GpuIndexedTriangle`] and a [`crate::PositionPool`] instead.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    /// Vertex 0.
    pub v0: [f32; 3],
    /// Vertex 1.
    pub v1: [f32; 3],
    /// Vertex 2.
    pub v2: [f32; 3],
}

/// One instance for the GPU: both affine maps as row-major 3×4 matrices, and the object-space root.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInstance {
    /// World to object, applied to rays.
    pub world_to_object: [[f32; 4]; 3],
    /// Object to world, applied to hit points and normals.
    pub object_to_world: [[f32; 4]; 3],
    /// Root of the object-space subtree (a [`NodeRef`]).
    pub root: u32,
    /// Slot of the group the instance places ([`crate::GroupId::index`]): groups that share
    /// triangles tell their hits apart by it (materials, normals).
    pub group: u32,
    /// Padding.
    pub pad1: u32,
    /// Padding to 112 bytes.
    pub pad2: u32,
}

fn rows(t: &Affine3A) -> [[f32; 4]; 3] {
    let m = t.matrix3;
    let c = t.translation;
    [
        [m.x_axis.x, m.y_axis.x, m.z_axis.x, c.x],
        [m.x_axis.y, m.y_axis.y, m.z_axis.y, c.y],
        [m.x_axis.z, m.y_axis.z, m.z_axis.z, c.z],
    ]
}

/// The whole tree's records in a layout other than the engine's own arrays (`N` is the node record):
/// nodes, the root reference, and the instances with their roots renamed to match. Triangles are
/// [`Bvh::gpu_triangle`]'s, unchanged.
#[derive(Clone, Debug, Default)]
pub struct GpuLayout<N> {
    /// Node records, the root's first.
    pub nodes: Vec<N>,
    /// The root reference (inner references name `nodes`).
    pub root: u32,
    /// Instance records, as [`Bvh::gpu_instance`] with each root renamed.
    pub instances: Vec<GpuInstance>,
}

impl Bvh {
    /// Every instance record with its root renamed by `rename` (a free slot keeps its null root).
    pub(crate) fn gpu_instances_renamed(
        &self,
        mut rename: impl FnMut(NodeRef) -> u32,
    ) -> Vec<GpuInstance> {
        (0..self.instances.len() as u32)
            .map(|i| {
                let mut rec = self.gpu_instance(i);
                if rec.root != NodeRef::NONE.0 {
                    rec.root = rename(NodeRef(rec.root));
                }
                rec
            })
            .collect()
    }

    /// The record of inner node `i` (a null record for a freed slot).
    pub fn gpu_node(&self, i: u32) -> GpuNode {
        let n = &self.inner[i as usize];
        if n.parent == FREE {
            return GpuNode {
                a_ref: NodeRef::NONE.0,
                b_ref: NodeRef::NONE.0,
                ..Default::default()
            };
        }
        let (a, b) = (self.aabb(n.children[0]), self.aabb(n.children[1]));
        GpuNode {
            a_min: a.min.to_array(),
            a_ref: n.children[0].0,
            a_max: a.max.to_array(),
            b_ref: n.children[1].0,
            b_min: b.min.to_array(),
            pad0: 0,
            b_max: b.max.to_array(),
            pad1: 0,
        }
    }

    /// Triangle `id` as stored (object space for groups kept whole); zeros for a freed slot.
    pub fn gpu_triangle(&self, id: u32) -> GpuTriangle {
        match self.triangle(id) {
            Some(t) => GpuTriangle {
                v0: t.v[0].to_array(),
                v1: t.v[1].to_array(),
                v2: t.v[2].to_array(),
            },
            None => GpuTriangle::default(),
        }
    }

    /// Instance `i`; a null root for a freed slot.
    pub fn gpu_instance(&self, i: u32) -> GpuInstance {
        match self.instance(i) {
            Some(inst) => GpuInstance {
                world_to_object: rows(&inst.inverse),
                object_to_world: rows(&inst.transform),
                root: inst.root.0,
                group: inst.group,
                ..Default::default()
            },
            None => GpuInstance {
                root: NodeRef::NONE.0,
                ..Default::default()
            },
        }
    }

    /// The root reference as the GPU reads it (a single leaf or instance root is possible).
    pub fn gpu_root(&self) -> u32 {
        self.root.0
    }

    /// All node records, for a first full upload.
    pub fn gpu_nodes(&self) -> Vec<GpuNode> {
        (0..self.inner.len() as u32)
            .map(|i| self.gpu_node(i))
            .collect()
    }

    /// What changed since the last call (or since construction): node ranges to rewrite, triangles
    /// written and removed, instances changed. Clears the log.
    pub fn take_changes(&mut self) -> ChangeSet {
        let sizes = (
            self.inner.len() as u32,
            self.tri.parent.len() as u32,
            self.instances.len() as u32,
        );
        let parents = &self.tri.parent;
        self.changes.take(|t| parents[t as usize] != FREE, sizes)
    }

    /// Marks everything as changed, for a consumer that lost its copy and must start over.
    pub fn mark_all_changed(&mut self) {
        self.changes.mark_all(
            self.inner.len() as u32,
            self.tri.parent.len() as u32,
            self.instances.len() as u32,
        );
    }
}
