//! The built-in default scene: a Cornell-box-like room with a few primitives and lights, built in code
//! so it works from any working directory.

use crate::selection::SceneObject;
use bevy::prelude::*;

/// Inside width, height and depth of the room.
pub const ROOM: f32 = 5.0;

/// Spawns the default scene.
pub fn spawn_default_scene(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let white = materials.add(StandardMaterial {
        base_color: Color::srgb(0.73, 0.73, 0.73),
        perceptual_roughness: 0.9,
        ..default()
    });
    let red = materials.add(StandardMaterial {
        base_color: Color::srgb(0.65, 0.05, 0.05),
        perceptual_roughness: 0.9,
        ..default()
    });
    let green = materials.add(StandardMaterial {
        base_color: Color::srgb(0.12, 0.45, 0.15),
        perceptual_roughness: 0.9,
        ..default()
    });
    let metal = materials.add(StandardMaterial {
        base_color: Color::srgb(0.95, 0.8, 0.5),
        metallic: 1.0,
        perceptual_roughness: 0.25,
        ..default()
    });
    let lamp = materials.add(StandardMaterial {
        base_color: Color::WHITE,
        emissive: LinearRgba::rgb(18.0, 15.0, 11.0),
        ..default()
    });
    let h = ROOM / 2.0;
    let t = 0.1;
    let wall = |size: Vec3| Mesh::from(Cuboid::from_size(size));
    let walls = [
        (
            "Floor",
            wall(Vec3::new(ROOM, t, ROOM)),
            Vec3::new(0.0, -t / 2.0, 0.0),
            white.clone(),
        ),
        (
            "Ceiling",
            wall(Vec3::new(ROOM, t, ROOM)),
            Vec3::new(0.0, ROOM + t / 2.0, 0.0),
            white.clone(),
        ),
        (
            "Back wall",
            wall(Vec3::new(ROOM, ROOM, t)),
            Vec3::new(0.0, h, -h - t / 2.0),
            white.clone(),
        ),
        (
            "Left wall",
            wall(Vec3::new(t, ROOM, ROOM)),
            Vec3::new(-h - t / 2.0, h, 0.0),
            red,
        ),
        (
            "Right wall",
            wall(Vec3::new(t, ROOM, ROOM)),
            Vec3::new(h + t / 2.0, h, 0.0),
            green,
        ),
    ];
    for (name, mesh, pos, mat) in walls {
        commands.spawn((
            Name::new(name),
            SceneObject,
            Mesh3d(meshes.add(mesh)),
            MeshMaterial3d(mat),
            Transform::from_translation(pos),
        ));
    }
    commands.spawn((
        Name::new("Tall box"),
        SceneObject,
        Mesh3d(meshes.add(Cuboid::new(1.4, 3.0, 1.4))),
        MeshMaterial3d(white.clone()),
        Transform::from_xyz(-0.9, 1.5, -0.8).with_rotation(Quat::from_rotation_y(0.35)),
    ));
    commands.spawn((
        Name::new("Short box"),
        SceneObject,
        Mesh3d(meshes.add(Cuboid::new(1.4, 1.4, 1.4))),
        MeshMaterial3d(white),
        Transform::from_xyz(1.0, 0.7, 0.7).with_rotation(Quat::from_rotation_y(-0.3)),
    ));
    commands.spawn((
        Name::new("Sphere"),
        SceneObject,
        Mesh3d(
            meshes.add(
                Sphere::new(0.6)
                    .mesh()
                    .ico(4)
                    .expect("a valid subdivision count"),
            ),
        ),
        MeshMaterial3d(metal),
        Transform::from_xyz(1.0, 2.0, 0.7),
    ));
    commands.spawn((
        Name::new("Ceiling lamp"),
        SceneObject,
        Mesh3d(meshes.add(Cuboid::new(1.2, 0.02, 1.2))),
        MeshMaterial3d(lamp),
        Transform::from_xyz(0.0, ROOM - 0.01, 0.0),
    ));
    commands.spawn((
        Name::new("Lamp light"),
        SceneObject,
        PointLight {
            intensity: 600_000.0,
            range: 20.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(0.0, ROOM - 0.3, 0.0),
    ));
    commands.spawn((
        Name::new("Sun"),
        SceneObject,
        DirectionalLight {
            illuminance: 1_500.0,
            shadow_maps_enabled: false,
            ..default()
        },
        Transform::from_xyz(2.0, 8.0, 6.0).looking_at(Vec3::new(0.0, h, 0.0), Vec3::Y),
    ));
}
