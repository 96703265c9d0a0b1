//! Top-down reference builders. Each produces a [`BuiltTree`] over a slice of primitive boxes, with
//! local ids, so that bBVHs can be built on worker threads and grafted into the global tree later.

mod binned;
mod median;
mod prims;
mod sweep;

pub use binned::build_binned;
pub use median::build_median;
pub(crate) use prims::{Box3A, Prims};
pub use sweep::build_sweep_sah;

use crate::tree::bvh::AreaSum;
use crate::tree::node::{InnerNode, NONE, NodeKind, NodeRef};
use crate::tree::triangle::validate_triangles;
use crate::{Aabb, Bvh, BvhConfig, BvhError, Triangle};

/// A bBVH over the primitives `order` lists, reordering `order`, built by spatial median splits into
/// `nodes` (`order.len() - 1` of them, indexed locally); returns its root.
pub(crate) fn build_batch_into(
    prims: &Prims,
    order: &mut [u32],
    nodes: &mut [InnerNode],
) -> NodeRef {
    median::build_median_into(prims, order, nodes)
}

/// A tree over primitives `0..n`: leaves are `NodeRef::leaf(local primitive index)`, inner nodes
/// index `nodes`.
#[derive(Clone, Debug, Default)]
pub struct BuiltTree {
    /// Inner nodes; `parent` is local too.
    pub nodes: Vec<InnerNode>,
    /// The root (a leaf when there is one primitive, none when there are none).
    pub root: NodeRef,
}

/// Which top-down builder to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TopDown {
    /// Full sweep over all split positions on all axes (the paper's "SAH").
    SweepSah,
    /// 32 bins per axis.
    BinnedSah,
    /// Spatial median of the centroid bounds on the longest axis.
    Median,
}

impl TopDown {
    /// Builds a tree over `boxes`.
    pub fn build(self, boxes: &[Aabb]) -> BuiltTree {
        match self {
            TopDown::SweepSah => build_sweep_sah(boxes),
            TopDown::BinnedSah => build_binned(boxes),
            TopDown::Median => build_median(boxes),
        }
    }
}

/// Assembles a [`BuiltTree`] from a split procedure: `split(start, range)` reorders `range`
/// (which is `order[start..start + range.len()]`, at least two primitives) and returns the split
/// position inside it, strictly between 0 and its length.
pub(crate) fn assemble(
    boxes: &[Aabb],
    order: &mut [u32],
    mut split: impl FnMut(usize, &mut [u32]) -> usize,
) -> BuiltTree {
    assemble_with_bounds(order, |s, range| {
        let aabb = range
            .iter()
            .fold(Aabb::EMPTY, |b, &p| b.union(&boxes[p as usize]));
        (split(s, range), aabb)
    })
}

/// [`assemble`] for a split procedure that also returns the bounds of the range's boxes (a builder
/// that passes over the range anyway saves the extra pass).
pub(crate) fn assemble_with_bounds(
    order: &mut [u32],
    mut split: impl FnMut(usize, &mut [u32]) -> (usize, Aabb),
) -> BuiltTree {
    let n = order.len();
    if n == 0 {
        return BuiltTree {
            nodes: Vec::new(),
            root: NodeRef::NONE,
        };
    }
    if n == 1 {
        return BuiltTree {
            nodes: Vec::new(),
            root: NodeRef::leaf(order[0]),
        };
    }
    let mut nodes: Vec<InnerNode> = Vec::with_capacity(n - 1);
    // (range start, range end, parent node, child slot)
    let mut stack: Vec<(usize, usize, u32, usize)> = vec![(0, n, NONE, 0)];
    while let Some((s, e, parent, slot)) = stack.pop() {
        let me = if e - s == 1 {
            NodeRef::leaf(order[s])
        } else {
            let (at, aabb) = split(s, &mut order[s..e]);
            let mid = s + at;
            debug_assert!(mid > s && mid < e);
            let i = nodes.len() as u32;
            nodes.push(InnerNode {
                aabb,
                children: [NodeRef::NONE; 2],
                parent,
            });
            stack.push((mid, e, i, 1));
            stack.push((s, mid, i, 0));
            NodeRef::inner(i)
        };
        if parent != NONE {
            nodes[parent as usize].children[slot] = me;
        }
    }
    BuiltTree {
        nodes,
        root: NodeRef::inner(0),
    }
}

