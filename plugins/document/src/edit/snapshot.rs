//! An object as an undone delete or a duplicate needs it: its id, name, transform, visibility, mesh,
//! material, lights and source key, and its children's snapshots, so it can be spawned again as it
//! was.

use crate::import::spawn::{MeshSource, SourceKey};
use crate::object::SceneObject;
use crate::object::{SceneId, SceneIndex};
use crate::primitive::PrimitiveShape;
use bevy::prelude::*;

/// A scene object and its subtree, taken from the world.
#[derive(Clone, Debug)]
pub struct ObjectSnapshot {
    /// Its id.
    pub id: SceneId,
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
    /// Its parent's id when the parent is a scene object.
    pub parent: Option<SceneId>,
    children: Vec<ObjectSnapshot>,
}

impl ObjectSnapshot {
    /// The object `e` and the scene objects under it; `None` if `e` has no id.
    pub fn capture(world: &World, e: Entity) -> Option<Self> {
        let entity = world.get_entity(e).ok()?;
        let id = *entity.get::<SceneId>()?;
        let parent = entity
            .get::<ChildOf>()
            .and_then(|c| world.get::<SceneId>(c.parent()).copied());
        let children = entity
            .get::<Children>()
            .map(|c| {
                c.iter()
                    .filter_map(|child| Self::capture(world, child))
                    .collect()
            })
            .unwrap_or_default();
        Some(Self {
            id,
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
            children,
        })
    }

    /// The same subtree as objects of the scene's own, not from a file (what a copy is).
    pub fn without_sources(mut self) -> Self {
        self.source = None;
        self.children = self
            .children
            .into_iter()
            .map(Self::without_sources)
            .collect();
        self
    }

    /// Ids in the subtree, the object first, then its children's subtrees in order.
    pub fn ids(&self) -> Vec<SceneId> {
        let mut out = vec![self.id];
        for c in &self.children {
            out.extend(c.ids());
        }
        out
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
        let id = ids.next().unwrap_or(self.id);
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
        let entity = e.id();
        for c in &self.children {
            c.spawn(world, Some(entity), ids);
        }
        entity
    }
}
