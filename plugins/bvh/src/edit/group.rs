//! Groups: a mesh's triangles inserted as one bBVH subtree, removable as a unit, and movable without
//! touching its triangles while it is kept whole under a transform (an instance node).

use crate::top_down::{BuiltTree, TopDown, build_binned_parallel};
use crate::tree::bvh::{AreaSum, Group};
use crate::tree::node::{NONE, NodeKind, NodeRef};
use crate::tree::triangle::{point_within_limits, validate_triangles};
use crate::tree::vertices::{Indexed, compact, gather};
use crate::{Aabb, Bvh, BvhError, Instance, Triangle, TriangleIds};
use glam::{Affine3A, Vec3};

/// Handle to a group; stale handles (of removed groups) are rejected, never confused with new ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GroupId {
    index: u32,
    generation: u32,
}

impl GroupId {
    pub(crate) fn new(index: u32, generation: u32) -> Self {
        Self { index, generation }
    }

    /// The group's slot: dense, below the number of groups ever alive at once, and reused after
    /// removal (with a new generation). Renderers index per-group tables (transforms, materials) by it.
    pub fn index(self) -> u32 {
        self.index
    }
}

/// A group's bBVH, built off the thread that owns the tree (it is `Send`), ready for
/// [`Bvh::insert_prepared`].
pub struct PreparedGroup {
    transform: Affine3A,
    whole: bool,
    /// Triangles as they will be stored: object space if whole, world space if baked.
    stored: Indexed,
    tree: BuiltTree,
}

impl PreparedGroup {
    /// Validates and builds (binned SAH, parallel for large meshes). `keep_whole` keeps the triangles in
    /// object space under `transform`; otherwise they are moved to world space and baked. The
    /// triangles are kept as shared vertices (each position that is the same to the bit once) and
    /// corners; each reads back exactly as given.
    pub fn build(
        object: &[Triangle],
        transform: Affine3A,
        keep_whole: bool,
    ) -> Result<Self, BvhError> {
        Self::build_with(object, transform, keep_whole, TopDown::BinnedSah)
    }

    /// [`PreparedGroup::build`] with another top-down builder (binned SAH runs in parallel for
    /// large meshes): full-sweep SAH, for one, costs about twice the time for a better tree.
    pub fn build_with(
        object: &[Triangle],
        transform: Affine3A,
        keep_whole: bool,
        builder: TopDown,
    ) -> Result<Self, BvhError> {
        validate_triangles(object)?;
        let indexed = Indexed::from_soup(object);
        Self::build_placed(indexed, transform, keep_whole, builder)
    }

    /// [`PreparedGroup::build`] from a mesh's own vertices and triangles (three indices into
    /// `vertices` each): no soup of triangles is made, and vertices at the same position (split
    /// where a mesh's normals or UVs part) are kept once.
    pub fn build_indexed(
        vertices: Vec<Vec3>,
        corners: Vec<[u32; 3]>,
        transform: Affine3A,
        keep_whole: bool,
    ) -> Result<Self, BvhError> {
        let indexed = Indexed::merged(vertices, corners);
        indexed.validate()?;
        Self::build_placed(indexed, transform, keep_whole, TopDown::BinnedSah)
    }

    fn build_placed(
        mut indexed: Indexed,
        transform: Affine3A,
        keep_whole: bool,
        builder: TopDown,
    ) -> Result<Self, BvhError> {
        check_transform(&transform)?;
        if !keep_whole {
            for p in &mut indexed.vertices {
                *p = transform.transform_point3(*p);
            }
        }
        Self::build_stored(indexed, transform, keep_whole, builder)
    }

    /// A baked group built from its triangles already in world space, placed by `transform` (what
    /// [`Bvh::group_world`] and [`Bvh::group_transform`] return): its triangles are stored exactly as
    /// given, so a rebuild of a baked group meets every ray the old one did.
    pub fn build_world(
        world: &[Triangle],
        transform: Affine3A,
        builder: TopDown,
    ) -> Result<Self, BvhError> {
        check_transform(&transform)?;
        validate_triangles(world)?;
        let indexed = Indexed::from_soup(world);
        Self::build_stored(indexed, transform, false, builder)
    }