impl BuiltTree {
    /// Sum of inner node areas (the part of Eq. 1 a builder controls).
    pub fn inner_area(&self) -> f32 {
        self.nodes.iter().map(|n| n.aabb.area()).sum()
    }
}

impl Bvh {
    /// A tree over `tris` (world space, ids in input order) built by a top-down builder.
    pub fn build_top_down(
        tris: &[Triangle],
        builder: TopDown,
        config: BvhConfig,
    ) -> Result<Bvh, BvhError> {
        validate_triangles(tris)?;
        let boxes: Vec<Aabb> = tris.iter().map(|t| t.aabb()).collect();
        // Our builders' boxes are exact: no refit.
        Bvh::graft_built(tris, &builder.build(&boxes), config, false)
    }

    /// A tree over `tris` with the structure of `built` (leaf `k` is triangle `k`), made by any
    /// builder, another library's included: the benchmark costs and traces other libraries' trees
    /// this way. Its boxes are recomputed from the triangles, so a caller's rounding cannot make the
    /// tree invalid; every triangle must be in exactly one leaf ([`Bvh::validate`] checks).
    pub fn from_built(
        tris: &[Triangle],
        built: &BuiltTree,
        config: BvhConfig,
    ) -> Result<Bvh, BvhError> {
        validate_triangles(tris)?;
        Bvh::graft_built(tris, built, config, true)
    }

    fn graft_built(
        tris: &[Triangle],
        built: &BuiltTree,
        config: BvhConfig,
        refit: bool,
    ) -> Result<Bvh, BvhError> {
        let mut bvh = Bvh::new(config);
        bvh.check_room(tris.len())?;
        let ids: Vec<u32> = tris.iter().map(|t| bvh.alloc_triangle(*t)).collect();
        let root = bvh.graft(built, &ids);
        if refit && !root.is_none() {
            bvh.refit_subtree(root);
        }
        if !root.is_none() {
            bvh.root = root;
            bvh.changes.root_changed = true;
        }
        Ok(bvh)
    }

    /// Copies `built` into the node arrays, mapping its leaf `k` to triangle `ids[k]`, and returns
    /// its root, detached.
    pub(crate) fn graft(&mut self, built: &BuiltTree, ids: &[u32]) -> NodeRef {
        self.graft_with(&built.nodes, built.root, ids, false)
    }

    /// [`Bvh::graft`] of the tree whose inner nodes are `nodes` (indexed locally) and whose root is
    /// `root`, putting the new inner nodes in the node update cache when `record` is set.
    pub(crate) fn graft_with(
        &mut self,
        nodes: &[InnerNode],
        root: NodeRef,
        ids: &[u32],
        record: bool,
    ) -> NodeRef {
        if root.is_none() {
            return NodeRef::NONE;
        }
        let root = if self.inner_free.is_empty() {
            // No slot is free, as in a tree being built: the nodes go to the end of the array in
            // their own order, so node `k` becomes `base + k`, with no slot map and the change log
            // marked as one range. IncrUPB grafts thousands of small bBVHs per build on its
            // owner's thread, so each node is written once, pushed in place, and enters the cache
            // without the per-node test of `record`.
            let base = self.inner.len() as u32;
            let end = base + nodes.len() as u32;
            self.changes.mark_new_inner(base..end);
            self.inner.reserve(nodes.len());
            let root = self.copy_built(
                nodes,
                root,
                ids,
                |k| base + k,
                |bvh, _, n| bvh.inner.push(n),
            );
            let record = record && self.cache.recording && self.config.global_updates;
            self.cache.queued.resize(end as usize, record);
            if record {
                self.cache.nodes.extend(base..end);
            }
            root
        } else {
            let mut slots = std::mem::take(&mut self.scratch.graft_slots);
            slots.clear();
            for _ in 0..nodes.len() {
                slots.push(self.alloc_inner());
            }
            let root = self.copy_built(
                nodes,
                root,
                ids,
                |k| slots[k as usize],
                |bvh, me, n| bvh.write_inner(me, AreaSum::Outside, |slot| *slot = n),
            );
            if record {
                for &me in &slots {
                    self.record(me);
                }
            }
            self.scratch.graft_slots = slots;
            root
        };
        self.set_parent(root, NONE);
        root
    }

