//! The tree: flat arrays indexed by `u32` with free lists, and the primitive edits every builder and
//! editing operation is made of (link a node next to a sibling, unlink a node, refit upwards).

use crate::change::ChangeLog;
use crate::group::Group;
use crate::node::{FREE, InnerNode, MAX_INDEX, NONE, NodeKind, NodeRef};
use crate::search::SearchScratch;
use crate::{Aabb, BvhConfig, BvhError, Triangle};
use glam::Affine3A;

/// A transformed group's root in the global tree: a leaf-like node whose box is the world box of
/// its object-space subtree; traversal carries the ray into object space here.
#[derive(Clone, Copy, Debug)]
pub struct Instance {
    /// World-space bounds.
    pub aabb: Aabb,
    /// Parent inner node in the global tree, or [`NONE`].
    pub parent: u32,
    /// Root of the object-space subtree.
    pub root: NodeRef,
    /// Object to world.
    pub transform: Affine3A,
    /// World to object, applied to rays.
    pub inverse: Affine3A,
    /// Index of the owning group, or `u32::MAX - 1` for a freed slot.
    pub group: u32,
}

/// A bounding volume hierarchy over triangles, built and edited incrementally.
#[derive(Clone)]
pub struct Bvh {
    pub(crate) inner: Vec<InnerNode>,
    pub(crate) inner_free: Vec<u32>,
    pub(crate) tris: Vec<Triangle>,
    pub(crate) tri_box: Vec<Aabb>,
    /// Parent inner node of each triangle's leaf; [`FREE`] for a freed triangle slot.
    pub(crate) tri_parent: Vec<u32>,
    /// Group of each triangle, or [`NONE`].
    pub(crate) tri_group: Vec<u32>,
    pub(crate) tri_free: Vec<u32>,
    pub(crate) instances: Vec<Instance>,
    pub(crate) inst_free: Vec<u32>,
    pub(crate) groups: Vec<Group>,
    pub(crate) group_free: Vec<u32>,
    pub(crate) root: NodeRef,
    pub(crate) config: BvhConfig,
    /// Node update cache: inner nodes whose boxes insertions changed since the last update batch.
    pub(crate) cache: Vec<u32>,
    pub(crate) in_cache: Vec<bool>,
    pub(crate) recording: bool,
    pub(crate) changes: ChangeLog,
    pub(crate) scratch: SearchScratch,
    /// Ranked candidates of an update batch, kept between batches so that batches allocate nothing.
    pub(crate) update_candidates: Vec<(f32, u32)>,
    /// Node slots of the bBVH being grafted, reused from graft to graft (IncrUPB grafts thousands).
    pub(crate) graft_slots: Vec<u32>,
    pub(crate) update_ops: u64,
    /// Treelet restructuring's tables (8 KiB), made on first use and kept, so that later passes
    /// and update batches allocate nothing (see `Bvh::with_treelet_scratch`).
    pub(crate) treelet_scratch: Option<Box<crate::treelet::TreeletScratch>>,
    pub(crate) live_tris: u32,
    /// Running sum of changes to the global tree's inner node areas. Links, unlinks, refits, moves,
    /// rotations and treelets keep its changes exact, so a move's effect on Eq. 1, and a post-pass
    /// round's cost, are known without recosting the tree. It is not the sum itself: a subtree
    /// linked whole (a cluster pair, a bBVH) enters with its new parent's area only.
    pub(crate) area_acc: f64,
}

impl Default for Bvh {
    fn default() -> Self {
        Self::new(BvhConfig::default())
    }
}

impl Bvh {
    /// An empty tree.
    pub fn new(config: BvhConfig) -> Self {
        Self {
            inner: Vec::new(),
            inner_free: Vec::new(),
            tris: Vec::new(),
            tri_box: Vec::new(),
            tri_parent: Vec::new(),
            tri_group: Vec::new(),
            tri_free: Vec::new(),
            instances: Vec::new(),
            inst_free: Vec::new(),
            groups: Vec::new(),
            group_free: Vec::new(),
            root: NodeRef::NONE,
            config,
            cache: Vec::new(),
            in_cache: Vec::new(),
            recording: true,
            changes: ChangeLog::default(),
            scratch: SearchScratch::default(),
            update_candidates: Vec::new(),
            graft_slots: Vec::new(),
            update_ops: 0,
            treelet_scratch: None,
            live_tris: 0,
            area_acc: 0.0,
        }
    }

