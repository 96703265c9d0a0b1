//! A Bevy app that is not Treelight: a ring of cubes around a sphere, seen by a path-traced
//! camera, the cursor's ray cast into the same tree. Click a mesh to print its name.
//!
//! `cargo run --release` in this folder (`--frames N` exits after N frames).

use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use treelight_render::{PathTraced, PathTracerPlugin};
use treelight_scene::{SceneBvh, SceneBvhPickingPlugin, SceneBvhPlugin};

fn main() {
    let frames = std::env::args()
        .skip_while(|a| a != "--frames")
        .nth(1)
        .and_then(|n| n.parse::<u32>().ok());
    App::new()
        .add_plugins((
            DefaultPlugins,
            SceneBvhPlugin::default(),
            SceneBvhPickingPlugin,
            PathTracerPlugin,
        ))
        .add_observer(|click: On<Pointer<Click>>, names: Query<&Name>| {
            if let Ok(name) = names.get(click.entity) {
                println!("clicked {name}");
            }
        })
        .add_systems(Startup, setup)
        .add_systems(Update, (hover, move |mut n: Local<u32>, mut exit: MessageWriter<AppExit>| {
            *n += 1;
            if frames.is_some_and(|f| *n >= f) {
                exit.write(AppExit::Success);
            }
        }))
        .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let cube = meshes.add(Cuboid::new(0.6, 0.6, 0.6));
    for i in 0..12 {
        let turn = i as f32 / 12.0 * std::f32::consts::TAU;
        commands.spawn((
            Name::new(format!("cube {i}")),
            Mesh3d(cube.clone()),
            MeshMaterial3d(materials.add(Color::hsl(i as f32 * 30.0, 0.6, 0.5))),
            Transform::from_xyz(turn.cos() * 2.5, 0.3, turn.sin() * 2.5),
        ));
    }
    commands.spawn((
        Name::new("sphere"),
        Mesh3d(meshes.add(Sphere::new(1.0).mesh().ico(4).expect("valid subdivisions"))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::WHITE,
            metallic: 1.0,
            perceptual_roughness: 0.15,
            ..default()
        })),
        Transform::from_xyz(0.0, 1.0, 0.0),
    ));
    commands.spawn((
        Name::new("floor"),
        Mesh3d(meshes.add(Plane3d::default().mesh().size(12.0, 12.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.7, 0.7, 0.7))),
    ));
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(3.0, 6.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        PathTraced::default(),
        Transform::from_xyz(0.0, 3.5, 7.0).looking_at(Vec3::new(0.0, 0.5, 0.0), Vec3::Y),
    ));
}

/// Prints what the cursor's ray hits whenever that changes, through the same tree the camera
/// traces.
fn hover(
    windows: Query<&Window, With<PrimaryWindow>>,
    cameras: Query<(&Camera, &GlobalTransform)>,
    bvh: Res<SceneBvh>,
    names: Query<&Name>,
    mut last: Local<Option<Entity>>,
) {
    let (Ok(window), Ok((camera, at))) = (windows.single(), cameras.single()) else {
        return;
    };
    let Some(ray) = window
        .cursor_position()
        .and_then(|p| camera.viewport_to_world(at, p).ok())
    else {
        return;
    };
    let hit = bvh.cast_ray(ray).map(|h| h.entity);
    if hit != *last {
        *last = hit;
        if let Some(name) = hit.and_then(|e| names.get(e).ok()) {
            println!("over {name}");
        }
    }
}
