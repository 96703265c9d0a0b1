//! Where the path tracer's 4-wide records live: only at the inner nodes its traversal reads.
//!
//! A record ([`GpuCompressedNode`]) holds up to four children: a node's children, an inner child
//! expanded into its own two where that child has no record of its own. So a node without a record
//! needs a parent with one, and a root (of the global tree or of an instanced subtree) always has
//! one. Records go to alternate levels from the top down: a node owns one where its parent does
//! not, so every record with two inner children holds four. That is half the inner nodes, where
//! one record per inner node was written before and the traversal read the same half. (The fewest
//! records, found from the bottom up, are 41-46% of the inner nodes on the test scenes, but where
//! subtrees of unlike depths meet they leave records of three children: rays through them were 7%
//! slower in the median on llvmpipe, up to 18%.)
//!
//! The layout is kept in step with the tree from its change sets: each changed subtree is decided
//! again from its (unchanged) parent down, an unchanged inner child of a node newly expanded given
//! a record of its own; records are slots in an array with a free list, so an edit rewrites only
//! the records that hold what changed. The consumer that uploads owns the layout; the tree does
//! not carry it.

use crate::export::change::coalesce;
use crate::tree::flags::Flags;
use crate::tree::node::{FREE, NONE};
use crate::{Bvh, ChangeSet, GpuCompressedNode, GpuInstance, GpuWideNode, NodeRef};
use std::ops::Range;

/// The path tracer's record layout for one tree: which inner nodes own a record, and at which slot.
#[derive(Clone, Debug, Default)]
pub struct WideRecords {
    /// Per inner node: its record's slot, or [`NONE`] where it is expanded into its parent's.
    slot: Vec<u32>,
    /// Per slot: the inner node whose record it is, or [`NONE`] for a free slot.
    node: Vec<u32>,
    /// Free slots, reused first.
    free: Vec<u32>,
    /// Scratch, kept between updates so that their working lists grow once: per inner node
    /// whether the change set being applied names it, the tops of its changed subtrees, a walk's
    /// stack, the nodes decided or given a record (whose records and holders are rewritten), the
    /// roots given a record (whose instances are rewritten) and the slots to rewrite.
    marked: Flags,
    tops: Vec<u32>,
    stack: Vec<u32>,
    touched: Vec<u32>,
    new_roots: Vec<u32>,
    dirty: Vec<u32>,
}

/// What one [`WideRecords::update`] asks a renderer to write.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RecordChanges {
    /// Record slots to rewrite ([`WideRecords::record`]), as sorted disjoint ranges.
    pub ranges: Vec<Range<u32>>,
    /// Instances whose root record moved to another slot, beyond the change set's own instances.
    pub instances: Vec<u32>,
}

impl WideRecords {
    /// The layout of `bvh` as it is now, every record decided afresh.
    pub fn of(bvh: &Bvh) -> Self {
        let mut records = Self::default();
        records.update(bvh, &everything(bvh));
        records
    }

    /// Slots the GPU array must hold (the highest slot in use, plus one, at the most).
    pub fn capacity(&self) -> u32 {
        self.node.len() as u32
    }

    /// Records in use.
    pub fn live(&self) -> u32 {
        self.node.len() as u32 - self.free.len() as u32
    }

    /// The inner node whose record is at `slot`; `None` for a free slot.
    pub fn node_of(&self, slot: u32) -> Option<u32> {
        self.node.get(slot as usize).copied().filter(|&x| x != NONE)
    }

    /// Heap bytes the layout holds, scratch included.
    pub fn heap_bytes(&self) -> usize {
        use crate::tree::memory::vec_bytes;
        vec_bytes(&self.slot)
            + vec_bytes(&self.node)
            + vec_bytes(&self.free)
            + self.marked.heap_bytes()
            + vec_bytes(&self.tops)
            + vec_bytes(&self.stack)
            + vec_bytes(&self.touched)
            + vec_bytes(&self.new_roots)
            + vec_bytes(&self.dirty)
    }