    /// Writes built node `k` (of `nodes`, rooted at `root`) as inner node `slot(k)`, handing it to
    /// `place` in order of `k`; its leaf `k` becomes triangle `ids[k]`. Returns where the root went.
    // Inlined into each caller so that `slot` and `place` become plain arithmetic and a push or
    // a store: IncrUPB's owner grafts every bBVH through it.
    #[inline(always)]
    fn copy_built(
        &mut self,
        nodes: &[InnerNode],
        root: NodeRef,
        ids: &[u32],
        slot: impl Fn(u32) -> u32,
        mut place: impl FnMut(&mut Self, u32, InnerNode),
    ) -> NodeRef {
        let map_node = |r: NodeRef| match r.kind() {
            NodeKind::Inner => NodeRef::inner(slot(r.index())),
            NodeKind::Leaf => NodeRef::leaf(ids[r.index() as usize]),
            _ => r,
        };
        for (k, n) in nodes.iter().enumerate() {
            let me = slot(k as u32);
            let children = n.children.map(map_node);
            let parent = if n.parent == NONE {
                NONE
            } else {
                slot(n.parent)
            };
            place(
                self,
                me,
                InnerNode {
                    aabb: n.aabb,
                    children,
                    parent,
                },
            );
            for c in children {
                if c.kind() == NodeKind::Leaf {
                    self.tri.parent[c.index() as usize] = me;
                }
            }
        }
        map_node(root)
    }
}

/// Primitives below which a subtree is built on one thread.
const PARALLEL_THRESHOLD: usize = 1 << 12;

/// Binned SAH, with the two halves of every large node built in parallel (rayon).
pub fn build_binned_parallel(boxes: &[Aabb]) -> BuiltTree {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    build_binned_range(boxes, &Prims::new(boxes), &mut order)
}

fn build_binned_range(boxes: &[Aabb], prims: &Prims, order: &mut [u32]) -> BuiltTree {
    if order.len() < PARALLEL_THRESHOLD {
        return binned::build_binned_over(prims, order);
    }
    let whole = binned::Side::of(prims, order);
    let [left, _] = binned::split(prims, &mut binned::Bins::default(), order, &whole);
    let (l, r) = order.split_at_mut(left.count);
    let (a, b) = rayon::join(
        || build_binned_range(boxes, prims, l),
        || build_binned_range(boxes, prims, r),
    );
    merge(a, b, boxes)
}

/// A tree whose root has `a` and `b` as children.
fn merge(a: BuiltTree, b: BuiltTree, boxes: &[Aabb]) -> BuiltTree {
    let mut nodes = Vec::with_capacity(1 + a.nodes.len() + b.nodes.len());
    let aabb_of = |t: &BuiltTree| match t.root.kind() {
        NodeKind::Inner => t.nodes[t.root.index() as usize].aabb,
        NodeKind::Leaf => boxes[t.root.index() as usize],
        _ => Aabb::EMPTY,
    };
    let shift = |r: NodeRef, by: u32| {
        if r.is_inner() {
            NodeRef::inner(r.index() + by)
        } else {
            r
        }
    };
    let (oa, ob) = (1u32, 1 + a.nodes.len() as u32);
    let root_box = aabb_of(&a).union(&aabb_of(&b));
    nodes.push(InnerNode {
        aabb: root_box,
        children: [shift(a.root, oa), shift(b.root, ob)],
        parent: NONE,
    });
    for (tree, off) in [(&a, oa), (&b, ob)] {
        for n in &tree.nodes {
            let parent = if n.parent == NONE { 0 } else { n.parent + off };
            nodes.push(InnerNode {
                aabb: n.aabb,
                children: n.children.map(|c| shift(c, off)),
                parent,
            });
        }
    }
    BuiltTree {
        nodes,
        root: NodeRef::inner(0),
    }
}
