//! Rays cast on the published tree: the entity hit and where.

use crate::types::tree::SceneTree;
use bevy::math::Ray3d;
use bevy::prelude::*;
use treelight_bvh::{Hit, Ray};

/// A ray hit on the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// The entity hit.
    pub entity: Entity,
    /// The triangle hit (the tree's id).
    pub triangle: u32,
    /// Distance along the ray (the ray's direction is unit length).
    pub distance: f32,
    /// World-space hit point.
    pub point: Vec3,
    /// Unit geometric normal, facing the ray.
    pub normal: Vec3,
}

/// Closest hit on a tree, with entity and world-space geometry.
pub fn cast_on(tree: &SceneTree, ray: Ray3d) -> Option<SceneHit> {
    let hit = tree
        .bvh
        .closest_hit(&Ray::new(ray.origin, Vec3::from(ray.direction)))?;
    scene_hit(tree, ray, hit)
}

/// Closest hit on a tree on an entity that `accept` takes; the others are seen through, however
/// close to an accepted surface they lie (an object resting on a floor, say).
pub fn cast_on_filtered(
    tree: &SceneTree,
    ray: Ray3d,
    mut accept: impl FnMut(Entity) -> bool,
) -> Option<SceneHit> {
    let hit = tree
        .bvh
        .closest_hit_where(&Ray::new(ray.origin, Vec3::from(ray.direction)), |h| {
            tree.entity_of_hit(h).is_some_and(&mut accept)
        })?;
    scene_hit(tree, ray, hit)
}

fn scene_hit(tree: &SceneTree, ray: Ray3d, hit: Hit) -> Option<SceneHit> {
    let dir = Vec3::from(ray.direction);
    let entity = tree.entity_of_hit(&hit)?;
    let tri = tree.bvh.hit_world_triangle(&hit)?;
    let n = tri.normal().normalize_or_zero();
    Some(SceneHit {
        entity,
        triangle: hit.triangle,
        distance: hit.t,
        point: ray.origin + dir * hit.t,
        normal: if n.dot(dir) > 0.0 { -n } else { n },
    })
}