    /// Applies `changes` (the tree's last [`Bvh::take_changes`]): decides again which of the
    /// changed nodes own a record and says which record slots and instances to rewrite.
    pub fn update(&mut self, bvh: &Bvh, changes: &ChangeSet) -> RecordChanges {
        let len = bvh.inner.len();
        if self.slot.len() < len {
            self.slot.resize(len, NONE);
        }
        self.marked.resize(0, false);
        self.marked.resize(len, false);
        self.tops.clear();
        self.touched.clear();
        self.new_roots.clear();
        self.dirty.clear();
        let live = |i: u32| bvh.inner[i as usize].parent != FREE;
        for r in &changes.inner_ranges {
            for i in r.clone() {
                if (i as usize) >= len {
                    continue;
                }
                if live(i) {
                    self.marked.set(i as usize, true);
                } else if self.slot[i as usize] != NONE {
                    let s = std::mem::replace(&mut self.slot[i as usize], NONE);
                    self.release(s);
                }
            }
        }
        // The tops of the changed subtrees, each decided from its parent down.
        for r in &changes.inner_ranges {
            for i in r.clone().filter(|&i| self.marked.get(i as usize)) {
                let p = bvh.inner[i as usize].parent;
                if p == NONE || !self.marked.get(p as usize) {
                    self.tops.push(i);
                }
            }
        }
        for k in 0..self.tops.len() {
            self.decide_below(bvh, self.tops[k]);
        }
        // Roots always own a record, whether or not the change set names them.
        if bvh.root.is_inner() {
            self.root_needs_record(bvh, bvh.root.index());
        }
        for &i in &changes.instances {
            if let Some(inst) = bvh.instance(i).filter(|inst| inst.root.is_inner()) {
                self.root_needs_record(bvh, inst.root.index());
            }
        }
        self.collect_dirty(bvh);
        // A root given a record here moves its instance's reference: rare (a root's record stays
        // while it lives), so the instances are looked through only then.
        let mut moved_roots = Vec::new();
        if !self.new_roots.is_empty() {
            self.new_roots.sort_unstable();
            for i in 0..bvh.instances.len() as u32 {
                if let Some(inst) = bvh.instance(i)
                    && inst.root.is_inner()
                    && self.new_roots.binary_search(&inst.root.index()).is_ok()
                {
                    moved_roots.push(i);
                }
            }
        }
        self.dirty.sort_unstable();
        self.dirty.dedup();
        RecordChanges {
            ranges: coalesce(&self.dirty),
            instances: moved_roots,
        }
    }

    /// The record at `slot`: its node's children, each inner child without a record of its own
    /// expanded into its two; inner references name records. A free slot's record has no children.
    pub fn record(&self, bvh: &Bvh, slot: u32) -> GpuCompressedNode {
        let mut wide = GpuWideNode::default();
        let x = self.node.get(slot as usize).copied().unwrap_or(NONE);
        if x == NONE {
            return GpuCompressedNode::quantize(&wide);
        }
        let mut k = 0;
        let mut put = |r: NodeRef| {
            wide.set_child(k, &bvh.aabb(r), self.gpu_ref(r));
            k += 1;
        };
        for c in bvh.inner[x as usize].children {
            if c.is_inner() && self.slot[c.index() as usize] == NONE {
                for g in bvh.inner[c.index() as usize].children {
                    put(g);
                }
            } else {
                put(c);
            }
        }
        GpuCompressedNode::quantize(&wide)
    }

    /// Every slot's record, for a first full upload.
    pub fn records(&self, bvh: &Bvh) -> Vec<GpuCompressedNode> {
        (0..self.capacity()).map(|s| self.record(bvh, s)).collect()
    }

    /// The root reference as the kernel reads it.
    pub fn root(&self, bvh: &Bvh) -> u32 {
        self.gpu_ref(bvh.root).0
    }

    /// Instance `i`'s record ([`Bvh::gpu_instance`]) with its root naming a record.
    pub fn instance(&self, bvh: &Bvh, i: u32) -> GpuInstance {
        let mut inst = bvh.gpu_instance(i);
        inst.root = self.gpu_ref(NodeRef(inst.root)).0;
        inst
    }

    /// `r` as a record names it: an inner node by its record's slot, anything else as it is.
    pub fn gpu_ref(&self, r: NodeRef) -> NodeRef {
        if r.is_inner() && !r.is_none() {
            NodeRef::inner(self.slot[r.index() as usize])
        } else {
            r
        }
    }

    /// Whether the layout holds for `bvh`: every live inner node owns a record or has a parent that
    /// does, roots own one, and slots and nodes name each other. Says what is wrong otherwise.
    pub fn check(&self, bvh: &Bvh) -> Result<(), String> {
        for (i, n) in bvh.inner.iter().enumerate() {
            if n.parent == FREE {
                continue;
            }
            let s = self.slot.get(i).copied().unwrap_or(NONE);
            if s == NONE {
                if n.parent == NONE {
                    return Err(format!("root {i} has no record"));
                }
                if self.slot[n.parent as usize] == NONE {
                    return Err(format!("{i} and its parent {} have no record", n.parent));
                }
            } else if self.node.get(s as usize) != Some(&(i as u32)) {
                return Err(format!("node {i}'s slot {s} names another node"));
            }
        }
        for (s, &x) in self.node.iter().enumerate() {
            if x != NONE && self.slot.get(x as usize) != Some(&(s as u32)) {
                return Err(format!("slot {s} names node {x}, whose slot is another"));
            }
            if x != NONE && bvh.inner[x as usize].parent == FREE {
                return Err(format!("slot {s} holds freed node {x}"));
            }
        }
        let free = self.node.iter().filter(|&&x| x == NONE).count();
        if free != self.free.len() {
            return Err(format!("{free} free slots, {} listed", self.free.len()));
        }
        Ok(())
    }