    /// [`PreparedGroup::build_world`] from what [`Bvh::group_world_indexed`] returns: the vertices
    /// and corners kept as they are, so a baked group rebuilt from its own keeps its object-space
    /// copy (see [`Bvh::swap_group`]).
    pub fn build_world_indexed(
        vertices: Vec<Vec3>,
        corners: Vec<[u32; 3]>,
        transform: Affine3A,
        builder: TopDown,
    ) -> Result<Self, BvhError> {
        check_transform(&transform)?;
        let indexed = Indexed { vertices, corners };
        Self::build_stored(indexed, transform, false, builder)
    }

    fn build_stored(
        stored: Indexed,
        transform: Affine3A,
        whole: bool,
        builder: TopDown,
    ) -> Result<Self, BvhError> {
        stored.validate()?;
        let boxes: Vec<Aabb> = (0..stored.len())
            .map(|k| stored.triangle(k).aabb())
            .collect();
        let tree = match builder {
            TopDown::BinnedSah => build_binned_parallel(&boxes),
            other => other.build(&boxes),
        };
        Ok(Self {
            transform,
            whole,
            stored,
            tree,
        })
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.stored.len()
    }

    /// Whether the group has no triangles.
    pub fn is_empty(&self) -> bool {
        self.stored.len() == 0
    }
}

fn check_transform(t: &Affine3A) -> Result<(), BvhError> {
    if !is_traceable_transform(t) {
        return Err(BvhError::BadTransform);
    }
    Ok(())
}

/// Whether a group may be placed by `t`: finite and invertible (a node scaled to zero, as
/// exporters hide one, is not).
pub fn is_traceable_transform(t: &Affine3A) -> bool {
    let det = t.matrix3.determinant();
    t.is_finite() && det != 0.0 && det.is_finite()
}

impl Bvh {
    pub(crate) fn group(&self, id: GroupId) -> Result<&Group, BvhError> {
        match self.groups.get(id.index as usize) {
            Some(g) if g.alive && !g.retired && g.generation == id.generation => Ok(g),
            _ => Err(BvhError::UnknownGroup),
        }
    }

    /// Builds and inserts a group in one call. See [`PreparedGroup::build`].
    pub fn insert_group(
        &mut self,
        object: &[Triangle],
        transform: Affine3A,
        keep_whole: bool,
    ) -> Result<GroupId, BvhError> {
        let prepared = PreparedGroup::build(object, transform, keep_whole)?;
        self.insert_prepared(prepared)
    }

    /// Inserts a group built elsewhere: its bBVH root goes in with one search (IncrUPB's insertion).
    pub fn insert_prepared(&mut self, g: PreparedGroup) -> Result<GroupId, BvhError> {
        self.check_room(g.stored.len())?;
        let index = self.take_group_slot();
        let Indexed { vertices, corners } = g.stored;
        // The vertices first: the graft reads the triangles' boxes through them.
        self.groups[index as usize].vertices = vertices;
        self.ascending_free_slots(corners.len());
        let ids: Vec<u32> = corners
            .iter()
            .map(|&c| self.alloc_grouped(c, index))
            .collect();
        drop(corners);
        let root = self.graft(&g.tree, &ids);
        let mut instance = NONE;
        if !root.is_none() {
            if g.whole {
                instance = self.make_instance(root, g.transform, index);
                self.insert_item(NodeRef::instance(instance));
            } else {
                self.record_subtree(root);
                self.insert_item(root);
            }
        }
        let slot = &mut self.groups[index as usize];
        slot.alive = true;
        slot.triangles = TriangleIds::new(ids);
        slot.object = Vec::new();
        slot.transform = g.transform;
        slot.instance = instance;
        slot.source = NONE;
        slot.users = 0;
        slot.retired = false;
        Ok(GroupId {
            index,
            generation: slot.generation,
        })
    }

