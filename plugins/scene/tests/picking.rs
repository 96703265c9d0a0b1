//! The `bevy_picking` backend, headless: rays put in the `RayMap` (as the picking plugins do for each
//! pointer and camera) come back as `PointerHits` for the nearest entity the camera may pick, seeing
//! through entities on other render layers and non-hoverable ones.

mod support;

use bevy::camera::visibility::RenderLayers;
use bevy::mesh::Meshable;
use bevy::picking::Pickable;
use bevy::picking::backend::PointerHits;
use bevy::picking::backend::ray::{RayId, RayMap};
use bevy::picking::pointer::PointerId;
use bevy::prelude::*;
use std::time::{Duration, Instant};
use support::headless_app;
use treelight_scene::{SceneBvh, SceneBvhConfig, SceneBvhPickingPlugin};

#[derive(Resource, Default)]
struct Seen(Vec<PointerHits>);

fn collect(mut hits: MessageReader<PointerHits>, mut seen: ResMut<Seen>) {
    seen.0.extend(hits.read().cloned());
}

fn app() -> App {
    let mut app = headless_app(SceneBvhConfig::default());
    app.add_plugins(SceneBvhPickingPlugin)
        .init_resource::<RayMap>()
        .init_resource::<Seen>()
        .add_message::<PointerHits>()
        .add_systems(Update, collect);
    app
}

#[test]
fn pointer_rays_hit_the_nearest_pickable_entity() {
    let mut app = app();
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(1.0, 1.0, 1.0).mesh().build());
    let at = |z: f32| Transform::from_xyz(0.0, 0.0, z);
    // Along the ray from z = 10 towards -z: a cube on another layer, a non-hoverable one, then the
    // one that must be reported, then one behind it.
    let other_layer = app
        .world_mut()
        .spawn((Mesh3d(cube.clone()), at(6.0), RenderLayers::layer(3)))
        .id();
    let not_hoverable = app
        .world_mut()
        .spawn((
            Mesh3d(cube.clone()),
            at(4.0),
            Pickable {
                should_block_lower: true,
                is_hoverable: false,
            },
        ))
        .id();
    let target = app.world_mut().spawn((Mesh3d(cube.clone()), at(2.0))).id();
    let behind = app.world_mut().spawn((Mesh3d(cube), at(0.0))).id();
    let camera = app
        .world_mut()
        .spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 10.0)))
        .id();
    let start = Instant::now();
    // The four cubes share one mesh: its 12 triangles, placed four times.
    while app
        .world()
        .resource::<SceneBvh>()
        .read_blocking()
        .entity_groups
        .len()
        < 4
    {
        app.update();
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "the tree never filled"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    let ray = Ray3d::new(Vec3::new(0.0, 0.0, 10.0), Dir3::NEG_Z);
    let id = RayId::new(camera, PointerId::Mouse);
    app.world_mut().resource_mut::<RayMap>().map.insert(id, ray);
    // A ray that misses everything reports nothing.
    let miss = RayId::new(camera, PointerId::Touch(7));
    app.world_mut()
        .resource_mut::<RayMap>()
        .map
        .insert(miss, Ray3d::new(Vec3::new(5.0, 0.0, 10.0), Dir3::NEG_Z));
    app.world_mut().resource_mut::<Seen>().0.clear();
    app.update();
    let seen = &app.world().resource::<Seen>().0;
    assert_eq!(
        seen.len(),
        1,
        "one report, for the pointer that hit: {seen:?}"
    );
    let report = &seen[0];
    assert_eq!(report.pointer, PointerId::Mouse);
    assert_eq!(report.picks.len(), 1);
    let (entity, data) = &report.picks[0];
    assert_eq!(
        *entity, target,
        "not {other_layer} (other layer), {not_hoverable} (not hoverable) or {behind} (behind)"
    );
    assert_eq!(data.camera, camera);
    // The target's near face is at z = 2.5: 7.5 along the ray.
    assert!((data.depth - 7.5).abs() < 1e-4, "depth {}", data.depth);
    assert!((data.position.unwrap().z - 2.5).abs() < 1e-4);
    assert!(data.normal.unwrap().z > 0.999);
}
