//! Edits as values: what the user asked for, naming objects by their stable ids, serializable so the
//! same values drive the UI, undo, tests and `--commands` scripts. Applying one returns what undoes
//! it.

use super::snapshot::ObjectSnapshot;
use crate::scene::environment::SceneEnvironment;
use crate::values::look::SceneLook;
use crate::values::map_transforms::MaterialMapTransforms;
use crate::values::object::SceneObject;
use crate::values::object::{EditedObjects, SceneId, SceneIndex};
use crate::values::primitive::{Primitive, PrimitiveShape};
use bevy::prelude::*;
use serde::{Deserialize, Serialize};

pub use crate::values::light::LightKind;
use crate::values::light::LightValue;
/// The values commands carry, kept with them for the shell and scripts.
pub use crate::values::material::{MaterialAlpha, MaterialValue};
pub use crate::values::transform::{MAX_VALUE, TransformValue, in_range};

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
    /// Gives several objects new local transforms at once (one gizmo drag of a multiple selection).
    SetTransforms {
        /// Each object and its new transform, relative to its parent.
        transforms: Vec<(SceneId, TransformValue)>,
    },
    /// Moves objects under another (or to the top, for `None`), keeping where they are in the world.
    Reparent {
        /// The objects.
        ids: Vec<SceneId>,
        /// The new parent.
        parent: Option<SceneId>,
    },
    /// Changes the values of an object's material (every object sharing it changes too).
    SetMaterial {
        /// The object.
        id: SceneId,
        /// The new values.
        material: MaterialValue,
    },
    /// Gives an object its own copy of its material, so edits no longer reach the others.
    MakeMaterialUnique {
        /// The object.
        id: SceneId,
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
    /// Adds a light.
    AddLight {
        /// Which kind.
        kind: LightKind,
        /// Where, in world space (a directional light shines along its forward axis, -z).
        transform: TransformValue,
        /// Its id; filled in on first use.
        #[serde(default)]
        id: Option<SceneId>,
    },
    /// Puts objects under a new empty group, keeping where they are in the world. The group goes
    /// at their median point, under the first object's parent.
    Group {
        /// The objects.
        ids: Vec<SceneId>,
        /// The group's name.
        name: String,
        /// The group's id; filled in on first use.
        #[serde(default)]
        group: Option<SceneId>,
    },
    /// Adds a scene file's contents as an assembly under one root named after the file (and a sun
    /// if the scene has no light).
    Import {
        /// The file (.gltf, .glb, .obj or .ply).
        file: std::path::PathBuf,
        /// The root's id; filled in on first use.
        #[serde(default)]
        root: Option<SceneId>,
        /// The root's transform (none: the file's own coordinates).
        #[serde(default)]
        transform: Option<TransformValue>,
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
    /// Gives a light object new values (its kind too).
    SetLight {
        /// The light.
        id: SceneId,
        /// Its new values.
        light: LightValue,
    },
    /// Sets the exposure and tone curve every view of the scene uses.
    SetLook {
        /// The new look.
        look: SceneLook,
    },
    /// Sets the panorama lighting the scene, its turn, intensity and whether it is seen.
    SetEnvironment {
        /// The new environment.
        environment: SceneEnvironment,
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
    /// A transform with a NaN, infinite or huge number.
    #[error("the transform has a number that is not finite or is larger than {MAX_VALUE:e}")]
    NotFinite,
    /// An id for a new object outside the range ids take.
    #[error("id {0} is outside the range of ids (1 to {max})", max = SceneId::MAX.0)]
    IdOutOfRange(SceneId),
    /// An object without a material, for a material command.
    #[error("{0} has no material")]
    NoMaterial(SceneId),
    /// A file that cannot be imported.
    #[error("{0}")]
    Import(String),
    /// Material values out of range.
    #[error("a material value is not finite or too large, or the emission is negative")]
    BadMaterial,
    /// A command that cannot be shown as a live preview (only transforms can).
    #[error("only transform commands can be previewed")]
    NotPreviewable,
    /// A parent that is the object itself or under it.
    #[error("{0} cannot go under itself or its own descendant")]
    Cycle(SceneId),
    /// An object that is not a light, for a light command.
    #[error("{0} is not a light")]
    NotALight(SceneId),
    /// Light values out of range.
    #[error(
        "a light value is not finite or out of range (negative intensity or colour, a range of 0 or less, or a cone outside 0 ≤ inner ≤ outer ≤ 90°)"
    )]
    BadLight,
    /// An exposure that is not finite or past the widest compensation.
    #[error("the exposure is not finite or beyond ±{max} stops, or the sky is negative or brighter than {sky:e} nits", max = crate::values::look::MAX_EXPOSURE_STOPS, sky = crate::values::look::MAX_SKY)]
    BadLook,
    /// A panorama that is not a `.hdr` or `.exr` file, or a rotation or intensity out of range.
    #[error("the sky panorama is not a .hdr or .exr file, or its rotation is beyond a full turn, or its intensity is negative or above {max:e} nits", max = crate::scene::environment::MAX_ENVIRONMENT_INTENSITY)]
    BadEnvironment,
    /// A hierarchy that would nest deeper than the editor holds.
    #[error(
        "{0} would lie {1} levels deep, more than the {max} the editor holds",
        max = crate::scene::hierarchy::MAX_HIERARCHY_DEPTH
    )]
    TooDeep(SceneId, usize),
}

