//! Edits as values: what the user asked for, naming objects by their stable ids, serializable so the
//! same values drive the UI, undo, tests and `--commands` scripts. Applying one returns what undoes
//! it.

use super::snapshot::ObjectSnapshot;
use crate::scene_id::{SceneId, SceneIndex};
use crate::selection::SceneObject;
use bevy::prelude::*;
use serde::{Deserialize, Serialize};

/// A transform as commands store it (plain arrays, so scripts can write it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformValue {
    /// Position.
    pub translation: [f32; 3],
    /// Rotation quaternion, x, y, z, w.
    #[serde(default = "identity_rotation")]
    pub rotation: [f32; 4],
    /// Scale per axis.
    #[serde(default = "unit_scale")]
    pub scale: [f32; 3],
}

fn identity_rotation() -> [f32; 4] {
    [0.0, 0.0, 0.0, 1.0]
}

fn unit_scale() -> [f32; 3] {
    [1.0; 3]
}

impl From<Transform> for TransformValue {
    fn from(t: Transform) -> Self {
        Self {
            translation: t.translation.to_array(),
            rotation: t.rotation.to_array(),
            scale: t.scale.to_array(),
        }
    }
}

impl From<TransformValue> for Transform {
    fn from(t: TransformValue) -> Self {
        let rotation = Quat::from_array(t.rotation);
        Transform {
            translation: Vec3::from_array(t.translation),
            rotation: if rotation.is_finite() && rotation.length_squared() > 0.0 {
                rotation.normalize()
            } else {
                Quat::IDENTITY
            },
            scale: Vec3::from_array(t.scale),
        }
    }
}

/// The built-in shapes of the Add menu, each fitting a unit cube centred on its origin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Primitive {
    /// A unit cube.
    Cube,
    /// A sphere of diameter 1.
    Sphere,
    /// A 1 × 1 square facing up.
    Plane,
    /// A cylinder of diameter 1 and height 1.
    Cylinder,
}

impl Primitive {
    /// Every shape, in menu order.
    pub const ALL: [Primitive; 4] = [
        Primitive::Cube,
        Primitive::Sphere,
        Primitive::Plane,
        Primitive::Cylinder,
    ];

    /// A name for menus and the outliner.
    pub fn label(self) -> &'static str {
        match self {
            Primitive::Cube => "Cube",
            Primitive::Sphere => "Sphere",
            Primitive::Plane => "Plane",
            Primitive::Cylinder => "Cylinder",
        }
    }

    /// The shape's mesh.
    pub fn mesh(self) -> Mesh {
        match self {
            Primitive::Cube => Cuboid::new(1.0, 1.0, 1.0).into(),
            Primitive::Sphere => Sphere::new(0.5).mesh().uv(32, 18),
            Primitive::Plane => Plane3d::default().mesh().size(1.0, 1.0).into(),
            Primitive::Cylinder => Cylinder::new(0.5, 1.0).into(),
        }
    }

    /// The mesh's bounding box in its own space: minimum and maximum corners.
    pub fn bounds(self) -> (Vec3, Vec3) {
        match self {
            Primitive::Plane => (Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 0.0, 0.5)),
            _ => (Vec3::splat(-0.5), Vec3::splat(0.5)),
        }
    }
}

/// One edit of the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum EditCommand {
    /// Gives an object a new local transform.
    SetTransform {
        /// The object.
        id: SceneId,
        /// Its new transform, relative to its parent.
        transform: TransformValue,
    },
    /// Renames an object.
    Rename {
        /// The object.
        id: SceneId,
        /// Its new name.
        name: String,
    },
    /// Shows or hides an object (a hidden mesh leaves the traced scene).
    SetVisible {
        /// The object.
        id: SceneId,
        /// Whether it is shown.
        visible: bool,
    },
    /// Deletes objects with everything under them.
    Delete {
        /// The objects.
        ids: Vec<SceneId>,
    },
    /// Copies objects with everything under them, in place, beside the originals.
    Duplicate {
        /// The objects to copy.
        ids: Vec<SceneId>,
        /// The copies' ids, each subtree's root first; filled in on first use so a redo makes the
        /// same objects.
        #[serde(default)]
        copies: Vec<SceneId>,
    },
    /// Adds a built-in shape with a grey material.
    AddPrimitive {
        /// Which shape.
        shape: Primitive,
        /// Where, in world space.
        transform: TransformValue,
        /// Its id; filled in on first use.
        #[serde(default)]
        id: Option<SceneId>,
    },
}