    /// The configuration in use.
    pub fn config(&self) -> &BvhConfig {
        &self.config
    }

    /// Changes the configuration; takes effect from the next operation.
    pub fn set_config(&mut self, config: BvhConfig) {
        self.config = config;
    }

    /// Root of the global tree ([`NodeRef::NONE`] when empty).
    pub fn root(&self) -> NodeRef {
        self.root
    }

    /// Number of live triangles (leaves), baked and instanced.
    pub fn triangle_count(&self) -> u32 {
        self.live_tris
    }

    /// Length of the triangle array, free slots included: the bound of triangle ids.
    pub fn triangle_capacity(&self) -> u32 {
        self.tris.len() as u32
    }

    /// Number of live inner nodes.
    pub fn inner_count(&self) -> u32 {
        (self.inner.len() - self.inner_free.len()) as u32
    }

    /// Length of the inner node array, free slots included: the bound of inner node ids.
    pub fn inner_capacity(&self) -> u32 {
        self.inner.len() as u32
    }

    /// Number of instance slots, free ones included.
    pub fn instance_capacity(&self) -> u32 {
        self.instances.len() as u32
    }

    /// Global updates (re-insertions) performed so far.
    pub fn update_ops(&self) -> u64 {
        self.update_ops
    }

    /// Triangle `id` as stored: world space, or object space for an instanced group.
    pub fn triangle(&self, id: u32) -> Option<&Triangle> {
        self.is_live_triangle(id).then(|| &self.tris[id as usize])
    }

    /// Whether `id` names a live triangle.
    pub fn is_live_triangle(&self, id: u32) -> bool {
        (id as usize) < self.tris.len() && self.tri_parent[id as usize] != FREE
    }

    /// The inner node `i`, if it is live.
    pub fn inner_node(&self, i: u32) -> Option<&InnerNode> {
        self.inner.get(i as usize).filter(|n| n.parent != FREE)
    }

    /// Instance `i`, if it is live.
    pub fn instance(&self, i: u32) -> Option<&Instance> {
        self.instances.get(i as usize).filter(|n| n.group != FREE)
    }

    /// Bounds of the whole scene (world space).
    pub fn bounds(&self) -> Aabb {
        if self.root.is_none() {
            Aabb::EMPTY
        } else {
            self.aabb(self.root)
        }
    }

    // ---- node access -------------------------------------------------------------------------

    /// Box of any node.
    #[inline]
    pub fn aabb(&self, r: NodeRef) -> Aabb {
        match r.kind() {
            NodeKind::Inner => self.inner[r.index() as usize].aabb,
            NodeKind::Leaf => self.tri_box[r.index() as usize],
            NodeKind::Instance => self.instances[r.index() as usize].aabb,
            NodeKind::None => Aabb::EMPTY,
        }
    }

    /// Whether any kept-whole group (instance) is live: without one, every live node with a
    /// parent hangs from the global root, which lets several passes scan the flat arrays.
    #[inline]
    pub(crate) fn has_live_instances(&self) -> bool {
        self.instances.len() != self.inst_free.len()
    }

    /// Parent inner node of any node, or [`NONE`].
    #[inline]
    pub fn parent(&self, r: NodeRef) -> u32 {
        match r.kind() {
            NodeKind::Inner => self.inner[r.index() as usize].parent,
            NodeKind::Leaf => self.tri_parent[r.index() as usize],
            NodeKind::Instance => self.instances[r.index() as usize].parent,
            NodeKind::None => NONE,
        }
    }

    #[inline]
    pub(crate) fn set_parent(&mut self, r: NodeRef, p: u32) {
        match r.kind() {
            NodeKind::Inner => self.inner[r.index() as usize].parent = p,
            NodeKind::Leaf => self.tri_parent[r.index() as usize] = p,
            NodeKind::Instance => self.instances[r.index() as usize].parent = p,
            NodeKind::None => {}
        }
    }

    // ---- allocation ----------------------------------------------------------------------------

    pub(crate) fn alloc_inner(&mut self) -> u32 {
        let node = InnerNode::UNLINKED;
        if let Some(i) = self.inner_free.pop() {
            self.inner[i as usize] = node;
            i
        } else {
            let i = self.inner.len() as u32;
            self.inner.push(node);
            self.in_cache.push(false);
            self.changes.grow_inner(self.inner.len());
            i
        }
    }

    pub(crate) fn free_inner(&mut self, i: u32) {
        self.inner[i as usize].parent = FREE;
        self.inner[i as usize].children = [NodeRef::NONE; 2];
        self.inner_free.push(i);
        self.changes.mark_inner(i);
    }