/// What undoes an applied command.
#[derive(Clone, Debug)]
pub enum Undo {
    /// Give the object this transform back.
    Transform(SceneId, Transform),
    /// Give each object its transform back.
    Transforms(Vec<(SceneId, Transform)>),
    /// Put each object back under its parent (none: at the top) with its local transform, in
    /// reverse order of the list.
    Parents(Vec<(SceneId, Option<SceneId>, Transform)>),
    /// Give the object's material these values back.
    Material(SceneId, MaterialValue),
    /// Give the object this material back.
    MaterialHandle(SceneId, Handle<StandardMaterial>),
    /// Give the object this name back (none: remove it).
    Name(SceneId, Option<Name>),
    /// Give the object this visibility back.
    Visibility(SceneId, Visibility),
    /// Spawn these objects again.
    Respawn(Vec<ObjectSnapshot>),
    /// Remove these objects.
    Despawn(Vec<SceneId>),
    /// Give the light these values back.
    Light(SceneId, LightValue),
    /// Give the scene this look back.
    Look(SceneLook),
    /// Give the scene this environment back.
    Environment(SceneEnvironment),
    /// Undo each of these, last first.
    Many(Vec<Undo>),
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
            EditCommand::SetTransforms { transforms } => {
                let ids: Vec<SceneId> = transforms.iter().map(|(id, _)| *id).collect();
                many("Move", &ids)
            }
            EditCommand::Reparent { ids, parent } => match parent {
                Some(p) => format!("{} under {}", many("Put", ids), name(p)),
                None => format!("{} at the top", many("Put", ids)),
            },
            EditCommand::Rename { name: to, .. } => format!("Rename to {to}"),
            EditCommand::SetMaterial { id, .. } => format!("Edit the material of {}", name(id)),
            EditCommand::MakeMaterialUnique { id } => {
                format!("Give {} its own material", name(id))
            }
            EditCommand::SetVisible { id, visible } => {
                format!("{} {}", if *visible { "Show" } else { "Hide" }, name(id))
            }
            EditCommand::Delete { ids } => many("Delete", ids),
            EditCommand::Duplicate { ids, .. } => many("Duplicate", ids),
            EditCommand::AddPrimitive { shape, .. } => format!("Add {}", shape.label()),
            EditCommand::AddLight { kind, .. } => format!("Add {}", kind.label()),
            EditCommand::Import { file, .. } => format!(
                "Import {}",
                file.file_name().map_or_else(
                    || file.display().to_string(),
                    |n| n.to_string_lossy().into()
                )
            ),
            EditCommand::Group { ids, .. } => many("Group", ids),
            EditCommand::SetLight { id, light } => {
                format!("Edit {} ({})", name(id), light.kind.label().to_lowercase())
            }
            EditCommand::SetLook { look } => {
                let before = world
                    .get_resource::<SceneLook>()
                    .copied()
                    .unwrap_or_default();
                let exposure = format!("Exposure {:+.1} EV", look.exposure);
                let tone = format!("Tone curve {}", look.tone.label());
                match (look.exposure != before.exposure, look.tone != before.tone) {
                    (true, true) => format!("{exposure}, {}", tone.to_lowercase()),
                    (false, true) => tone,
                    (false, false) if look.sky != before.sky => "Sky colour".into(),
                    _ => exposure,
                }
            }
            EditCommand::SetEnvironment { environment } => {
                let before = world
                    .get_resource::<SceneEnvironment>()
                    .cloned()
                    .unwrap_or_default();
                match &environment.image {
                    None if before.image.is_some() => "Remove the sky panorama".into(),
                    Some(p) if before.image.as_ref() != Some(p) => format!(
                        "Sky panorama {}",
                        p.file_name().map_or_else(
                            || p.display().to_string(),
                            |n| n.to_string_lossy().into()
                        )
                    ),
                    _ if environment.shown != before.shown => if environment.shown {
                        "Show the sky panorama"
                    } else {
                        "Hide the sky panorama"
                    }
                    .into(),
                    _ if environment.intensity != before.intensity => {
                        format!("Sky intensity {:.0} nits", environment.intensity)
                    }
                    _ => format!("Sky rotation {:.0}°", environment.rotation_degrees),
                }
            }
        }
    }

    /// Whether the command can be applied to `world` as it is.
    pub fn check(&self, world: &World) -> Result<(), EditError> {
        match self {
            EditCommand::SetTransform { id, transform } => {
                entity(world, *id)?;
                check_finite(transform)?;
            }
            EditCommand::SetTransforms { transforms } => {
                if transforms.is_empty() {
                    return Err(EditError::Empty);
                }
                for (id, transform) in transforms {
                    entity(world, *id)?;
                    check_finite(transform)?;
                }
            }
            EditCommand::Reparent { ids, parent } => {
                if ids.is_empty() {
                    return Err(EditError::Empty);
                }
                let index = world.resource::<SceneIndex>();
                let new_parent = match parent {
                    Some(p) => Some(index.entity(*p).ok_or(EditError::Missing(*p))?),
                    None => None,
                };
                let base = new_parent.map_or(0, |p| crate::scene::hierarchy::depth_of(world, p));
                for id in ids {
                    let e = entity(world, *id)?;
                    // The new parent may not be the object or anything under it.
                    let mut up = new_parent;
                    while let Some(p) = up {
                        if p == e {
                            return Err(EditError::Cycle(*id));
                        }
                        up = world.get::<ChildOf>(p).map(|c| c.parent());
                    }
                    check_depth(world, *id, e, base)?;
                }
            }
            EditCommand::Rename { id, .. } | EditCommand::SetVisible { id, .. } => {
                entity(world, *id)?;
            }
            EditCommand::SetMaterial { id, material } => {
                material_of(world, *id)?;
                if !material.is_valid() {
                    return Err(EditError::BadMaterial);
                }
            }
            EditCommand::MakeMaterialUnique { id } => {
                material_of(world, *id)?;
            }
            EditCommand::Delete { ids } | EditCommand::Duplicate { ids, .. } => {
                if ids.is_empty() {
                    return Err(EditError::Empty);
                }
                for id in ids {
                    entity(world, *id)?;
                }
            }
            EditCommand::Import {
                root, transform, ..
            } => {
                if let Some(t) = transform {
                    check_finite(t)?;
                }
                check_free(world, *root)?;
            }
            EditCommand::AddLight { id, transform, .. } => {
                check_free(world, *id)?;
                check_finite(transform)?;
            }
            EditCommand::Group { ids, group, .. } => {
                if ids.is_empty() {
                    return Err(EditError::Empty);
                }
                // The group goes under the first object's parent; all of them go under it.
                let first = entity(world, ids[0])?;
                let base = crate::scene::hierarchy::depth_of(world, first);
                for id in ids {
                    let e = entity(world, *id)?;
                    check_depth(world, *id, e, base)?;
                }
                check_free(world, *group)?;
            }
            EditCommand::AddPrimitive { id, transform, .. } => {
                check_free(world, *id)?;
                check_finite(transform)?;
            }
            EditCommand::SetLight { id, light } => {
                let e = entity(world, *id)?;
                LightValue::of(&world.entity(e)).ok_or(EditError::NotALight(*id))?;
                if !light.is_valid() {
                    return Err(EditError::BadLight);
                }
            }
            EditCommand::SetLook { look } => {
                if !look.is_valid() {
                    return Err(EditError::BadLook);
                }
            }
            EditCommand::SetEnvironment { environment } => {
                if !environment.is_valid() {
                    return Err(EditError::BadEnvironment);
                }
            }
        }
        if let EditCommand::Duplicate { copies, .. } = self {
            for c in copies {
                check_free(world, Some(*c))?;
            }
        }
        Ok(())
    }

    /// Applies the command (filling in the ids it makes) and returns what undoes it.
    pub fn apply(&mut self, world: &mut World) -> Result<Undo, EditError> {
        self.check(world)?;
        self.mark_edited(world);
        self.apply_checked(world)
    }

    /// Notes the objects whose saved values the command sets ([`EditedObjects`]): a material's
    /// values reach every object sharing it.
    fn mark_edited(&self, world: &mut World) {
        let mut ids: Vec<SceneId> = match self {
            EditCommand::SetTransform { id, .. }
            | EditCommand::MakeMaterialUnique { id }
            | EditCommand::Rename { id, .. }
            | EditCommand::SetVisible { id, .. }
            | EditCommand::SetLight { id, .. } => vec![*id],
            EditCommand::SetTransforms { transforms } => transforms.iter().map(|t| t.0).collect(),
            EditCommand::Reparent { ids, .. } | EditCommand::Group { ids, .. } => ids.clone(),
            EditCommand::SetMaterial { id, .. } => {
                let mut ids = vec![*id];
                if let Ok(handle) = material_of(world, *id) {
                    let mut users = world.query::<(&SceneId, &MeshMaterial3d<StandardMaterial>)>();
                    ids.extend(
                        users
                            .iter(world)
                            .filter(|(_, m)| m.0.id() == handle.id())
                            .map(|(id, _)| *id),
                    );
                }
                ids
            }
            _ => return,
        };
        if let Some(mut edited) = world.get_resource_mut::<EditedObjects>() {
            edited.0.extend(ids.drain(..));
        }
    }

    fn apply_checked(&mut self, world: &mut World) -> Result<Undo, EditError> {
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
            EditCommand::SetTransforms { transforms } => {
                let mut before = Vec::with_capacity(transforms.len());
                for (id, transform) in transforms.iter() {
                    let e = entity(world, *id)?;
                    if let Some(mut t) = world.get_mut::<Transform>(e) {
                        before.push((*id, *t));
                        *t = (*transform).into();
                    }
                }
                Undo::Transforms(before)
            }
            EditCommand::Reparent { ids, parent } => {
                let new_parent = parent.and_then(|p| world.resource::<SceneIndex>().entity(p));
                let mut before = Vec::with_capacity(ids.len());
                for id in ids.iter() {
                    let e = entity(world, *id)?;
                    let old_parent = world
                        .get::<ChildOf>(e)
                        .and_then(|c| world.get::<SceneId>(c.parent()).copied());
                    let local = world.get::<Transform>(e).copied().unwrap_or_default();
                    before.push((*id, old_parent, local));
                    set_parent_keeping_world(world, e, new_parent);
                }
                Undo::Parents(before)
            }
            EditCommand::SetMaterial { id, material } => {
                let handle = material_of(world, *id)?;
                let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
                let m = materials
                    .get_mut(&handle)
                    .ok_or(EditError::NoMaterial(*id))?;
                let before = MaterialValue::of(&m);
                material.write(m.into_inner());
                Undo::Material(*id, before)
            }
            EditCommand::MakeMaterialUnique { id } => {
                let handle = material_of(world, *id)?;
                let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
                let copy = materials
                    .get(&handle)
                    .ok_or(EditError::NoMaterial(*id))?
                    .clone();
                let unique = materials.add(copy);
                if let Some(mut t) = world.get_resource_mut::<MaterialMapTransforms>() {
                    t.copy(handle.id(), unique.id());
                }
                let e = entity(world, *id)?;
                world.entity_mut(e).insert(MeshMaterial3d(unique));
                Undo::MaterialHandle(*id, handle)
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
                    crate::scene::hierarchy::despawn_subtree(world, e);
                }
                Undo::Respawn(snapshots)
            }
            EditCommand::Duplicate { ids, copies } => duplicate(world, ids, copies),
            EditCommand::Import {
                file,
                root,
                transform,
            } => import(world, file, root, transform)?,
            EditCommand::AddLight {
                kind,
                transform,
                id,
            } => add_light(world, *kind, transform, id),
            EditCommand::Group { ids, name, group } => make_group(world, ids, name, group)?,
            EditCommand::AddPrimitive {
                shape,
                transform,
                id,
            } => add_primitive(world, *shape, transform, id),
            EditCommand::SetLight { id, light } => {
                let e = entity(world, *id)?;
                let before = LightValue::of(&world.entity(e)).ok_or(EditError::NotALight(*id))?;
                light.put_on(&mut world.entity_mut(e));
                Undo::Light(*id, before)
            }
            EditCommand::SetLook { look } => {
                let before = world
                    .get_resource::<SceneLook>()
                    .copied()
                    .unwrap_or_default();
                world.insert_resource(*look);
                Undo::Look(before)
            }
            EditCommand::SetEnvironment { environment } => {
                let before = world
                    .get_resource::<SceneEnvironment>()
                    .cloned()
                    .unwrap_or_default();
                world.insert_resource(environment.clone());
                Undo::Environment(before)
            }
        })
    }
}

