//! Where things the user adds from the menus and the Assets panel go: through the viewport's centre
//! (or the pointer) onto the surface there, by the placement rule.

use bevy::math::Ray3d;
use bevy::prelude::*;
use treelight_document::edit::command::{EditCommand, LightKind};
use treelight_document::scene::placement::{place_transform, surface_under};
use treelight_document::values::primitive::Primitive;
use treelight_scene::SceneBvh;

/// The ray from the viewport's camera through `at` (logical window pixels), or through the
/// viewport's centre for `None`.
pub fn view_ray(camera: &Camera, cam_gt: &GlobalTransform, at: Option<Vec2>) -> Option<Ray3d> {
    let at = match at {
        Some(at) => at,
        None => camera.logical_viewport_rect()?.center(),
    };
    camera.viewport_to_world(cam_gt, at).ok()
}

/// A new `shape` standing where `ray` meets the scene.
pub fn shape_at(scene: &SceneBvh, ray: Ray3d, shape: Primitive) -> EditCommand {
    let surface = surface_under(scene, ray, 5.0);
    let (min, max) = shape.bounds();
    EditCommand::AddPrimitive {
        shape,
        transform: place_transform(surface, min, max, false).into(),
        id: None,
    }
}

/// A new light a little above where `ray` meets the scene; a directional one shines down the way
/// the view (`forward`) looks, a spot light at that point from two units off the surface.
pub fn light_at(scene: &SceneBvh, ray: Ray3d, forward: Vec3, kind: LightKind) -> EditCommand {
    let surface = surface_under(scene, ray, 5.0);
    let at = surface.point + surface.normal * 1.0;
    let down = Vec3::new(forward.x, -1.0, forward.z).normalize();
    let transform = match kind {
        LightKind::Point => Transform::from_translation(at),
        LightKind::Directional => {
            Transform::from_translation(at + Vec3::Y * 2.0).looking_to(down, Vec3::Y)
        }
        LightKind::Spot => Transform::from_translation(surface.point + surface.normal * 2.0)
            .looking_to(-surface.normal, forward),
    };
    EditCommand::AddLight {
        kind,
        transform: transform.into(),
        id: None,
    }
}
