//! The tree the worker keeps and publishes: the engine's BVH and which entity each group is, its
//! figures, and what changed in it for a renderer.

use crate::types::shading::MeshShading;
use bevy::prelude::*;
use std::collections::{HashMap, HashSet};
use std::sync::Arc;
use std::time::Duration;
use treelight_bvh::glam::Affine3A;
use treelight_bvh::{Bvh, BvhError, ChangeSet, GroupId, Hit};

/// Figures about the tree, refreshed every frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneStats {
    /// Triangles in the tree.
    pub triangles: u32,
    /// Inner nodes.
    pub inner_nodes: u32,
    /// SAH cost (Eq. 1, c_T = c_I = 1 by default).
    pub sah_cost: f32,
    /// Meshes still being copied out of the world, plus commands sent but not yet applied.
    pub pending: usize,
    /// Triangles per second (millions) of the last batch of inserted meshes, build included.
    pub insertion_mtris_per_s: f64,
    /// From sending the last mesh to its appearance in the tree.
    pub last_latency: Duration,
    /// Still meshes whose binned build the worker has replaced in idle time by a full-sweep SAH
    /// build of the same triangles, so far.
    pub meshes_refined: u64,
    /// Heap bytes the tree holds ([`Bvh::memory_bytes`]), as of the last cost.
    pub tree_bytes: usize,
    /// Heap bytes of the groups' normals and texture coordinates ([`SceneTree::shading`]), each
    /// shared set once, as of the last cost.
    pub shading_bytes: usize,
}

/// The tree and the entity each group belongs to.
#[derive(Default)]
pub struct SceneTree {
    /// The global BVH.
    pub bvh: Bvh,
    /// Which entity each group is.
    pub group_entity: HashMap<GroupId, Entity>,
    /// Which groups each traced entity is: one, or one per chunk of a mesh that entered the tree in
    /// spatial chunks ([`SceneBvhConfig::chunks`](crate::types::config::SceneBvhConfig::chunks)).
    pub entity_groups: HashMap<Entity, Vec<GroupId>>,
    /// Each group's normals and texture coordinates, in the order of its triangles
    /// ([`Bvh::group_triangles`]).
    pub shading: HashMap<GroupId, Arc<MeshShading>>,
    /// Groups inserted since a renderer last took the changes (bounded by the live groups: removed
    /// ones leave the set).
    pub(crate) fresh_groups: HashSet<GroupId>,
    /// Groups re-laid since a renderer last asked (a mesh rebuilt by another builder), each with
    /// the group it replaced.
    pub(crate) relaid_groups: HashMap<GroupId, GroupId>,
    /// The mesh asset each traced entity shows, and the entities showing each: entities with the
    /// same mesh share its triangles in the tree ([`Bvh::insert_instance`]).
    pub(crate) entity_mesh: HashMap<Entity, AssetId<Mesh>>,
    pub(crate) mesh_entities: HashMap<AssetId<Mesh>, Vec<Entity>>,
    /// Entities holding an older version of their mesh than the last one sent (the asset was
    /// edited, and their own new version is on its way): never a source for others.
    pub(crate) stale: HashSet<Entity>,
}

impl SceneTree {
    /// Heap bytes of the tree's arrays and of the groups' shading (each shared set once).
    pub fn memory_bytes(&self) -> (usize, usize) {
        // Shading shared by groups (instances, re-laid groups) counts once, and vertex arrays
        // shared by a mesh's chunks once.
        let (mut sets, mut vertex_sets) = (HashSet::new(), HashSet::new());
        let shading = self
            .shading
            .values()
            .filter(|s| sets.insert(Arc::as_ptr(s)))
            .map(|s| {
                let (vertices, at) = s.vertex_bytes();
                s.corner_bytes() + if vertex_sets.insert(at) { vertices } else { 0 }
            })
            .sum();
        (self.bvh.memory_bytes().total(), shading)
    }

    pub(crate) fn bind(
        &mut self,
        e: Entity,
        g: GroupId,
        shading: Arc<MeshShading>,
        mesh: AssetId<Mesh>,
    ) {
        self.group_entity.insert(g, e);
        self.entity_groups.entry(e).or_default().push(g);
        self.shading.insert(g, shading);
        self.fresh_groups.insert(g);
        match self.entity_mesh.insert(e, mesh) {
            Some(old) if old == mesh => {}
            old => {
                if let Some(old) = old {
                    self.unlist(e, old);
                }
                self.mesh_entities.entry(mesh).or_default().push(e);
            }
        }
        self.stale.remove(&e);
    }