    /// Checks that `extra` more triangles fit in 30-bit ids.
    pub(crate) fn check_room(&self, extra: usize) -> Result<(), BvhError> {
        let tris = self.tris.len() - self.tri_free.len() + extra;
        if tris > MAX_INDEX as usize / 2 {
            return Err(BvhError::TooLarge {
                limit: MAX_INDEX / 2,
            });
        }
        Ok(())
    }

    /// Stores a triangle (not yet in the tree) and returns its id.
    pub(crate) fn alloc_triangle(&mut self, t: Triangle, group: u32) -> u32 {
        let id = if let Some(id) = self.tri_free.pop() {
            self.tris[id as usize] = t;
            self.tri_box[id as usize] = t.aabb();
            self.tri_parent[id as usize] = NONE;
            self.tri_group[id as usize] = group;
            id
        } else {
            let id = self.tris.len() as u32;
            self.tris.push(t);
            self.tri_box.push(t.aabb());
            self.tri_parent.push(NONE);
            self.tri_group.push(group);
            id
        };
        self.live_tris += 1;
        self.changes.mark_triangle(id, self.tris.len());
        id
    }

    /// Allocates ids for `tris`, in input order, growing the arrays by slices rather than
    /// triangle by triangle (see [`Bvh::alloc_triangles_boxed`]).
    pub(crate) fn alloc_triangles(&mut self, tris: &[Triangle]) -> Vec<u32> {
        let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
        let mut ids = Vec::with_capacity(tris.len());
        self.alloc_triangles_boxed(tris, &boxes, &mut ids);
        ids
    }

    /// Allocates ids for `tris`, whose boxes `boxes` are already known, appending them to `ids`.
    /// Reuses free slots first like [`Bvh::alloc_triangle`]; the rest are appended to the arrays as
    /// slices, which for a fresh tree is every triangle.
    pub(crate) fn alloc_triangles_boxed(
        &mut self,
        tris: &[Triangle],
        boxes: &[Aabb],
        ids: &mut Vec<u32>,
    ) {
        let reused = self.tri_free.len().min(tris.len());
        for &t in &tris[..reused] {
            ids.push(self.alloc_triangle(t, NONE));
        }
        let (tris, boxes) = (&tris[reused..], &boxes[reused..]);
        let first = self.tris.len() as u32;
        let end = self.tris.len() + tris.len();
        self.tris.extend_from_slice(tris);
        self.tri_box.extend_from_slice(boxes);
        self.tri_parent.resize(end, NONE);
        self.tri_group.resize(end, NONE);
        self.live_tris += tris.len() as u32;
        ids.extend(first..end as u32);
        self.changes.mark_new_triangles(first..end as u32);
    }

    /// Makes room for `triangles` more triangles, and the inner nodes they bring, without inserting
    /// anything: a later insertion of up to that many then grows no array. Growth doubles the
    /// arrays, cheap per triangle, but once a tree holds ~100k triangles it is a copy of megabytes
    /// inside one small insertion (the first edit after a build paid 1–4 ms for 74 triangles on
    /// Sibenik). Call this ahead of edits whose latency matters more than memory.
    pub fn reserve(&mut self, triangles: usize) {
        self.reserve_triangles(triangles);
        let fresh = triangles.saturating_sub(self.inner_free.len());
        self.inner.reserve(fresh);
        self.in_cache.reserve(fresh);
        self.changes.reserve_inner(self.inner.len() + fresh);
    }

    /// Makes room for `n` more triangles at once, so a large batch does not grow the arrays step
    /// by step.
    pub(crate) fn reserve_triangles(&mut self, n: usize) {
        let fresh = n.saturating_sub(self.tri_free.len());
        self.tris.reserve(fresh);
        self.tri_box.reserve(fresh);
        self.tri_parent.reserve(fresh);
        self.tri_group.reserve(fresh);
        self.changes.reserve_triangles(self.tris.len() + fresh, n);
    }

    pub(crate) fn free_triangle(&mut self, id: u32) {
        self.tri_parent[id as usize] = FREE;
        self.tri_group[id as usize] = NONE;
        self.tri_free.push(id);
        self.live_tris -= 1;
        self.changes.mark_triangle(id, self.tris.len());
    }