    pub(crate) fn make_instance(&mut self, root: NodeRef, transform: Affine3A, group: u32) -> u32 {
        let aabb = self.aabb(root).transformed(&transform);
        self.alloc_instance(Instance {
            aabb,
            parent: NONE,
            root,
            transform,
            inverse: transform.inverse(),
            group,
        })
    }

    /// Puts a baked subtree's inner nodes in the node update cache, opening them to global updates.
    fn record_subtree(&mut self, root: NodeRef) {
        if !self.config.global_updates {
            return;
        }
        let mut nodes = Vec::new();
        self.collect_inner(root, &mut nodes);
        for i in nodes {
            self.record(i);
        }
    }

    /// Puts `new` in `old`'s place: inserts it, then removes `old` (the triangles never lapse). The
    /// new group's triangles are `new`'s in its order, so data kept per triangle in group order (a
    /// mesh's shading) still fits when `new` was built from `old`'s [`Bvh::group_world`] (or
    /// [`Bvh::group_object`]); a baked `new` of as many triangles and vertices (built from
    /// [`Bvh::group_world_indexed`]) takes over `old`'s exact object-space copy, if it kept one.
    pub fn swap_group(&mut self, old: GroupId, new: PreparedGroup) -> Result<GroupId, BvhError> {
        let same_count = self.group(old)?.triangles.len() == new.len();
        let baked = !new.whole;
        let id = self.insert_prepared(new)?;
        let copy = std::mem::take(&mut self.groups[old.index as usize].object);
        if baked && same_count && self.same_vertices(old.index, id.index, copy.len()) {
            self.groups[id.index as usize].object = copy;
        }
        self.remove_group(old)?;
        Ok(id)
    }

    /// Whether group `b` indexes `vertices` vertices as group `a` does, corner for corner, triangle
    /// for triangle: what makes `a`'s object-space copy (of that many) fit `b`.
    fn same_vertices(&self, a: u32, b: u32, vertices: usize) -> bool {
        let (a, b) = (&self.groups[a as usize], &self.groups[b as usize]);
        let corners = &self.tri.corners;
        b.vertices.len() == vertices
            && a.triangles.len() == b.triangles.len()
            && a.triangles
                .iter()
                .zip(&b.triangles)
                .all(|(s, t)| corners.get(s as usize) == corners.get(t as usize))
    }

    /// Removes a group and all its triangles. A group whose triangles others share
    /// ([`Bvh::insert_instance`]) leaves the tree at once; its triangles stay while they are used.
    pub fn remove_group(&mut self, id: GroupId) -> Result<(), BvhError> {
        let g = self.group(id)?;
        if g.source != NONE {
            self.remove_user(id.index);
            return Ok(());
        }
        if g.users > 0 {
            self.retire(id.index);
            return Ok(());
        }
        let (instance, triangles) = (g.instance, g.triangles.to_vec());
        if instance != NONE {
            let root = self.instances[instance as usize].root;
            self.detach_instance(instance);
            let mut inner = Vec::new();
            self.collect_inner(root, &mut inner);
            for i in inner {
                self.free_inner(i);
            }
            for t in &triangles {
                self.free_triangle(*t);
            }
            self.free_instance(instance);
        } else {
            self.remove_leaves(&triangles);
        }
        self.free_group_slot(id.index);
        Ok(())
    }

    /// Marks slot `index` free and stales every handle to it.
    pub(crate) fn free_group_slot(&mut self, index: u32) {
        let slot = &mut self.groups[index as usize];
        slot.alive = false;
        slot.retired = false;
        slot.generation = slot.generation.wrapping_add(1);
        slot.triangles = TriangleIds::default();
        slot.vertices = Vec::new();
        slot.object = Vec::new();
        slot.instance = NONE;
        slot.source = NONE;
        slot.users = 0;
        self.group_free.push(index);
    }