    fn unlist(&mut self, e: Entity, mesh: AssetId<Mesh>) {
        if let Some(list) = self.mesh_entities.get_mut(&mesh) {
            list.retain(|&x| x != e);
            if list.is_empty() {
                self.mesh_entities.remove(&mesh);
            }
        }
    }

    /// The groups entity `e` is in the tree (none if it is not traced).
    pub fn groups_of(&self, e: Entity) -> &[GroupId] {
        self.entity_groups.get(&e).map_or(&[], Vec::as_slice)
    }

    /// Whether any of `e`'s triangles are in the tree.
    pub fn is_traced(&self, e: Entity) -> bool {
        self.entity_groups.contains_key(&e)
    }

    /// `e` brought new triangles for `mesh`: every other entity's are an older version.
    pub(crate) fn supersede(&mut self, e: Entity, mesh: AssetId<Mesh>) {
        if let Some(list) = self.mesh_entities.get(&mesh) {
            self.stale.extend(list.iter().copied().filter(|x| *x != e));
        }
    }

    /// Traces `e` with the triangles an entity of the same mesh brought (`e` itself among them:
    /// its new instance is made before its old group goes, so the triangles never lapse). On
    /// failure `e` is not traced.
    pub(crate) fn share(
        &mut self,
        e: Entity,
        mesh: AssetId<Mesh>,
        transform: Affine3A,
    ) -> Result<(), BvhError> {
        // Another entity's current version first, else `e`'s own, else whatever there is.
        let holders: Vec<Entity> = self.mesh_entities.get(&mesh).cloned().unwrap_or_default();
        let fresh = |x: &Entity| !self.stale.contains(x);
        let sources: Vec<GroupId> = holders
            .iter()
            .filter(|x| **x != e && fresh(x))
            .chain(holders.iter().filter(|x| **x == e && fresh(x)))
            .chain(holders.iter())
            .find_map(|x| self.entity_groups.get(x))
            .cloned()
            .unwrap_or_default();
        if sources.is_empty() {
            self.remove_entity(e);
            return Err(BvhError::UnknownGroup);
        }
        // One instance per group of the source (one per chunk of a chunked mesh).
        let mut made: Vec<(GroupId, GroupId)> = Vec::with_capacity(sources.len());
        let failed = self.bvh.batch(|bvh| {
            for &source in &sources {
                match bvh.insert_instance(source, transform) {
                    Ok(g) => made.push((g, source)),
                    Err(err) => return Some(err),
                }
            }
            None
        });
        if let Some(err) = failed {
            for (g, _) in made {
                // Made just now by this tree, so removal cannot fail.
                let _ = self.bvh.remove_group(g);
            }
            self.remove_entity(e);
            return Err(err);
        }
        self.remove_entity(e);
        for (g, source) in made {
            let shading = self.shading.get(&source).cloned().unwrap_or_default();
            self.bind(e, g, shading, mesh);
        }
        Ok(())
    }

    pub(crate) fn remove_entity(&mut self, e: Entity) {
        self.stale.remove(&e);
        if let Some(mesh) = self.entity_mesh.remove(&e) {
            self.unlist(e, mesh);
        }
        for g in self.entity_groups.remove(&e).unwrap_or_default() {
            self.drop_group(g);
        }
    }

    /// Removes some of `e`'s groups (an older version of its mesh, once all chunks of the new one
    /// are in); `e` stays traced by the rest.
    pub(crate) fn remove_groups(&mut self, e: Entity, old: &[GroupId]) {
        if let Some(list) = self.entity_groups.get_mut(&e) {
            list.retain(|g| !old.contains(g));
            if list.is_empty() {
                self.remove_entity(e);
            }
        }
        for &g in old {
            if self.group_entity.get(&g) == Some(&e) {
                self.drop_group(g);
            }
        }
    }

    /// `e`'s group `old` was swapped in the tree for `new` ([`Bvh::swap_group`]): the same
    /// triangles in the same order, so the same shading and mesh.
    pub(crate) fn replace_group(&mut self, e: Entity, old: GroupId, new: GroupId) {
        let shading = self.shading.get(&old).cloned().unwrap_or_default();
        self.forget_group(old);
        if let Some(list) = self.entity_groups.get_mut(&e) {
            list.retain(|g| *g != old);
        }
        if let Some(&mesh) = self.entity_mesh.get(&e) {
            self.bind(e, new, shading, mesh);
            // The same triangles, laid out anew: their shading moves with them, no hit changes.
            if self.fresh_groups.remove(&new) {
                let was = self.relaid_groups.remove(&old).unwrap_or(old);
                self.relaid_groups.insert(new, was);
            }
        }
    }

