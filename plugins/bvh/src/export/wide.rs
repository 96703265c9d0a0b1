//! A 4-wide layout of the tree for the GPU, made by collapsing the binary tree: each wide node takes
//! its binary node's two children and keeps opening the child of largest surface area until it holds
//! four. Fewer, fuller nodes mean fewer loop iterations and stack operations per ray; one slab test
//! covers all four boxes, which the record stores as rows (all minimum x, then all maximum x, ...).
//! Leaves and instances keep their references; an instance's object-space subtree is collapsed once,
//! however many instances share it.

use crate::tree::node::{NodeKind, NodeRef};
use crate::{Aabb, Bvh, GpuLayout};
use bytemuck::{Pod, Zeroable};
use std::collections::HashMap;

/// One 4-wide node for the GPU, 112 bytes: the children's boxes as rows, then their references
/// (the [`NodeRef`] encoding, with inner references naming wide records; `NONE` for an empty slot,
/// whose box is empty so no ray enters it).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuWideNode {
    /// Minimum x of each child's box.
    pub min_x: [f32; 4],
    /// Maximum x of each child's box.
    pub max_x: [f32; 4],
    /// Minimum y.
    pub min_y: [f32; 4],
    /// Maximum y.
    pub max_y: [f32; 4],
    /// Minimum z.
    pub min_z: [f32; 4],
    /// Maximum z.
    pub max_z: [f32; 4],
    /// Child references.
    pub refs: [u32; 4],
}

impl Default for GpuWideNode {
    fn default() -> Self {
        let (lo, hi) = ([f32::INFINITY; 4], [f32::NEG_INFINITY; 4]);
        Self {
            min_x: lo,
            max_x: hi,
            min_y: lo,
            max_y: hi,
            min_z: lo,
            max_z: hi,
            refs: [NodeRef::NONE.0; 4],
        }
    }
}

impl GpuWideNode {
    /// Puts child `r`, with box `b`, in slot `k`.
    pub fn set_child(&mut self, k: usize, b: &Aabb, r: NodeRef) {
        self.min_x[k] = b.min.x;
        self.max_x[k] = b.max.x;
        self.min_y[k] = b.min.y;
        self.max_y[k] = b.max.y;
        self.min_z[k] = b.min.z;
        self.max_z[k] = b.max.z;
        self.refs[k] = r.0;
    }
}

/// The tree as 4-wide records (inner references name wide records).
pub type WideLayout = GpuLayout<GpuWideNode>;

impl Bvh {
    /// Collapses the whole tree into 4-wide records, breadth first from the root.
    pub fn gpu_wide_layout(&self) -> WideLayout {
        let mut out = WideLayout::default();
        let mut wide_of: HashMap<u32, u32> = HashMap::new();
        let mut queue: Vec<(u32, u32)> = Vec::new();
        let mut name = |r: NodeRef, nodes: &mut Vec<GpuWideNode>, queue: &mut Vec<(u32, u32)>| {
            if !r.is_inner() {
                return r.0;
            }
            let slot = *wide_of.entry(r.index()).or_insert_with(|| {
                nodes.push(GpuWideNode::default());
                let slot = nodes.len() as u32 - 1;
                queue.push((r.index(), slot));
                slot
            });
            NodeRef::inner(slot).0
        };
        out.root = name(self.root, &mut out.nodes, &mut queue);
        out.instances = self.gpu_instances_renamed(|r| name(r, &mut out.nodes, &mut queue));
        let mut next = 0;
        while next < queue.len() {
            let (binary, slot) = queue[next];
            next += 1;
            let mut kids: Vec<NodeRef> = self.inner[binary as usize].children.to_vec();
            while kids.len() < 4 {
                let open = kids
                    .iter()
                    .enumerate()
                    .filter(|(_, k)| k.kind() == NodeKind::Inner)
                    .max_by(|a, b| self.aabb(*a.1).area().total_cmp(&self.aabb(*b.1).area()))
                    .map(|(i, _)| i);
                let Some(i) = open else { break };
                let opened = kids.swap_remove(i);
                kids.extend(self.inner[opened.index() as usize].children);
            }
            let mut rec = GpuWideNode::default();
            for (k, &kid) in kids.iter().enumerate() {
                let named = NodeRef(name(kid, &mut out.nodes, &mut queue));
                rec.set_child(k, &self.aabb(kid), named);
            }
            out.nodes[slot as usize] = rec;
        }
        out
    }
}