    /// Unlinks an instance node from the global tree and frees the inner node it hung from.
    pub(crate) fn detach_instance(&mut self, instance: u32) {
        let p = self.unlink(NodeRef::instance(instance));
        if p != NONE {
            self.free_inner(p);
        }
    }

    /// Moves a group. A baked group is first opened into an instance (its triangles go back to object
    /// space, once); from then on each move is one O(log n) re-insertion of the instance node.
    pub fn set_group_transform(
        &mut self,
        id: GroupId,
        transform: Affine3A,
    ) -> Result<(), BvhError> {
        check_transform(&transform)?;
        let g = self.group(id)?;
        if g.instance == NONE && g.triangles.is_empty() {
            self.groups[id.index as usize].transform = transform;
            return Ok(());
        }
        if g.instance == NONE {
            // The group's copy is taken, not cloned: while whole, the stored triangles are the
            // object-space ones.
            let slot = id.index as usize;
            let object = if self.groups[slot].object.is_empty() {
                self.baked_object(id.index).ok_or(BvhError::BadTransform)?
            } else {
                std::mem::take(&mut self.groups[slot].object)
            };
            self.unbake(id.index, object);
        }
        let index = id.index as usize;
        let instance = self.groups[index].instance;
        self.groups[index].transform = transform;
        let attached = self.instances[instance as usize].parent != NONE
            || self.root == NodeRef::instance(instance);
        let p = if attached {
            self.unlink(NodeRef::instance(instance))
        } else {
            NONE
        };
        let inst = &mut self.instances[instance as usize];
        inst.transform = transform;
        inst.inverse = transform.inverse();
        let root = inst.root;
        self.instances[instance as usize].aabb = self.aabb(root).transformed(&transform);
        self.changes.mark_instance(instance);
        if p == NONE {
            self.insert_node(NodeRef::instance(instance));
        } else {
            self.insert_node_with(NodeRef::instance(instance), p);
        }
        self.maybe_update();
        Ok(())
    }

    /// The object-space vertices a baked group goes back to when it is opened: its exact copy if
    /// it kept one, else its world vertices carried back through its transform's inverse (rounded
    /// once; the copy then kept rules out any further drift). `None` if that inverse leaves the
    /// numbers the tree accepts.
    fn baked_object(&self, index: u32) -> Option<Vec<Vec3>> {
        let g = &self.groups[index as usize];
        if !g.object.is_empty() {
            return Some(g.object.clone());
        }
        let inverse = g.transform.inverse();
        let object: Vec<Vec3> = g
            .vertices
            .iter()
            .map(|&p| inverse.transform_point3(p))
            .collect();
        object
            .iter()
            .all(|&p| point_within_limits(p))
            .then_some(object)
    }

    /// Turns a baked group (its copy, if it kept one, already taken as `object`) into an instance
    /// over an object-space subtree of the same triangle ids.
    fn unbake(&mut self, index: u32, object: Vec<Vec3>) {
        let g = &self.groups[index as usize];
        let (triangles, transform) = (g.triangles.to_vec(), g.transform);
        // The triangles keep the shape they have in the tree (a rigid transform away from the one
        // they get in object space): far quicker than a build, and as good for a mesh's own parts.
        let tree = self.induced_tree(&triangles);
        self.remove_leaves_keep_triangles(&triangles);
        self.groups[index as usize].vertices = object;
        for &t in &triangles {
            self.changes.mark_triangle(t, self.tri.parent.len());
        }
        let root = self.graft(&tree, &triangles);
        self.refit_subtree(root);
        let instance = self.make_instance(root, transform, index);
        // Left detached: the caller links it at its new position.
        self.groups[index as usize].instance = instance;
    }

