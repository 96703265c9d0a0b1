//! The tree: flat arrays indexed by `u32` with free lists, and the primitive edits every builder and
//! editing operation is made of (link a node next to a sibling, unlink a node, refit upwards).

use crate::export::change::ChangeLog;
use crate::tree::corners::Corners;
use crate::tree::flags::Flags;
use crate::tree::ids::TriangleIds;
use crate::tree::node::{FREE, InnerNode, MAX_INDEX, NONE, NodeKind, NodeRef};
use crate::tree::scratch::Scratch;
use crate::tree::vertices::gather;
use crate::{Aabb, BvhConfig, BvhError, Triangle};
use glam::{Affine3A, Vec3};

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

/// What a write of an inner node ([`Bvh::write_inner`]) does to the running area sum
/// (`Bvh::area_acc`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum AreaSum {
    /// The node is in the global tree before and after: the sum follows its box's change.
    Change,
    /// The node joins the global tree (a link): its new box enters the sum.
    Enter,
    /// The node leaves the global tree (an unlink): its old box leaves the sum.
    Leave,
    /// The sum is not touched: the box is unchanged, or the node is outside what the sum counts
    /// (a detached node, an instance's object-space subtree, a subtree being rebuilt or linked
    /// whole, whose root's link counts for it).
    Outside,
}

/// A bounding volume hierarchy over triangles, built and edited incrementally.
#[derive(Clone)]
pub struct Bvh {
    pub(crate) inner: Vec<InnerNode>,
    pub(crate) inner_free: Vec<u32>,
    pub(crate) tri: Triangles,
    pub(crate) instances: Vec<Instance>,
    pub(crate) inst_free: Vec<u32>,
    pub(crate) groups: Vec<Group>,
    pub(crate) group_free: Vec<u32>,
    pub(crate) root: NodeRef,
    pub(crate) config: BvhConfig,
    pub(crate) cache: UpdateCache,
    pub(crate) changes: ChangeLog,
    pub(crate) scratch: Scratch,
    pub(crate) update_ops: u64,
    /// Running sum of changes to the global tree's inner node areas. Links, unlinks, refits, moves,
    /// and treelets keep its changes exact, so a move's effect on Eq. 1, and a post-pass
    /// round's cost, are known without recosting the tree. It is not the sum itself: a subtree
    /// linked whole (a cluster pair, a bBVH) enters with its new parent's area only.
    pub(crate) area_acc: f64,
}

#[derive(Clone)]
pub(crate) struct Group {
    pub(crate) generation: u32,
    pub(crate) alive: bool,
    /// Triangle ids, in the group's order (a mesh's own, for data kept per triangle), as runs of
    /// consecutive ids where those are smaller.
    pub(crate) triangles: TriangleIds,
    /// The vertices its triangles' corners index ([`Triangles::corners`]), as stored: world space
    /// while baked, object space while whole. Each distinct position once, shared by the
    /// triangles that meet there.
    pub(crate) vertices: Vec<Vec3>,
    /// A baked group's object-space vertices, in the order of `vertices`, kept once it has been
    /// whole (moved): each later move starts from them, so moves never accumulate rounding drift.
    /// Empty while whole (the stored vertices are in object space) and for a group inserted baked
    /// and never moved, whose object space comes back through its transform's inverse, rounded
    /// once: an unedited scene keeps no second copy of its vertices.
    pub(crate) object: Vec<Vec3>,
    pub(crate) transform: Affine3A,
    /// The instance while kept whole, [`NONE`] while baked.
    pub(crate) instance: u32,
    /// For a group made by [`Bvh::insert_instance`]: the slot of the group whose triangles it
    /// shares (it then has none of its own). [`NONE`] for a group that owns its triangles.
    pub(crate) source: u32,
    /// For an owner: how many groups share its triangles. Shared triangles stay in object space
    /// (the owner is never baked while it has users).
    pub(crate) users: u32,
    /// An owner whose own handle was removed while others still share its triangles: it has no
    /// instance in the tree and its slot is freed with its last user.
    pub(crate) retired: bool,
}