    pub(crate) fn alloc_instance(&mut self, inst: Instance) -> u32 {
        let i = if let Some(i) = self.inst_free.pop() {
            self.instances[i as usize] = inst;
            i
        } else {
            self.instances.push(inst);
            self.instances.len() as u32 - 1
        };
        self.changes.mark_instance(i);
        i
    }

    pub(crate) fn free_instance(&mut self, i: u32) {
        self.instances[i as usize].group = FREE;
        self.instances[i as usize].parent = FREE;
        self.inst_free.push(i);
        self.changes.mark_instance(i);
    }

    // ---- structural edits ----------------------------------------------------------------------

    /// Makes `l` the sibling of `x` under the fresh inner node `p`, which takes `x`'s place, then
    /// refits upwards. `l` must be detached.
    pub(crate) fn link(&mut self, l: NodeRef, x: NodeRef, p: u32) {
        let xp = self.parent(x);
        let aabb = self.aabb(x).union(&self.aabb(l));
        self.inner[p as usize] = InnerNode {
            aabb,
            children: [x, l],
            parent: xp,
        };
        self.area_acc += aabb.area() as f64;
        self.set_parent(x, p);
        self.set_parent(l, p);
        self.changes.mark_inner(p);
        self.record(p);
        if xp == NONE {
            self.root = NodeRef::inner(p);
            self.changes.root_changed = true;
        } else {
            let node = &mut self.inner[xp as usize];
            let slot = (node.children[1] == x) as usize;
            node.children[slot] = NodeRef::inner(p);
            self.changes.mark_inner(xp);
            self.grow_from(xp, &aabb);
        }
    }

    /// Inserts the detached node `l` (a leaf, an instance or a subtree root) at the best position
    /// found by the branch-and-bound search, using `p` as the new inner node.
    pub(crate) fn insert_node_with(&mut self, l: NodeRef, p: u32) {
        if self.root.is_none() {
            self.free_inner(p);
            self.root = l;
            self.set_parent(l, NONE);
            self.changes.root_changed = true;
            return;
        }
        self.insert_node_from(l, p, self.root);
    }

    /// [`Bvh::insert_node_with`] with the search seeded by `hint`, a node of the tree: it becomes
    /// `l`'s sibling unless the search finds a strictly better one. A re-insertion passes the node's
    /// old sibling; a fresh insertion the root. The tree must not be empty.
    pub(crate) fn insert_node_from(&mut self, l: NodeRef, p: u32, hint: NodeRef) {
        let bl = self.aabb(l);
        let mut scratch = std::mem::take(&mut self.scratch);
        let x = self.find_best_sibling_from(&bl, hint, &mut scratch);
        self.scratch = scratch;
        self.link(l, x, p);
    }

    /// Inserts the detached node `l` at the best position.
    pub(crate) fn insert_node(&mut self, l: NodeRef) {
        if self.root.is_none() {
            self.root = l;
            self.set_parent(l, NONE);
            self.changes.root_changed = true;
            return;
        }
        let p = self.alloc_inner();
        self.insert_node_with(l, p);
    }

    /// Detaches `n` (with its subtree) from the global tree. Its sibling takes the parent's place;
    /// the parent node is detached too and returned for reuse ([`NONE`] if `n` was the root).
    pub(crate) fn unlink(&mut self, n: NodeRef) -> u32 {
        let p = self.parent(n);
        self.set_parent(n, NONE);
        if p == NONE {
            debug_assert_eq!(self.root, n);
            self.root = NodeRef::NONE;
            self.changes.root_changed = true;
            return NONE;
        }
        let pn = self.inner[p as usize];
        let s = if pn.children[0] == n {
            pn.children[1]
        } else {
            pn.children[0]
        };
        let g = pn.parent;
        self.set_parent(s, g);
        self.area_acc -= pn.aabb.area() as f64;
        self.inner[p as usize].parent = NONE;
        self.inner[p as usize].children = [NodeRef::NONE; 2];
        self.changes.mark_inner(p);
        if g == NONE {
            self.root = s;
            self.changes.root_changed = true;
        } else {
            let gn = &mut self.inner[g as usize];
            let slot = (gn.children[1] == NodeRef::inner(p)) as usize;
            gn.children[slot] = s;
            self.changes.mark_inner(g);
            let removed = self.aabb(n);
            self.shrink_from(g, &removed);
        }
        p
    }