    /// Moves a group's triangles to world space and replaces its instance node by its subtree, which
    /// then takes part in global updates: the single-level tree the paper measures. Shared triangles
    /// ([`Bvh::insert_instance`]) stay in object space: a group that shares them, or whose triangles
    /// are shared, stays an instance.
    pub fn bake_group(&mut self, id: GroupId) -> Result<(), BvhError> {
        let g = self.group(id)?;
        let instance = g.instance;
        if instance == NONE || g.source != NONE || g.users > 0 {
            return Ok(());
        }
        let (triangles, transform) = (g.triangles.to_vec(), g.transform);
        // The object-space vertices are replaced: kept, so that the group's next move starts from
        // them exactly.
        let object = std::mem::take(&mut self.groups[id.index as usize].vertices);
        self.groups[id.index as usize].vertices = object
            .iter()
            .map(|&p| transform.transform_point3(p))
            .collect();
        for &t in &triangles {
            self.changes.mark_triangle(t, self.tri.parent.len());
        }
        let inst = self.instances[instance as usize];
        self.refit_subtree(inst.root);
        // The subtree takes the instance's place in the tree.
        let root = inst.root;
        self.set_parent(root, inst.parent);
        if inst.parent == NONE {
            self.root = root;
            self.changes.root_changed = true;
        } else {
            self.replace_child(inst.parent, NodeRef::instance(instance), root);
            self.refit_from(inst.parent);
        }
        self.free_instance(instance);
        self.groups[id.index as usize].instance = NONE;
        self.groups[id.index as usize].object = object;
        self.record_subtree(root);
        self.maybe_update();
        Ok(())
    }

    /// Replaces a group's vertices (same triangle count, object space) and refits. Groups that share
    /// these triangles move with them; a group that shares another's triangles has none of its own
    /// to replace (its count is 0).
    pub fn update_group_vertices(
        &mut self,
        id: GroupId,
        object: &[Triangle],
    ) -> Result<(), BvhError> {
        let g = self.group(id)?;
        if g.triangles.len() != object.len() {
            return Err(BvhError::TriangleCountMismatch {
                expected: g.triangles.len(),
                got: object.len(),
            });
        }
        validate_triangles(object)?;
        let (instance, transform, triangles) = (g.instance, g.transform, g.triangles.to_vec());
        let had_copy = !g.object.is_empty();
        let mut new = Indexed::from_soup(object);
        let stored = if instance == NONE {
            let world = Indexed {
                vertices: new
                    .vertices
                    .iter()
                    .map(|&p| transform.transform_point3(p))
                    .collect(),
                corners: new.corners.clone(),
            };
            world.validate()?;
            world.vertices
        } else {
            // A whole group keeps no object-space copy: its stored vertices are that.
            std::mem::take(&mut new.vertices)
        };
        for (&t, &c) in triangles.iter().zip(&new.corners) {
            self.tri.corners.set(t as usize, c);
            self.changes.mark_triangle(t, self.tri.parent.len());
        }
        self.groups[id.index as usize].vertices = stored;
        if instance != NONE {
            self.refit_subtree(self.instances[instance as usize].root);
            self.set_group_transform(id, transform)?;
            self.refresh_users(id.index);
            return Ok(());
        }
        for &t in &triangles {
            let p = self.tri.parent[t as usize];
            if p != NONE {
                self.refit_from(p);
            }
        }
        // A baked group's copy, if it kept one, follows: its next move starts from these.
        self.groups[id.index as usize].object = if had_copy { new.vertices } else { Vec::new() };
        Ok(())
    }

    /// Recomputes every box of the subtree under `root` bottom-up.
    pub(crate) fn refit_subtree(&mut self, root: NodeRef) {
        let mut nodes = Vec::new();
        self.collect_inner(root, &mut nodes);
        // Pre-order lists parents before children; reversed, children come first.
        for &i in nodes.iter().rev() {
            let [a, b] = self.inner[i as usize].children;
            let aabb = self.aabb(a).union(&self.aabb(b));
            self.write_inner(i, AreaSum::Outside, |n| n.aabb = aabb);
        }
    }

    /// Number of group slots (live or free): every [`GroupId::index`] is below it.
    pub fn group_slots(&self) -> u32 {
        self.groups.len() as u32
    }