/// The triangles: leaves, where a leaf *is* its triangle id, in parallel arrays with a free list.
/// A grouped triangle is three indices into its group's vertices (a mesh's positions are shared by
/// the triangles that meet there: about half the bytes of three corners apiece); a triangle outside
/// any group keeps its own three corners.
#[derive(Clone, Default)]
pub(crate) struct Triangles {
    /// Each grouped triangle's corners, indices into [`Group::vertices`]. Grown only as far as the
    /// highest grouped id: a tree of loose triangles keeps none.
    pub(crate) corners: Corners,
    /// The corners of triangles outside any group, `3 * id ..`, as stored (world space). Grown only
    /// as far as the highest loose id: a tree of groups keeps none.
    pub(crate) loose: Vec<Vec3>,
    /// Parent inner node of each triangle's leaf; [`FREE`] for a freed slot.
    pub(crate) parent: Vec<u32>,
    /// Group of each triangle, or [`NONE`].
    pub(crate) group: Vec<u32>,
    /// Freed slots, reused first.
    pub(crate) free: Vec<u32>,
    /// Live triangles.
    pub(crate) live: u32,
}

/// The node update cache (the paper's section 4.3): inner nodes whose boxes insertions changed
/// since the last update batch.
#[derive(Clone, Default)]
pub(crate) struct UpdateCache {
    /// The cached nodes, in the order they were recorded.
    pub(crate) nodes: Vec<u32>,
    /// Per inner-node slot: whether it is in `nodes`.
    pub(crate) queued: Flags,
    /// Whether edits record their nodes (off while update moves run, so that moves queue none).
    pub(crate) recording: bool,
    /// Inside [`Bvh::batch`]: update batches wait for its end.
    pub(crate) deferred: bool,
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
            tri: Triangles::default(),
            instances: Vec::new(),
            inst_free: Vec::new(),
            groups: Vec::new(),
            group_free: Vec::new(),
            root: NodeRef::NONE,
            config,
            cache: UpdateCache {
                recording: true,
                ..UpdateCache::default()
            },
            changes: ChangeLog::default(),
            scratch: Scratch::default(),
            update_ops: 0,
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
        self.tri.live
    }

    /// Length of the triangle array, free slots included: the bound of triangle ids.
    pub fn triangle_capacity(&self) -> u32 {
        self.tri.parent.len() as u32
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
    pub fn triangle(&self, id: u32) -> Option<Triangle> {
        self.is_live_triangle(id).then(|| self.tri(id))
    }

    /// Triangle `id` as stored, gathered from its corners. `id` must be a live triangle's (or one
    /// whose corners were just written): the traversal's and the builders' reads.
    #[inline]
    pub(crate) fn tri(&self, id: u32) -> Triangle {
        let i = id as usize;
        let g = self.tri.group[i];
        if g == NONE {
            let v = &self.tri.loose[3 * i..3 * i + 3];
            return Triangle::new(v[0], v[1], v[2]);
        }
        gather(&self.groups[g as usize].vertices, self.tri.corners.get(i))
    }

    /// Whether `id` names a live triangle.
    pub fn is_live_triangle(&self, id: u32) -> bool {
        (id as usize) < self.tri.parent.len() && self.tri.parent[id as usize] != FREE
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
            NodeKind::Leaf => self.tri(r.index()).aabb(),
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
            NodeKind::Leaf => self.tri.parent[r.index() as usize],
            NodeKind::Instance => self.instances[r.index() as usize].parent,
            NodeKind::None => NONE,
        }
    }

    /// Sets the parent link of any node. Parent links are in no GPU record and no area sum, so
    /// this is the one write of an inner node that does not go through [`Bvh::write_inner`].
    #[inline]
    pub(crate) fn set_parent(&mut self, r: NodeRef, p: u32) {
        match r.kind() {
            NodeKind::Inner => self.inner[r.index() as usize].parent = p,
            NodeKind::Leaf => self.tri.parent[r.index() as usize] = p,
            NodeKind::Instance => self.instances[r.index() as usize].parent = p,
            NodeKind::None => {}
        }
    }

    /// Writes inner node `i` (its box, children or parent) by `edit`, in place: the one place
    /// that does, so that the change log hears of every write and the running area sum follows as
    /// `area` says. The node's GPU record holds its children and their boxes, so it is marked; a
    /// box change also changes the parent's record, which the refit walk that follows every box
    /// change marks.
    #[inline(always)]
    pub(crate) fn write_inner(&mut self, i: u32, area: AreaSum, edit: impl FnOnce(&mut InnerNode)) {
        let node = &mut self.inner[i as usize];
        let old = node.aabb.area();
        edit(node);
        match area {
            AreaSum::Change => self.area_acc += node.aabb.area() as f64 - old as f64,
            AreaSum::Enter => self.area_acc += node.aabb.area() as f64,
            AreaSum::Leave => self.area_acc -= old as f64,
            AreaSum::Outside => {}
        }
        self.changes.mark_inner(i);
    }

    /// Inner node `i` with child `old` replaced by `new` (box unchanged).
    #[inline(always)]
    pub(crate) fn replace_child(&mut self, i: u32, old: NodeRef, new: NodeRef) {
        self.write_inner(i, AreaSum::Outside, |n| {
            let slot = (n.children[1] == old) as usize;
            n.children[slot] = new;
        });
    }

    // ---- allocation ----------------------------------------------------------------------------

    pub(crate) fn alloc_inner(&mut self) -> u32 {
        let node = InnerNode::UNLINKED;
        if let Some(i) = self.inner_free.pop() {
            self.write_inner(i, AreaSum::Outside, |n| *n = node);
            i
        } else {
            let i = self.inner.len() as u32;
            self.inner.push(node);
            self.cache.queued.push(false);
            self.changes.grow_inner(self.inner.len());
            i
        }
    }

    pub(crate) fn free_inner(&mut self, i: u32) {
        self.write_inner(i, AreaSum::Outside, |n| {
            n.children = [NodeRef::NONE; 2];
            n.parent = FREE;
        });
        // Out of the update cache (its entry is dropped at the next batch): the slot may be reused
        // where updates do not reach, inside a group kept whole.
        if (i as usize) < self.cache.queued.len() {
            self.cache.queued.set(i as usize, false);
        }
        self.inner_free.push(i);
    }

    /// Checks that `extra` more triangles fit in 30-bit ids.
    pub(crate) fn check_room(&self, extra: usize) -> Result<(), BvhError> {
        let tris = self.tri.parent.len() - self.tri.free.len() + extra;
        if tris > MAX_INDEX as usize / 2 {
            return Err(BvhError::TooLarge {
                limit: MAX_INDEX / 2,
            });
        }
        Ok(())
    }

    /// Takes a triangle slot (not yet in the tree) for `group`: a free one first.
    fn alloc_slot(&mut self, group: u32) -> u32 {
        let id = if let Some(id) = self.tri.free.pop() {
            self.tri.parent[id as usize] = NONE;
            self.tri.group[id as usize] = group;
            id
        } else {
            let id = self.tri.parent.len() as u32;
            self.tri.parent.push(NONE);
            self.tri.group.push(group);
            id
        };
        self.tri.live += 1;
        self.changes.mark_triangle(id, self.tri.parent.len());
        id
    }

    /// Orders the free slots the next `n` allocations take so that they come in ascending order:
    /// a group given slots a removed group left then holds its ids as runs
    /// ([`crate::TriangleIds`]), not as a list that descends.
    pub(crate) fn ascending_free_slots(&mut self, n: usize) {
        let free = &mut self.tri.free;
        let from = free.len() - n.min(free.len());
        // Taken from the end: the largest first in the list, the smallest last.
        free[from..].sort_unstable_by(|a, b| b.cmp(a));
    }

    /// Stores a triangle outside any group (not yet in the tree) and returns its id.
    pub(crate) fn alloc_triangle(&mut self, t: Triangle) -> u32 {
        let id = self.alloc_slot(NONE);
        self.write_loose(id, t);
        id
    }

    /// Stores a triangle of `group` by its corners, indices into the group's vertices (not yet in
    /// the tree), and returns its id.
    pub(crate) fn alloc_grouped(&mut self, corners: [u32; 3], group: u32) -> u32 {
        let id = self.alloc_slot(group);
        self.tri.corners.set(id as usize, corners);
        id
    }

    /// Writes the corners of triangle `id`, outside any group.
    pub(crate) fn write_loose(&mut self, id: u32, t: Triangle) {
        let i = 3 * id as usize;
        if self.tri.loose.len() < i + 3 {
            self.tri.loose.resize(i + 3, Vec3::ZERO);
        }
        self.tri.loose[i..i + 3].copy_from_slice(&t.v);
    }

    /// Allocates ids for `tris`, in input order, growing the arrays by slices rather than
    /// triangle by triangle (see [`Bvh::alloc_triangles_into`]).
    pub(crate) fn alloc_triangles(&mut self, tris: &[Triangle]) -> Vec<u32> {
        let mut ids = Vec::with_capacity(tris.len());
        self.alloc_triangles_into(tris, &mut ids);
        ids
    }

    /// Allocates ids for `tris` (outside any group), appending them to `ids`. Reuses free slots
    /// first like [`Bvh::alloc_triangle`]; the rest are appended to the arrays as slices, which
    /// for a fresh tree is every triangle.
    pub(crate) fn alloc_triangles_into(&mut self, tris: &[Triangle], ids: &mut Vec<u32>) {
        let reused = self.tri.free.len().min(tris.len());
        for &t in &tris[..reused] {
            ids.push(self.alloc_triangle(t));
        }
        let tris = &tris[reused..];
        let first = self.tri.parent.len();
        let end = first + tris.len();
        self.tri.loose.resize(3 * first, Vec3::ZERO);
        self.tri.loose.extend(tris.iter().flat_map(|t| t.v));
        self.tri.parent.resize(end, NONE);
        self.tri.group.resize(end, NONE);
        self.tri.live += tris.len() as u32;
        ids.extend(first as u32..end as u32);
        self.changes.mark_new_triangles(first as u32..end as u32);
    }

    /// Makes room for `triangles` more triangles, and the inner nodes they bring, without inserting
    /// anything: a later insertion of up to that many then grows no array. Growth doubles the
    /// arrays, cheap per triangle, but in a large tree it is a copy of megabytes inside one small
    /// insertion. Call this ahead of edits whose latency matters more than memory.
    pub fn reserve(&mut self, triangles: usize) {
        self.reserve_triangles(triangles);
        let fresh = triangles.saturating_sub(self.inner_free.len());
        self.inner.reserve(fresh);
        self.cache.queued.reserve_to(self.inner.len() + fresh);
        self.changes.reserve_inner(self.inner.len() + fresh);
    }

    /// Makes room for `n` more triangles at once, so a large batch does not grow the arrays step
    /// by step: the store of grouped triangles' corners, of loose ones', or both, as the tree
    /// holds (both while it is empty).
    pub(crate) fn reserve_triangles(&mut self, n: usize) {
        let fresh = n.saturating_sub(self.tri.free.len());
        self.tri.parent.reserve(fresh);
        self.tri.group.reserve(fresh);
        let end = self.tri.parent.len() + fresh;
        let empty = self.tri.corners.is_empty() && self.tri.loose.is_empty();
        if empty || !self.tri.corners.is_empty() {
            self.tri.corners.reserve_to(end);
        }
        if empty || !self.tri.loose.is_empty() {
            let more = (3 * end).saturating_sub(self.tri.loose.len());
            self.tri.loose.reserve(more);
        }
        self.changes
            .reserve_triangles(self.tri.parent.len() + fresh, n);
    }

    pub(crate) fn free_triangle(&mut self, id: u32) {
        if (id as usize) < self.tri.corners.len() {
            // A freed slot's corners say nothing: cleared, they hold no high halves.
            self.tri.corners.set(id as usize, [0; 3]);
        }
        self.tri.parent[id as usize] = FREE;
        self.tri.group[id as usize] = NONE;
        self.tri.free.push(id);
        self.tri.live -= 1;
        self.changes.mark_triangle(id, self.tri.parent.len());
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
        let node = InnerNode {
            aabb,
            children: [x, l],
            parent: xp,
        };
        self.write_inner(p, AreaSum::Enter, |n| *n = node);
        self.set_parent(x, p);
        self.set_parent(l, p);
        self.record(p);
        if xp == NONE {
            self.root = NodeRef::inner(p);
            self.changes.root_changed = true;
        } else {
            self.replace_child(xp, x, NodeRef::inner(p));
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
        let mut scratch = std::mem::take(&mut self.scratch.search);
        let x = self.find_best_sibling_from(&bl, hint, &mut scratch);
        self.scratch.search = scratch;
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
        self.write_inner(p, AreaSum::Leave, |n| {
            n.parent = NONE;
            n.children = [NodeRef::NONE; 2];
        });
        if g == NONE {
            self.root = s;
            self.changes.root_changed = true;
        } else {
            self.replace_child(g, NodeRef::inner(p), s);
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

    /// The walk the refits share: from inner node `i` upwards, mark each node reached (its record
    /// holds the box of a child that just changed), take the box `next_box` gives it (none: it
    /// keeps its own), and stop at the first whose box is unchanged, keeping the area sum and the
    /// update cache in step.
    #[inline(always)]
    fn refit_with(&mut self, mut i: u32, next_box: impl Fn(&Self, u32) -> Option<Aabb>) {
        while i != NONE {
            self.changes.mark_inner(i);
            let Some(aabb) = next_box(self, i) else {
                break;
            };
            let node = &self.inner[i as usize];
            if node.aabb == aabb {
                break;
            }
            let parent = node.parent;
            self.write_inner(i, AreaSum::Change, |n| n.aabb = aabb);
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
        if self.cache.recording
            && self.config.global_updates
            && !self.cache.queued.replace(i as usize, true)
        {
            self.cache.nodes.push(i);
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