    /// [`Bvh::refit_from`] after an unlink took a subtree with box `removed` from below inner node
    /// `i`: a box that `removed` lies strictly inside on all six sides keeps every side, since
    /// what reaches each side lies outside the removed subtree, so the refit stops there without
    /// reading the children's boxes; other boxes are recomputed from their children.
    pub(crate) fn shrink_from(&mut self, i: u32, removed: &Aabb) {
        self.refit_with(i, |bvh, i| {
            let old = &bvh.inner[i as usize].aabb;
            let inside = removed.min.cmpgt(old.min).all() && removed.max.cmplt(old.max).all();
            (!inside).then(|| bvh.children_union(i))
        });
    }

    /// Recomputes boxes from inner node `i` upwards, stopping where a box no longer changes
    /// (above that point every box already contains what lies below). A node's GPU record holds its
    /// children's boxes, so every node reached is marked changed: its child's box just changed.
    pub(crate) fn refit_from(&mut self, i: u32) {
        self.refit_with(i, |bvh, i| Some(bvh.children_union(i)));
    }

    /// [`Bvh::refit_from`] after a link: the boxes from inner node `i` upwards take in `b`, the
    /// box of what was linked below them, stopping at the first that already holds it. Each box
    /// comes out the same, bit for bit, as the union of its children (every box was that union
    /// before, and one child grew by `b`), but without reading the other child's box at each
    /// level, a load that the refit's profile showed missing the cache.
    pub(crate) fn grow_from(&mut self, i: u32, b: &Aabb) {
        self.refit_with(i, |bvh, i| Some(bvh.inner[i as usize].aabb.union(b)));
    }

    /// The walk the refits share: from inner node `i` upwards, mark each node reached, take the
    /// box `next_box` gives it (none: it keeps its own), and stop at the first whose box is
    /// unchanged, keeping the area sum and the update cache in step.
    #[inline(always)]
    fn refit_with(&mut self, mut i: u32, next_box: impl Fn(&Self, u32) -> Option<Aabb>) {
        while i != NONE {
            self.changes.mark_inner(i);
            let Some(aabb) = next_box(self, i) else {
                break;
            };
            let node = &mut self.inner[i as usize];
            if node.aabb == aabb {
                break;
            }
            self.area_acc += aabb.area() as f64 - node.aabb.area() as f64;
            node.aabb = aabb;
            let parent = node.parent;
            self.record(i);
            i = parent;
        }
    }

    /// The union of inner node `i`'s children's boxes.
    #[inline]
    fn children_union(&self, i: u32) -> Aabb {
        let [a, b] = self.inner[i as usize].children;
        self.aabb(a).union(&self.aabb(b))
    }

    /// Adds an inner node to the node update cache while insertions are recorded.
    #[inline]
    pub(crate) fn record(&mut self, i: u32) {
        if self.recording && self.config.global_updates && !self.in_cache[i as usize] {
            self.in_cache[i as usize] = true;
            self.cache.push(i);
        }
    }

    /// Whether inner node `i` is reachable from the global root (not freed, not inside an instance).
    pub(crate) fn in_global_tree(&self, i: u32) -> bool {
        let parent = self.inner[i as usize].parent;
        if parent == FREE {
            return false;
        }
        if !self.has_live_instances() {
            // Without instances every live node with a parent hangs, through live parents, from the
            // root: no walk up the tree (update batches ask this for every cached node).
            return parent != NONE || self.root == NodeRef::inner(i);
        }
        let mut n = NodeRef::inner(i);
        loop {
            let p = self.parent(n);
            if p == FREE {
                return false;
            }
            if p == NONE {
                return n == self.root;
            }
            n = NodeRef::inner(p);
        }
    }

    /// The triangles of the leaves under `r`, left to right (instances are not entered): the
    /// unit tests' view of what a subtree holds.
    #[cfg(test)]
    pub(crate) fn leaves_under(&self, r: NodeRef) -> Vec<u32> {
        let (mut out, mut stack) = (Vec::new(), vec![r]);
        while let Some(n) = stack.pop() {
            match n.kind() {
                NodeKind::Inner => {
                    let [a, b] = self.inner[n.index() as usize].children;
                    stack.extend([b, a]);
                }
                NodeKind::Leaf => out.push(n.index()),
                _ => {}
            }
        }
        out
    }

    /// Inner node ids in the subtree under `r` (instances are not entered).
    pub(crate) fn collect_inner(&self, r: NodeRef, out: &mut Vec<u32>) {
        let mut stack = vec![r];
        while let Some(n) = stack.pop() {
            if n.is_inner() {
                out.push(n.index());
                stack.extend_from_slice(&self.inner[n.index() as usize].children);
            }
        }
    }
}