    /// The group's own triangle ids (none for a group that shares another's: see
    /// [`Bvh::shared_triangles`]).
    pub fn group_triangles(&self, id: GroupId) -> Result<&TriangleIds, BvhError> {
        Ok(&self.group(id)?.triangles)
    }

    /// The group's triangles in object space, in the order of [`Bvh::group_triangles`] (none for a
    /// group that shares another's). Exactly what it was built from while it is kept whole, or once it
    /// has been moved; a group inserted baked keeps no object-space copy, so its triangles come back
    /// through its transform's inverse, within rounding.
    pub fn group_object(&self, id: GroupId) -> Result<Vec<Triangle>, BvhError> {
        let g = self.group(id)?;
        if g.instance != NONE {
            return Ok(g.triangles.iter().map(|t| self.tri(t)).collect());
        }
        let object = self.baked_object(id.index).ok_or(BvhError::BadTransform)?;
        Ok(g.triangles
            .iter()
            .map(|t| gather(&object, self.tri.corners.get(t as usize)))
            .collect())
    }

    /// The group's triangles in world space, in the order of [`Bvh::group_triangles`] (none for a
    /// group that shares another's): a baked group's exactly as stored.
    pub fn group_world(&self, id: GroupId) -> Result<Vec<Triangle>, BvhError> {
        let g = self.group(id)?;
        let stored = g.triangles.iter().map(|t| self.tri(t));
        Ok(if g.instance != NONE {
            stored.map(|t| t.transformed(&g.transform)).collect()
        } else {
            stored.collect()
        })
    }

