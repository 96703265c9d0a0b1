//! A `bevy_picking` backend over the scene BVH: pointer rays hit what the tree holds, so picking
//! costs a BVH traversal per pointer instead of a test against every mesh.

use crate::world::scene_bvh::SceneBvh;
use bevy::camera::visibility::RenderLayers;
use bevy::picking::Pickable;
use bevy::picking::PickingSystems;
use bevy::picking::backend::ray::RayMap;
use bevy::picking::backend::{HitData, PointerHits};
use bevy::prelude::*;

/// Pointer events through the scene BVH. Add it with `SceneBvhPlugin` and Bevy's picking plugins
/// (`DefaultPickingPlugins`), instead of or beside `MeshPickingPlugin`.
///
/// Each pointer ray reports the nearest entity the ray may hit: one whose [`RenderLayers`] meet the
/// camera's and that is not marked `Pickable { is_hoverable: false, .. }` (those are seen through).
#[derive(Default)]
pub struct SceneBvhPickingPlugin;

impl Plugin for SceneBvhPickingPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(PreUpdate, scene_bvh_hits.in_set(PickingSystems::Backend));
    }
}

fn scene_bvh_hits(
    scene: Res<SceneBvh>,
    ray_map: Res<RayMap>,
    cameras: Query<(&Camera, Option<&RenderLayers>)>,
    layers: Query<&RenderLayers>,
    pickables: Query<&Pickable>,
    mut out: MessageWriter<PointerHits>,
) {
    for (&id, &ray) in ray_map.iter() {
        let Ok((camera, camera_layers)) = cameras.get(id.camera) else {
            continue;
        };
        let camera_layers = camera_layers.cloned().unwrap_or_default();
        let hit = scene.cast_ray_filtered(ray, |e| {
            let entity_layers = layers.get(e).cloned().unwrap_or_default();
            camera_layers.intersects(&entity_layers)
                && pickables.get(e).map_or(true, |p| p.is_hoverable)
        });
        if let Some(hit) = hit {
            let data = HitData::new(id.camera, hit.distance, Some(hit.point), Some(hit.normal));
            out.write(PointerHits::new(
                id.pointer,
                vec![(hit.entity, data)],
                camera.order as f32,
            ));
        }
    }
}