/// Copies of the objects `ids` and everything under them, under the ids `copies` (given now
/// when they do not fit).
fn duplicate(world: &mut World, ids: &[SceneId], copies: &mut Vec<SceneId>) -> Undo {
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

/// The file as an assembly: the scene parsed for `root` when there is one, else read now.
fn import(
    world: &mut World,
    file: &std::path::Path,
    root: &mut Option<SceneId>,
    transform: &Option<TransformValue>,
) -> Result<Undo, EditError> {
    let parsed = root.and_then(|id| {
        world
            .get_resource_mut::<crate::scene::parsed::ParsedImports>()
            .and_then(|mut p| p.0.remove(&id))
    });
    let mut parsed = match parsed {
        Some(s) => s,
        None => treelight_import::load_scene(file)
            .map(crate::scene::parsed::ParsedScene::from)
            .map_err(|e| EditError::Import(e.to_string()))?,
    };
    // A redone import's root gets its id back.
    let root_id: Vec<SceneId> = root.iter().copied().collect();
    let add_sun = world
        .get_resource::<crate::scene::spawn::DefaultSun>()
        .is_none_or(|d| d.0);
    let top = crate::scene::spawn::spawn_scene_in_world(
        world,
        file,
        &parsed.scene,
        &mut parsed.parts,
        add_sun,
        &root_id,
    )
    .map_err(EditError::Import)?
    .top;
    if top.len() > 1
        && let Some(mut notices) = world.get_resource_mut::<crate::scene::notice::Notices>()
    {
        notices.info(format!(
            "{} has no lights: added a Sun of {} lux (delete it to light the scene by the sky \
             alone)",
            file.display(),
            crate::scene::spawn::DEFAULT_SUN_LUX
        ));
    }
    if let Some(t) = transform {
        world.entity_mut(top[0]).insert(Transform::from(*t));
    }
    let ids: Vec<SceneId> = top
        .iter()
        .filter_map(|e| world.get::<SceneId>(*e).copied())
        .collect();
    *root = ids.first().copied();
    Ok(Undo::Despawn(ids))
}

/// A new light of `kind`.
fn add_light(
    world: &mut World,
    kind: LightKind,
    transform: &TransformValue,
    id: &mut Option<SceneId>,
) -> Undo {
    let new_id = take_id(world, id);
    let mut e = world.spawn((
        Name::new(kind.label()),
        SceneObject,
        new_id,
        Transform::from(*transform),
    ));
    LightValue::new(kind).put_on(&mut e);
    Undo::Despawn(vec![new_id])
}

/// A new group around the objects `ids`, at their centre, under the first one's parent.
fn make_group(
    world: &mut World,
    ids: &[SceneId],
    name: &str,
    group: &mut Option<SceneId>,
) -> Result<Undo, EditError> {
    let roots = top_level(world, ids);
    let entities: Vec<Entity> = roots
        .iter()
        .map(|id| entity(world, *id))
        .collect::<Result<_, _>>()?;
    let parent = world.get::<ChildOf>(entities[0]).map(|c| c.parent());
    let centre = entities
        .iter()
        .map(|e| Vec3::from(world_affine(world, *e).translation))
        .sum::<Vec3>()
        / entities.len() as f32;
    let parent_world = parent.map_or(bevy::math::Affine3A::IDENTITY, |p| world_affine(world, p));
    let group_id = take_id(world, group);
    let mut g = world.spawn((
        Name::new(name.to_owned()),
        SceneObject,
        group_id,
        Transform::from_translation(parent_world.inverse().transform_point3(centre)),
        Visibility::default(),
    ));
    if let Some(p) = parent {
        g.insert(ChildOf(p));
    }
    let g = g.id();
    let mut before = Vec::new();
    for (id, e) in roots.iter().zip(&entities) {
        let old_parent = world
            .get::<ChildOf>(*e)
            .and_then(|c| world.get::<SceneId>(c.parent()).copied());
        let local = world.get::<Transform>(*e).copied().unwrap_or_default();
        before.push((*id, old_parent, local));
        set_parent_keeping_world(world, *e, Some(g));
    }
    Ok(Undo::Many(vec![
        Undo::Despawn(vec![group_id]),
        Undo::Parents(before),
    ]))
}

/// A new built-in shape.
fn add_primitive(
    world: &mut World,
    shape: Primitive,
    transform: &TransformValue,
    id: &mut Option<SceneId>,
) -> Undo {
    let new_id = take_id(world, id);
    let mesh = world.resource_mut::<Assets<Mesh>>().add(shape.mesh());
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(shape.material());
    world.spawn((
        Name::new(shape.label()),
        SceneObject,
        new_id,
        Mesh3d(mesh),
        MeshMaterial3d(material),
        Transform::from(*transform),
        PrimitiveShape(shape),
    ));
    Undo::Despawn(vec![new_id])
}

/// Refuses an id for a new object that another object already has, or that is out of range.
/// Refuses to put `e` (object `id`) and its subtree under something at level `base`, if its
/// deepest object would then pass [`crate::scene::hierarchy::MAX_HIERARCHY_DEPTH`].
fn check_depth(world: &World, id: SceneId, e: Entity, base: usize) -> Result<(), EditError> {
    let deepest = base + crate::scene::hierarchy::height_of(world, e);
    if deepest > crate::scene::hierarchy::MAX_HIERARCHY_DEPTH {
        return Err(EditError::TooDeep(id, deepest));
    }
    Ok(())
}

fn check_free(world: &World, id: Option<SceneId>) -> Result<(), EditError> {
    match id {
        Some(id) if !id.is_valid() => Err(EditError::IdOutOfRange(id)),
        Some(id) if world.resource::<SceneIndex>().entity(id).is_some() => {
            Err(EditError::Taken(id))
        }
        _ => Ok(()),
    }
}

/// The id a command names for what it makes, or a fresh one, kept in the command so a redo makes
/// the same object.
fn take_id(world: &mut World, id: &mut Option<SceneId>) -> SceneId {
    *id.get_or_insert_with(|| world.resource_mut::<SceneIndex>().allocate())
}

/// The material handle of object `id`.
fn material_of(world: &World, id: SceneId) -> Result<Handle<StandardMaterial>, EditError> {
    let e = entity(world, id)?;
    world
        .get::<MeshMaterial3d<StandardMaterial>>(e)
        .map(|m| m.0.clone())
        .ok_or(EditError::NoMaterial(id))
}

fn check_finite(t: &TransformValue) -> Result<(), EditError> {
    if t.is_valid() {
        Ok(())
    } else {
        Err(EditError::NotFinite)
    }
}

/// The world transform of `e` from the local transforms up its chain of parents (not the
/// `GlobalTransform`, which is only brought up to date once a frame).
pub fn world_affine(world: &World, e: Entity) -> bevy::math::Affine3A {
    let mut out = bevy::math::Affine3A::IDENTITY;
    let mut at = Some(e);
    while let Some(x) = at {
        let local = world.get::<Transform>(x).copied().unwrap_or_default();
        out = local.compute_affine() * out;
        at = world.get::<ChildOf>(x).map(|c| c.parent());
    }
    out
}

/// Puts `e` under `parent` (or at the top) with the local transform that keeps its world
/// transform (as far as a transform can: a rotated child of a non-uniformly scaled parent keeps
/// its place and loses the shear).
fn set_parent_keeping_world(world: &mut World, e: Entity, parent: Option<Entity>) {
    let world_of_e = world_affine(world, e);
    let parent_world = parent.map_or(bevy::math::Affine3A::IDENTITY, |p| world_affine(world, p));
    let local = Transform::from_matrix((parent_world.inverse() * world_of_e).into());
    let mut entity = world.entity_mut(e);
    match parent {
        Some(p) => entity.insert(ChildOf(p)),
        None => entity.remove::<ChildOf>(),
    };
    if let Some(mut t) = entity.get_mut::<Transform>() {
        *t = local;
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
            Undo::Transforms(list) => {
                for (id, t) in list {
                    if let Some(e) = find(world, id)
                        && let Some(mut tr) = world.get_mut::<Transform>(e)
                    {
                        *tr = *t;
                    }
                }
            }
            Undo::Parents(list) => {
                for (id, parent, local) in list.iter().rev() {
                    let Some(e) = find(world, id) else { continue };
                    match parent.and_then(|p| find(world, &p)) {
                        Some(p) => world.entity_mut(e).insert(ChildOf(p)),
                        None => world.entity_mut(e).remove::<ChildOf>(),
                    };
                    if let Some(mut tr) = world.get_mut::<Transform>(e) {
                        *tr = *local;
                    }
                }
            }
            Undo::Material(id, value) => {
                if let Ok(handle) = material_of(world, *id)
                    && let Some(m) = world
                        .resource_mut::<Assets<StandardMaterial>>()
                        .get_mut(&handle)
                {
                    value.write(m.into_inner());
                }
            }
            Undo::MaterialHandle(id, handle) => {
                if let Some(e) = find(world, id) {
                    world.entity_mut(e).insert(MeshMaterial3d(handle.clone()));
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
                        crate::scene::hierarchy::despawn_subtree(world, e);
                    }
                }
            }
            Undo::Light(id, light) => {
                if let Some(e) = find(world, id) {
                    light.put_on(&mut world.entity_mut(e));
                }
            }
            Undo::Look(look) => world.insert_resource(*look),
            Undo::Environment(environment) => world.insert_resource(environment.clone()),
            Undo::Many(list) => {
                for undo in list.iter().rev() {
                    undo.revert(world);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_material_value_without_the_newer_fields_leaves_them_as_they_are() {
        // As a version 2 project or an older script writes it.
        let old: MaterialValue = ron::from_str(
            "(base_color: (1.0, 1.0, 1.0, 1.0), metallic: 0.0, perceptual_roughness: 0.5)",
        )
        .unwrap();
        assert!(old.is_valid());
        let mut glass = StandardMaterial {
            specular_transmission: 0.9,
            clearcoat: 0.5,
            alpha_mode: AlphaMode::Blend,
            ..Default::default()
        };
        old.write(&mut glass);
        assert_eq!(glass.specular_transmission, 0.9);
        assert_eq!(glass.clearcoat, 0.5);
        assert_eq!(glass.alpha_mode, AlphaMode::Blend);
        // A full value round-trips through RON and writes every field.
        let mut full = MaterialValue::of(&glass);
        full.transmission = Some(0.25);
        full.alpha = Some(MaterialAlpha::Mask(0.4));
        let back: MaterialValue = ron::from_str(&ron::to_string(&full).unwrap()).unwrap();
        assert_eq!(back, full);
        back.write(&mut glass);
        assert_eq!(glass.specular_transmission, 0.25);
        assert_eq!(glass.alpha_mode, AlphaMode::Mask(0.4));
        assert_eq!(MaterialValue::of(&glass), full);
    }

    #[test]
    fn fractions_outside_zero_to_one_are_refused() {
        let ok = MaterialValue::of(&StandardMaterial::default());
        assert!(ok.is_valid());
        for bad in [
            MaterialValue {
                transmission: Some(1.5),
                ..ok
            },
            MaterialValue {
                clearcoat: Some(f32::NAN),
                ..ok
            },
            MaterialValue {
                alpha: Some(MaterialAlpha::Mask(-0.1)),
                ..ok
            },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }
}