    /// [`Bvh::group_world`] as the group keeps it: its vertices in world space and each triangle's
    /// corners, in the order of [`Bvh::group_triangles`] (for
    /// [`PreparedGroup::build_world_indexed`]). A baked group's vertices exactly as stored.
    #[allow(clippy::type_complexity)]
    pub fn group_world_indexed(&self, id: GroupId) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), BvhError> {
        let g = self.group(id)?;
        let vertices = if g.instance != NONE {
            g.vertices
                .iter()
                .map(|&p| g.transform.transform_point3(p))
                .collect()
        } else {
            g.vertices.clone()
        };
        let corners = g
            .triangles
            .iter()
            .map(|t| self.tri.corners.get(t as usize))
            .collect();
        Ok((vertices, corners))
    }

    /// The group's current transform.
    pub fn group_transform(&self, id: GroupId) -> Result<Affine3A, BvhError> {
        Ok(self.group(id)?.transform)
    }

    /// Whether the group is kept whole under its transform (true) or baked (false).
    pub fn is_group_whole(&self, id: GroupId) -> Result<bool, BvhError> {
        Ok(self.group(id)?.instance != NONE)
    }

    /// The group a triangle belongs to, if any.
    pub fn triangle_group(&self, t: u32) -> Option<GroupId> {
        if !self.is_live_triangle(t) {
            return None;
        }
        let g = self.tri.group[t as usize];
        (g != NONE).then(|| GroupId {
            index: g,
            generation: self.groups[g as usize].generation,
        })
    }

    /// Triangle `t` in world space, whatever its group's state, placed by the group that owns it
    /// (see [`Bvh::hit_world_triangle`] for triangles shared by several groups).
    pub fn world_triangle(&self, t: u32) -> Option<Triangle> {
        let tri = self.triangle(t)?;
        let g = self.tri.group[t as usize];
        if g != NONE && self.groups[g as usize].instance != NONE {
            return Some(tri.transformed(&self.groups[g as usize].transform));
        }
        Some(tri)
    }

    /// Removes individual triangles (leaves). Triangles of a group kept whole bake that group first.
    /// Unknown ids are rejected before anything changes.
    pub fn remove_triangles(&mut self, ids: &[u32]) -> Result<(), BvhError> {
        if let Some(&bad) = ids.iter().find(|&&t| !self.is_live_triangle(t)) {
            return Err(BvhError::UnknownTriangle(bad));
        }
        let mut ids = ids.to_vec();
        ids.sort_unstable();
        ids.dedup();
        let mut touched_groups: Vec<u32> = ids
            .iter()
            .map(|&t| self.tri.group[t as usize])
            .filter(|&g| g != NONE)
            .collect();
        touched_groups.sort_unstable();
        touched_groups.dedup();
        if let Some(&g) = touched_groups
            .iter()
            .find(|&&g| self.groups[g as usize].users > 0)
        {
            return Err(BvhError::SharedTriangles(
                self.groups[g as usize].triangles.first().unwrap_or(NONE),
            ));
        }
        for &g in &touched_groups {
            if self.groups[g as usize].instance != NONE {
                let id = GroupId {
                    index: g,
                    generation: self.groups[g as usize].generation,
                };
                self.bake_group(id)?;
            }
        }
        for &g in &touched_groups {
            let group = &mut self.groups[g as usize];
            group.triangles.retain(|t| ids.binary_search(t).is_err());
        }
        self.remove_leaves(&ids);
        for &g in &touched_groups {
            self.drop_unused_vertices(g);
        }
        Ok(())
    }

    /// Moves baked or ungrouped triangles (world space) and refits. Unknown ids or bad vertices are
    /// rejected before anything changes. Triangles of groups kept whole must use
    /// [`Bvh::update_group_vertices`]. A baked group whose triangles move here keeps them where they
    /// are moved to when the group itself moves later.
    pub fn set_triangles(&mut self, updates: &[(u32, Triangle)]) -> Result<(), BvhError> {
        if let Some(&(t, _)) = updates.iter().find(|(t, _)| !self.is_live_triangle(*t)) {
            return Err(BvhError::UnknownTriangle(t));
        }
        validate_triangles(&updates.iter().map(|u| u.1).collect::<Vec<_>>())?;
        for &(t, _) in updates {
            let g = self.tri.group[t as usize];
            if g != NONE && self.groups[g as usize].instance != NONE {
                return Err(BvhError::UnknownTriangle(t));
            }
        }
        for &(t, tri) in updates {
            let g = self.tri.group[t as usize];
            if g == NONE {
                self.write_loose(t, tri);
            } else {
                // Its corners may be its neighbours' too: the triangle gets three of its own.
                let vertices = &mut self.groups[g as usize].vertices;
                let first = vertices.len() as u32;
                vertices.extend_from_slice(&tri.v);
                self.tri
                    .corners
                    .set(t as usize, [first, first + 1, first + 2]);
            }
            self.changes.mark_triangle(t, self.tri.parent.len());
            let p = self.tri.parent[t as usize];
            if p != NONE {
                self.refit_from(p);
            }
        }
        // A baked group's object-space copy no longer holds triangles edited in the world: it
        // goes, and the group's object space is carried back from the world when it moves.
        let mut touched: Vec<u32> = updates
            .iter()
            .map(|&(t, _)| self.tri.group[t as usize])
            .filter(|&g| g != NONE)
            .collect();
        touched.sort_unstable();
        touched.dedup();
        for g in touched {
            self.groups[g as usize].object = Vec::new();
            self.drop_unused_vertices(g);
        }
        Ok(())
    }

    /// Compacts group `g`'s vertices once more than three a triangle are kept (the triangles
    /// edited one by one got their own, those removed left theirs): the store stays within what
    /// corners of their own would take, at a cost spread over as many edits.
    fn drop_unused_vertices(&mut self, g: u32) {
        let group = &mut self.groups[g as usize];
        if group.vertices.len() <= 3 * group.triangles.len() {
            return;
        }
        let object = (!group.object.is_empty()).then_some(&mut group.object);
        compact(
            &mut group.vertices,
            &mut self.tri.corners,
            &group.triangles,
            object,
        );
        // Their corners are numbered anew: a copy that indexes the vertices must hear of it.
        let len = self.tri.parent.len();
        for t in self.groups[g as usize].triangles.iter() {
            self.changes.mark_triangle(t, len);
        }
    }

    /// Removes leaves from the global tree and frees their triangles.
    pub(crate) fn remove_leaves(&mut self, ids: &[u32]) {
        self.remove_leaves_keep_triangles(ids);
        for &t in ids {
            self.free_triangle(t);
        }
    }

    /// Removes leaves from the global tree, keeping their triangle slots (detached).
    fn remove_leaves_keep_triangles(&mut self, ids: &[u32]) {
        // Many leaves at once: one pass that prunes the whole tree beats a refit walk per leaf.
        if ids.len() > 64 && ids.len() * 16 > self.tri.live as usize {
            self.prune_leaves(ids);
            return;
        }
        for &t in ids {
            let p = self.unlink(NodeRef::leaf(t));
            if p != NONE {
                self.free_inner(p);
            }
        }
    }

    /// Removes `ids` from the global tree in one post-order pass over the subtrees that hold them
    /// (their ancestors, marked first; the rest of the tree is not visited): an inner node with one
    /// surviving child is replaced by that child, one with none disappears.
    fn prune_leaves(&mut self, ids: &[u32]) {
        let mut doomed = vec![false; self.tri.parent.len()];
        let mut touched = vec![false; self.inner.len()];
        for &t in ids {
            doomed[t as usize] = true;
            let mut p = self.tri.parent[t as usize];
            while p != NONE && !touched[p as usize] {
                touched[p as usize] = true;
                p = self.inner[p as usize].parent;
            }
            self.tri.parent[t as usize] = NONE;
        }
        let root = self.root;
        if root.is_none() {
            return;
        }
        // Iterative post-order: (node, children visited). Results carry whether the node's box changed,
        // because the parent's GPU record holds its children's boxes.
        let mut stack: Vec<(NodeRef, bool)> = vec![(root, false)];
        let mut results: Vec<(NodeRef, bool)> = Vec::new();
        while let Some((n, visited)) = stack.pop() {
            match n.kind() {
                // No doomed leaf below: kept as it is.
                NodeKind::Inner if !touched[n.index() as usize] => results.push((n, false)),
                NodeKind::Inner if !visited => {
                    stack.push((n, true));
                    let [a, b] = self.inner[n.index() as usize].children;
                    stack.push((b, false));
                    stack.push((a, false));
                }
                NodeKind::Inner => {
                    let (b, b_changed) = results.pop().unwrap_or((NodeRef::NONE, false));
                    let (a, a_changed) = results.pop().unwrap_or((NodeRef::NONE, false));
                    let i = n.index();
                    let kept = match (a.is_none(), b.is_none()) {
                        (true, true) => {
                            self.free_inner(i);
                            (NodeRef::NONE, true)
                        }
                        (false, true) | (true, false) => {
                            self.free_inner(i);
                            (if a.is_none() { b } else { a }, true)
                        }
                        (false, false) => {
                            let old = self.inner[i as usize];
                            let aabb = self.aabb(a).union(&self.aabb(b));
                            if old.children != [a, b] || a_changed || b_changed {
                                self.write_inner(i, AreaSum::Outside, |n| {
                                    n.children = [a, b];
                                    n.aabb = aabb;
                                });
                            }
                            self.set_parent(a, i);
                            self.set_parent(b, i);
                            (n, old.aabb != aabb)
                        }
                    };
                    results.push(kept);
                }
                NodeKind::Leaf if doomed[n.index() as usize] => results.push((NodeRef::NONE, true)),
                _ => results.push((n, false)),
            }
        }
        let new_root = results.pop().map_or(NodeRef::NONE, |r| r.0);
        if new_root != self.root {
            self.root = new_root;
            self.changes.root_changed = true;
        }
        if !new_root.is_none() {
            self.set_parent(new_root, NONE);
        }
    }
}

impl Group {
    pub(crate) fn is_alive(&self) -> bool {
        self.alive
    }
    pub(crate) fn triangle_ids(&self) -> &TriangleIds {
        &self.triangles
    }
}
