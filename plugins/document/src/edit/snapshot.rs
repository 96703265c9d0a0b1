//! An object as an undone delete or a duplicate needs it: its id, name, transform, visibility, mesh,
//! material, lights and source key, and its children's snapshots, so it can be spawned again as it
//! was.

use crate::scene::spawn::{MeshSource, SourceKey};
use crate::values::object::SceneObject;
use crate::values::object::{SceneId, SceneIndex};
use crate::values::primitive::PrimitiveShape;
use bevy::prelude::*;

/// One object of a snapshot, without its children.
#[derive(Clone, Debug)]
struct SnapshotNode {
    id: SceneId,
    name: Option<Name>,
    transform: Transform,
    visibility: Option<Visibility>,
    mesh: Option<Mesh3d>,
    material: Option<MeshMaterial3d<StandardMaterial>>,
    point: Option<PointLight>,
    spot: Option<SpotLight>,
    directional: Option<DirectionalLight>,
    source: Option<SourceKey>,
    mesh_source: Option<MeshSource>,
    shape: Option<PrimitiveShape>,
    /// Its parent's place in the snapshot (`None` for the root).
    parent: Option<u32>,
}

/// A scene object and its subtree, taken from the world: a flat list in pre-order, each object
/// naming its parent's place, so that no depth of hierarchy is walked (or dropped) by recursion.
#[derive(Clone, Debug)]
pub struct ObjectSnapshot {
    /// Its id.
    pub id: SceneId,
    /// Its parent's id when the parent is a scene object.
    pub parent: Option<SceneId>,
    nodes: Vec<SnapshotNode>,
}

impl SnapshotNode {
    fn of(entity: EntityRef, parent: Option<u32>) -> Option<Self> {
        Some(Self {
            id: *entity.get::<SceneId>()?,
            name: entity.get::<Name>().cloned(),
            transform: entity.get::<Transform>().copied().unwrap_or_default(),
            visibility: entity.get::<Visibility>().copied(),
            mesh: entity.get::<Mesh3d>().cloned(),
            material: entity.get::<MeshMaterial3d<StandardMaterial>>().cloned(),
            point: entity.get::<PointLight>().copied(),
            spot: entity.get::<SpotLight>().copied(),
            directional: entity.get::<DirectionalLight>().copied(),
            source: entity.get::<SourceKey>().cloned(),
            mesh_source: entity.get::<MeshSource>().cloned(),
            shape: entity.get::<PrimitiveShape>().copied(),
            parent,
        })
    }

    fn spawn(&self, world: &mut World, id: SceneId, parent: Option<Entity>) -> Entity {
        let mut e = world.spawn((SceneObject, id, self.transform));
        if let Some(v) = self.visibility {
            e.insert(v);
        }
        if let Some(n) = &self.name {
            e.insert(n.clone());
        }
        if let Some(m) = &self.mesh {
            e.insert(m.clone());
        }
        if let Some(m) = &self.material {
            e.insert(m.clone());
        }
        if let Some(l) = &self.point {
            e.insert(*l);
        }
        if let Some(l) = &self.spot {
            e.insert(*l);
        }
        if let Some(l) = &self.directional {
            e.insert(*l);
        }
        if let Some(s) = &self.source {
            e.insert(s.clone());
        }
        if let Some(s) = &self.mesh_source {
            e.insert(s.clone());
        }
        if let Some(s) = self.shape {
            e.insert(s);
        }
        if let Some(p) = parent {
            e.insert(ChildOf(p));
        }
        e.id()
    }
}

impl ObjectSnapshot {
    /// The object `e` and the scene objects under it; `None` if `e` has no id. (A child without
    /// an id is left out with what lies under it.)
    pub fn capture(world: &World, e: Entity) -> Option<Self> {
        let entity = world.get_entity(e).ok()?;
        let root = SnapshotNode::of(entity, None)?;
        let parent = entity
            .get::<ChildOf>()
            .and_then(|c| world.get::<SceneId>(c.parent()).copied());
        let mut nodes = vec![root];
        // (entity, its parent's place), children in order.
        let mut stack: Vec<(Entity, u32)> = Vec::new();
        let push_children = |stack: &mut Vec<(Entity, u32)>, at: Entity, place: u32| {
            if let Some(children) = world.get::<Children>(at) {
                stack.extend(children.iter().rev().map(|c| (c, place)));
            }
        };
        push_children(&mut stack, e, 0);
        while let Some((at, parent_place)) = stack.pop() {
            let Some(node) = world
                .get_entity(at)
                .ok()
                .and_then(|r| SnapshotNode::of(r, Some(parent_place)))
            else {
                continue;
            };
            let place = nodes.len() as u32;
            nodes.push(node);
            push_children(&mut stack, at, place);
        }
        Some(Self {
            id: nodes[0].id,
            parent,
            nodes,
        })
    }

    /// The same subtree as objects of the scene's own, not from a file (what a copy is).
    pub fn without_sources(mut self) -> Self {
        for n in &mut self.nodes {
            n.source = None;
        }
        self
    }

    /// Ids in the subtree, the object first, then its children's subtrees in order.
    pub fn ids(&self) -> Vec<SceneId> {
        self.nodes.iter().map(|n| n.id).collect()
    }

    /// Spawns the subtree back under its recorded parent (at the top when that parent is gone),
    /// giving each object the next id from `ids` (its own when `ids` runs out). Returns the root.
    pub fn respawn(&self, world: &mut World, ids: &mut impl Iterator<Item = SceneId>) -> Entity {
        let parent = self
            .parent
            .and_then(|p| world.resource::<SceneIndex>().entity(p));
        self.spawn(world, parent, ids)
    }

    /// Spawns the subtree under `parent`, giving each object the next id from `ids` (its own id
    /// when `ids` runs out). Returns the root entity.
    pub fn spawn(
        &self,
        world: &mut World,
        parent: Option<Entity>,
        ids: &mut impl Iterator<Item = SceneId>,
    ) -> Entity {
        let mut spawned: Vec<Entity> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let id = ids.next().unwrap_or(node.id);
            let under = node
                .parent
                .map_or(parent, |p| spawned.get(p as usize).copied());
            spawned.push(node.spawn(world, id, under));
        }
        spawned[0]
    }
}