/// Why a command cannot be applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    /// An id names no object.
    #[error("no object has id {0}")]
    Missing(SceneId),
    /// An object would get an id another object has.
    #[error("id {0} is already taken")]
    Taken(SceneId),
    /// A command with nothing to do.
    #[error("the command names no objects")]
    Empty,
    /// A transform with a NaN or infinite number.
    #[error("the transform has a number that is not finite")]
    NotFinite,
}

/// What undoes an applied command.
#[derive(Clone, Debug)]
pub enum Undo {
    /// Give the object this transform back.
    Transform(SceneId, Transform),
    /// Give the object this name back (none: remove it).
    Name(SceneId, Option<Name>),
    /// Give the object this visibility back.
    Visibility(SceneId, Visibility),
    /// Spawn these objects again.
    Respawn(Vec<ObjectSnapshot>),
    /// Remove these objects.
    Despawn(Vec<SceneId>),
}

fn entity(world: &World, id: SceneId) -> Result<Entity, EditError> {
    world
        .resource::<SceneIndex>()
        .entity(id)
        .ok_or(EditError::Missing(id))
}

impl EditCommand {
    /// A short description for the history.
    pub fn label(&self, world: &World) -> String {
        let name = |id: &SceneId| {
            world
                .resource::<SceneIndex>()
                .entity(*id)
                .and_then(|e| world.get::<Name>(e))
                .map_or_else(|| id.to_string(), |n| n.as_str().to_owned())
        };
        let many = |verb: &str, ids: &[SceneId]| match ids {
            [one] => format!("{verb} {}", name(one)),
            _ => format!("{verb} {} objects", ids.len()),
        };
        match self {
            EditCommand::SetTransform { id, .. } => format!("Move {}", name(id)),
            EditCommand::Rename { name: to, .. } => format!("Rename to {to}"),
            EditCommand::SetVisible { id, visible } => {
                format!("{} {}", if *visible { "Show" } else { "Hide" }, name(id))
            }
            EditCommand::Delete { ids } => many("Delete", ids),
            EditCommand::Duplicate { ids, .. } => many("Duplicate", ids),
            EditCommand::AddPrimitive { shape, .. } => format!("Add {}", shape.label()),
        }
    }

    /// Whether the command can be applied to `world` as it is.
    pub fn check(&self, world: &World) -> Result<(), EditError> {
        match self {
            EditCommand::SetTransform { id, transform } => {
                entity(world, *id)?;
                let t = transform;
                let finite = t
                    .translation
                    .iter()
                    .chain(&t.rotation)
                    .chain(&t.scale)
                    .all(|v| v.is_finite());
                if !finite {
                    return Err(EditError::NotFinite);
                }
            }
            EditCommand::Rename { id, .. } | EditCommand::SetVisible { id, .. } => {
                entity(world, *id)?;
            }
            EditCommand::Delete { ids } | EditCommand::Duplicate { ids, .. } => {
                if ids.is_empty() {
                    return Err(EditError::Empty);
                }
                for id in ids {
                    entity(world, *id)?;
                }
            }
            EditCommand::AddPrimitive { id, transform, .. } => {
                if let Some(id) = id
                    && world.resource::<SceneIndex>().entity(*id).is_some()
                {
                    return Err(EditError::Taken(*id));
                }
                let t = transform;
                if !t.translation.iter().chain(&t.scale).all(|v| v.is_finite()) {
                    return Err(EditError::NotFinite);
                }
            }
        }
        if let EditCommand::Duplicate { copies, .. } = self {
            let index = world.resource::<SceneIndex>();
            if let Some(taken) = copies.iter().find(|c| index.entity(**c).is_some()) {
                return Err(EditError::Taken(*taken));
            }
        }
        Ok(())
    }