    /// Decides the changed nodes under `top` (itself included) from the top down: a node owns a
    /// record when it is a root or its parent has none, and is expanded into its parent's record
    /// otherwise, its inner children then given records of their own where they had none. Slots
    /// go out in the same depth-first order, so a fresh tree's records lie as the traversal meets
    /// them.
    fn decide_below(&mut self, bvh: &Bvh, top: u32) {
        self.stack.clear();
        self.stack.push(top);
        while let Some(x) = self.stack.pop() {
            let n = &bvh.inner[x as usize];
            let own = n.parent == NONE || self.slot[n.parent as usize] == NONE;
            let s = self.slot[x as usize];
            if own && s == NONE {
                self.give_record(bvh, x);
            } else if !own && s != NONE {
                self.slot[x as usize] = NONE;
                self.release(s);
            }
            self.touched.push(x);
            // Right first, so the left child is handed its slot first.
            for c in n.children.into_iter().rev() {
                if !c.is_inner() || c.is_none() {
                    continue;
                }
                let c = c.index();
                if self.marked.get(c as usize) {
                    self.stack.push(c);
                } else if !own && self.slot[c as usize] == NONE {
                    self.give_record(bvh, c);
                    self.touched.push(c);
                }
            }
        }
    }

    fn root_needs_record(&mut self, bvh: &Bvh, r: u32) {
        if self.slot[r as usize] == NONE {
            self.give_record(bvh, r);
            self.touched.push(r);
        }
    }

    /// Gives `x`, without a record, a slot; a root's is listed, as its instance names it.
    fn give_record(&mut self, bvh: &Bvh, x: u32) {
        self.slot[x as usize] = self.allocate(x);
        if bvh.inner[x as usize].parent == NONE {
            self.new_roots.push(x);
        }
    }

    /// The slots to rewrite: each touched node's own record and the record that holds its box
    /// and reference (its parent's, or its grandparent's where the parent is expanded).
    fn collect_dirty(&mut self, bvh: &Bvh) {
        for &x in &self.touched {
            let s = self.slot[x as usize];
            if s != NONE {
                self.dirty.push(s);
            }
            let p = bvh.inner[x as usize].parent;
            if p == NONE {
                continue;
            }
            let ps = self.slot[p as usize];
            if ps != NONE {
                self.dirty.push(ps);
            } else {
                let g = bvh.inner[p as usize].parent;
                if g != NONE && self.slot[g as usize] != NONE {
                    self.dirty.push(self.slot[g as usize]);
                }
            }
        }
        // A freed node's slot is not rewritten: the records that named it hold its parent's
        // children, and the parent is in the change set.
    }

    fn allocate(&mut self, x: u32) -> u32 {
        match self.free.pop() {
            Some(s) => {
                self.node[s as usize] = x;
                s
            }
            None => {
                self.node.push(x);
                self.node.len() as u32 - 1
            }
        }
    }

    fn release(&mut self, s: u32) {
        self.node[s as usize] = NONE;
        self.free.push(s);
    }
}

/// A change set naming every inner node and instance, for a layout made afresh.
fn everything(bvh: &Bvh) -> ChangeSet {
    ChangeSet {
        inner_ranges: std::iter::once(0..bvh.inner.len() as u32).collect(),
        instances: (0..bvh.instances.len() as u32).collect(),
        root_changed: true,
        inner_capacity: bvh.inner.len() as u32,
        ..ChangeSet::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Triangle;
    use glam::{Affine3A, Vec3};

    /// `n` small triangles along x.
    fn strip(n: usize) -> Vec<Triangle> {
        (0..n)
            .map(|k| {
                let x = k as f32;
                Triangle::new(
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x + 0.5, 0.0, 0.0),
                    Vec3::new(x, 1.0, 0.0),
                )
            })
            .collect()
    }

    #[test]
    fn an_instance_whose_root_gains_a_record_is_listed_for_rewriting() {
        let mut bvh = Bvh::default();
        bvh.insert_group(&strip(2), Affine3A::IDENTITY, false)
            .unwrap();
        bvh.insert_group(&strip(16), Affine3A::from_translation(Vec3::Z), true)
            .unwrap();
        let mut records = WideRecords::of(&bvh);
        records.check(&bvh).unwrap();
        let i = (0..bvh.instances.len() as u32)
            .find(|&i| bvh.instance(i).is_some())
            .unwrap();
        let root = bvh.instances[i as usize].root.index();
        // An inner child of the instance's root: expanded into the root's record, so without one.
        let child = bvh.inner[root as usize]
            .children
            .into_iter()
            .find(|c| c.is_inner())
            .unwrap()
            .index();
        assert_eq!(records.slot[child as usize], NONE);
        // The child becomes the instance's root (as an edit inside the group may leave it), the
        // change set naming the nodes but not the instance: its reference moves all the same.
        bvh.inner[child as usize].parent = NONE;
        bvh.instances[i as usize].root = NodeRef::inner(child);
        let changes = ChangeSet {
            inner_ranges: std::iter::once(child..child + 1).collect(),
            inner_capacity: bvh.inner.len() as u32,
            ..ChangeSet::default()
        };
        let rewrite = records.update(&bvh, &changes);
        assert_eq!(rewrite.instances, vec![i]);
        let slot = records.instance(&bvh, i).root;
        assert_eq!(records.node_of(NodeRef(slot).index()), Some(child));
    }
}
