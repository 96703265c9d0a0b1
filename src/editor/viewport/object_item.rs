//! What the panels and the viewport read of each scene object, with named fields.

use bevy::prelude::*;
use treelight_document::object::{SceneId, SceneObject};

/// What the outliner, inspector and viewport read of each scene object.
#[derive(bevy::ecs::query::QueryData)]
pub struct ObjectItem {
    /// The object.
    pub entity: Entity,
    /// Its stable id.
    pub id: &'static SceneId,
    /// Its name.
    pub name: &'static Name,
    /// Its local transform.
    pub transform: &'static Transform,
    /// Its world transform.
    pub global: &'static GlobalTransform,
    /// Its mesh, if it shows one.
    pub mesh: Option<&'static Mesh3d>,
    /// Whether it is a point light.
    pub point_light: Has<PointLight>,
    /// Whether it is a directional light.
    pub directional_light: Has<DirectionalLight>,
    /// Whether it is shown.
    pub visibility: Option<&'static Visibility>,
    /// Its parent.
    pub parent: Option<&'static ChildOf>,
}

/// The scene's objects, as the panels query them.
pub type Objects<'w, 's> = Query<'w, 's, ObjectItem, With<SceneObject>>;

/// `e`'s parent among the scene objects (not the editor's own entities).
pub fn parent_of(objects: &Objects, e: Entity) -> Option<Entity> {
    objects
        .get(e)
        .ok()
        .and_then(|o| o.parent)
        .map(|c| c.parent())
        .filter(|p| objects.contains(*p))
}

/// The glyph the outliner shows for an object: a mesh, a point light, a sun or an empty.
pub fn kind_of(mesh: bool, point: bool, directional: bool) -> &'static str {
    if mesh {
        "▣"
    } else if point {
        "💡"
    } else if directional {
        "☀"
    } else {
        "•"
    }
}