    /// Applies the command (filling in the ids it makes) and returns what undoes it.
    pub fn apply(&mut self, world: &mut World) -> Result<Undo, EditError> {
        self.check(world)?;
        Ok(match self {
            EditCommand::SetTransform { id, transform } => {
                let e = entity(world, *id)?;
                let mut t = world
                    .get_mut::<Transform>(e)
                    .ok_or(EditError::Missing(*id))?;
                let before = *t;
                *t = (*transform).into();
                Undo::Transform(*id, before)
            }
            EditCommand::Rename { id, name } => {
                let e = entity(world, *id)?;
                let before = world.get::<Name>(e).cloned();
                world.entity_mut(e).insert(Name::new(name.clone()));
                Undo::Name(*id, before)
            }
            EditCommand::SetVisible { id, visible } => {
                let e = entity(world, *id)?;
                let before = world.get::<Visibility>(e).copied().unwrap_or_default();
                world.entity_mut(e).insert(if *visible {
                    Visibility::Inherited
                } else {
                    Visibility::Hidden
                });
                Undo::Visibility(*id, before)
            }
            EditCommand::Delete { ids } => {
                let roots = top_level(world, ids);
                let mut snapshots = Vec::new();
                for id in roots {
                    let e = entity(world, id)?;
                    if let Some(s) = ObjectSnapshot::capture(world, e) {
                        snapshots.push(s);
                    }
                    world.entity_mut(e).despawn();
                }
                Undo::Respawn(snapshots)
            }
            EditCommand::Duplicate { ids, copies } => {
                let roots = top_level(world, ids);
                let snapshots: Vec<ObjectSnapshot> = roots
                    .iter()
                    .filter_map(|id| ObjectSnapshot::capture(world, entity(world, *id).ok()?))
                    .map(ObjectSnapshot::without_sources)
                    .collect();
                let wanted: usize = snapshots.iter().map(|s| s.ids().len()).sum();
                if copies.len() != wanted {
                    let mut index = world.resource_mut::<SceneIndex>();
                    *copies = (0..wanted).map(|_| index.allocate()).collect();
                }
                let mut fresh = copies.clone().into_iter();
                let mut made = Vec::new();
                for s in &snapshots {
                    let root = s.respawn(world, &mut fresh);
                    made.extend(world.get::<SceneId>(root).copied());
                }
                Undo::Despawn(made)
            }
            EditCommand::AddPrimitive {
                shape,
                transform,
                id,
            } => {
                let new_id = match id {
                    Some(id) => *id,
                    None => world.resource_mut::<SceneIndex>().allocate(),
                };
                *id = Some(new_id);
                let mesh = world.resource_mut::<Assets<Mesh>>().add(shape.mesh());
                let material =
                    world
                        .resource_mut::<Assets<StandardMaterial>>()
                        .add(StandardMaterial {
                            base_color: Color::srgb(0.8, 0.8, 0.8),
                            perceptual_roughness: 0.6,
                            ..default()
                        });
                world.spawn((
                    Name::new(shape.label()),
                    SceneObject,
                    new_id,
                    Mesh3d(mesh),
                    MeshMaterial3d(material),
                    Transform::from(*transform),
                ));
                Undo::Despawn(vec![new_id])
            }
        })
    }
}

/// `ids` without those under another of them (deleting a parent deletes its children).
fn top_level(world: &World, ids: &[SceneId]) -> Vec<SceneId> {
    let index = world.resource::<SceneIndex>();
    let named: Vec<Entity> = ids.iter().filter_map(|id| index.entity(*id)).collect();
    let mut out = Vec::new();
    for id in ids {
        let Some(e) = index.entity(*id) else {
            continue;
        };
        let mut up = world.get::<ChildOf>(e).map(|c| c.parent());
        let mut under_another = false;
        while let Some(p) = up {
            if named.contains(&p) {
                under_another = true;
                break;
            }
            up = world.get::<ChildOf>(p).map(|c| c.parent());
        }
        if !under_another && !out.contains(id) {
            out.push(*id);
        }
    }
    out
}

impl Undo {
    /// Puts the world back as it was before the command.
    pub fn revert(&self, world: &mut World) {
        let find = |world: &World, id: &SceneId| world.resource::<SceneIndex>().entity(*id);
        match self {
            Undo::Transform(id, t) => {
                if let Some(e) = find(world, id)
                    && let Some(mut tr) = world.get_mut::<Transform>(e)
                {
                    *tr = *t;
                }
            }
            Undo::Name(id, name) => {
                if let Some(e) = find(world, id) {
                    match name {
                        Some(n) => world.entity_mut(e).insert(n.clone()),
                        None => world.entity_mut(e).remove::<Name>(),
                    };
                }
            }
            Undo::Visibility(id, v) => {
                if let Some(e) = find(world, id) {
                    world.entity_mut(e).insert(*v);
                }
            }
            Undo::Respawn(snapshots) => {
                for s in snapshots {
                    s.respawn(world, &mut std::iter::empty());
                }
            }
            Undo::Despawn(ids) => {
                for id in ids {
                    if let Some(e) = find(world, id) {
                        world.entity_mut(e).despawn();
                    }
                }
            }
        }
    }
}