    /// Forgets what this tree keeps about group `g` (the engine's tree is the caller's).
    fn forget_group(&mut self, g: GroupId) {
        self.group_entity.remove(&g);
        self.shading.remove(&g);
        self.fresh_groups.remove(&g);
        self.relaid_groups.remove(&g);
    }

    fn drop_group(&mut self, g: GroupId) {
        self.forget_group(g);
        // The handle came from this tree, so removal cannot fail.
        let _ = self.bvh.remove_group(g);
    }

    /// The entity owning triangle `t` (the one whose mesh brought it, while it is traced; entities
    /// of the same mesh share it: see [`SceneTree::entity_of_hit`]).
    pub fn entity_of_triangle(&self, t: u32) -> Option<Entity> {
        self.bvh
            .triangle_group(t)
            .and_then(|g| self.group_entity.get(&g).copied())
    }

    /// The entity a ray hit: the one whose instance it reached the triangle through.
    pub fn entity_of_hit(&self, hit: &Hit) -> Option<Entity> {
        self.bvh
            .hit_group(hit)
            .and_then(|g| self.group_entity.get(&g).copied())
    }
}

/// What changed in the tree since a renderer last asked (`SceneBvh::try_take_changes`).
#[derive(Clone, Debug, Default)]
pub struct SceneChanges {
    /// The engine's change set: node ranges, triangles written and removed, instances.
    pub bvh: ChangeSet,
    /// Groups inserted since then, still alive, by slot: their triangles' shading data must be
    /// uploaded ([`SceneTree::shading`]).
    pub fresh_groups: Vec<GroupId>,
    /// Groups re-laid since then (a still mesh rebuilt by a better builder: the same triangles in
    /// new slots), by slot, each with the group it replaced: their shading must be uploaded again,
    /// but no hit changed.
    pub relaid_groups: Vec<(GroupId, GroupId)>,
    /// The tree's version these changes bring a copy up to (`SceneBvh::version`; at most one
    /// behind, never ahead, when the worker has just written).
    pub version: u64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use treelight_bvh::Triangle;

    fn quad(z: f32) -> Vec<Triangle> {
        let v = |x: f32, y: f32| Vec3::new(x, y, z);
        vec![
            Triangle::new(v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0)),
            Triangle::new(v(0.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)),
        ]
    }

    #[test]
    fn shared_meshes_take_their_triangles_from_a_current_holder() {
        let mut world = World::new();
        let [a, b, c] = [(); 3].map(|_| world.spawn_empty().id());
        let mesh = AssetId::<Mesh>::default();
        let mut tree = SceneTree::default();
        let g = tree
            .bvh
            .insert_group(&quad(0.0), Affine3A::IDENTITY, false)
            .unwrap();
        tree.bind(a, g, Arc::default(), mesh);
        // The order proptest found: `a` is sent again as an instance before the first copy of its
        // mesh arrives, so it must share its own triangles.
        tree.share(a, mesh, Affine3A::from_translation(Vec3::X))
            .unwrap();
        tree.share(b, mesh, Affine3A::from_translation(Vec3::Y))
            .unwrap();
        assert_eq!(tree.bvh.triangle_count(), 2);
        assert_eq!(tree.entity_groups.len(), 2);
        tree.bvh.validate().unwrap();
        // The mesh edited: `a` brings new triangles; `b` still holds the old ones, and a new copy
        // shares `a`'s.
        let fresh = tree
            .bvh
            .insert_group(&quad(5.0), Affine3A::IDENTITY, false)
            .unwrap();
        tree.remove_entity(a);
        tree.bind(a, fresh, Arc::default(), mesh);
        tree.supersede(a, mesh);
        tree.share(c, mesh, Affine3A::IDENTITY).unwrap();
        let shared =
            |t: &SceneTree, e: Entity| t.bvh.shared_triangles(t.groups_of(e)[0]).unwrap().to_vec();
        assert_eq!(shared(&tree, c), shared(&tree, a));
        assert_ne!(shared(&tree, c), shared(&tree, b));
        tree.bvh.validate().unwrap();
    }
}
