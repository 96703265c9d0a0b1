//! What the panels and the viewport read of each scene object, with named fields.

use bevy::prelude::*;
use treelight_document::values::light::LightKind;
use treelight_document::values::object::{SceneId, SceneObject};

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
    /// Whether it is a spot light.
    pub spot_light: Has<SpotLight>,
    /// Whether it is a directional light.
    pub directional_light: Has<DirectionalLight>,
    /// Whether it is a camera (a scene file's).
    pub camera: Has<treelight_document::values::camera::SceneCamera>,
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

impl ObjectItemItem<'_, '_> {
    /// The kind of light it is, if it is one.
    pub fn light_kind(&self) -> Option<LightKind> {
        if self.point_light {
            Some(LightKind::Point)
        } else if self.spot_light {
            Some(LightKind::Spot)
        } else if self.directional_light {
            Some(LightKind::Directional)
        } else {
            None
        }
    }
}

/// The glyph the panels and the viewport show for a light.
pub fn light_glyph(kind: LightKind) -> &'static str {
    match kind {
        LightKind::Point => "💡",
        LightKind::Spot => "🔦",
        LightKind::Directional => "☀",
    }
}

/// The glyph the outliner shows for an object: a mesh, a light or an empty.
pub fn kind_of(mesh: bool, light: Option<LightKind>) -> &'static str {
    match (mesh, light) {
        (true, _) => "▣",
        (false, Some(kind)) => light_glyph(kind),
        (false, None) => "•",
    }
}
