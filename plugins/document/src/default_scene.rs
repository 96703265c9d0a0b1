//! The built-in default scene: a Cornell-box-like room with a few primitives and lights, built in code
//! so it works from any working directory.

use crate::values::object::SceneObject;
use crate::values::primitive::Primitive;
use crate::values::primitive::PrimitiveShape;
use bevy::prelude::*;

/// The default scene as a project, embedded so the editor opens it from any working directory.
/// `assets/default.treelight` is written from [`spawn_default_scene`] (see `tests/default_scene.rs`).
pub const DEFAULT_PROJECT: &str = include_str!("../../../assets/default.treelight");

/// Opens the embedded default scene as an untitled, unsaved-free scene.
pub fn open_default_scene(world: &mut World) {
    let name = std::path::Path::new("default.treelight");
    let opened = crate::project::format::read_project_str(DEFAULT_PROJECT, name)
        .and_then(|p| crate::project::restore::open_project_value(world, p, name));
    if let Err(e) = opened {
        // Only a broken build can get here; the scene the file was made from is still at hand.
        error!("the embedded default scene: {e}");
        let _ = world.run_system_cached(spawn_default_scene);
    }
    world
        .resource_mut::<crate::project::format::ProjectState>()
        .path = None;
    world
        .resource_mut::<crate::edit::history::EditHistory>()
        .mark_saved();
}

/// Inside width, height and depth of the room.
pub const ROOM: f32 = 5.0;

/// Spawns the default scene from code: what `assets/default.treelight` is made from.
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
    // Built from the Add menu's unit shapes, scaled, so the scene saves as a project like any other.
    let cube = meshes.add(Primitive::Cube.mesh());
    let shaped = |name: &str,
                  shape: Primitive,
                  mesh: &Handle<Mesh>,
                  material: &Handle<StandardMaterial>,
                  transform: Transform| {
        (
            Name::new(name.to_owned()),
            SceneObject,
            Mesh3d(mesh.clone()),
            MeshMaterial3d(material.clone()),
            transform,
            PrimitiveShape(shape),
        )
    };
    let slab = |pos: Vec3, size: Vec3| Transform::from_translation(pos).with_scale(size);
    commands.spawn(shaped(
        "Floor",
        Primitive::Cube,
        &cube,
        &white,
        slab(Vec3::new(0.0, -t / 2.0, 0.0), Vec3::new(ROOM, t, ROOM)),
    ));
    commands.spawn(shaped(
        "Ceiling",
        Primitive::Cube,
        &cube,
        &white,
        slab(
            Vec3::new(0.0, ROOM + t / 2.0, 0.0),
            Vec3::new(ROOM, t, ROOM),
        ),
    ));
    commands.spawn(shaped(
        "Back wall",
        Primitive::Cube,
        &cube,
        &white,
        slab(Vec3::new(0.0, h, -h - t / 2.0), Vec3::new(ROOM, ROOM, t)),
    ));
    commands.spawn(shaped(
        "Left wall",
        Primitive::Cube,
        &cube,
        &red,
        slab(Vec3::new(-h - t / 2.0, h, 0.0), Vec3::new(t, ROOM, ROOM)),
    ));
    commands.spawn(shaped(
        "Right wall",
        Primitive::Cube,
        &cube,
        &green,
        slab(Vec3::new(h + t / 2.0, h, 0.0), Vec3::new(t, ROOM, ROOM)),
    ));
    commands.spawn(shaped(
        "Tall box",
        Primitive::Cube,
        &cube,
        &white,
        Transform::from_xyz(-0.9, 1.5, -0.8)
            .with_rotation(Quat::from_rotation_y(0.35))
            .with_scale(Vec3::new(1.4, 3.0, 1.4)),
    ));
    commands.spawn(shaped(
        "Short box",
        Primitive::Cube,
        &cube,
        &white,
        Transform::from_xyz(1.0, 0.7, 0.7)
            .with_rotation(Quat::from_rotation_y(-0.3))
            .with_scale(Vec3::splat(1.4)),
    ));
    commands.spawn(shaped(
        "Sphere",
        Primitive::Sphere,
        &meshes.add(Primitive::Sphere.mesh()),
        &metal,
        Transform::from_xyz(1.0, 2.0, 0.7).with_scale(Vec3::splat(1.2)),
    ));
    commands.spawn(shaped(
        "Ceiling lamp",
        Primitive::Cube,
        &cube,
        &lamp,
        slab(Vec3::new(0.0, ROOM - 0.01, 0.0), Vec3::new(1.2, 0.02, 1.2)),
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
