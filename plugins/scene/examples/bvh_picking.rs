//! A plain Bevy app (not the editor) using `SceneBvhPlugin`: a few hundred meshes, some moving every
//! frame, and what the cursor and a scripted ray hit, printed as it changes.
//!
//! `cargo run --release -p treelight_scene --example bvh_picking -- [--frames N]`: with `--frames`, exits after N frames
//! once the scripted ray has hit something (at the latest after 20 N frames, for a slow machine).

use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use treelight_scene::{SceneBvh, SceneBvhPickingPlugin, SceneBvhPlugin};

#[derive(Component)]
struct Spinner(f32);

#[derive(Resource)]
struct ExitAfter(Option<u32>);

/// Whether the scripted ray has hit an object yet.
#[derive(Resource, Default)]
struct ScriptedHit(bool);

fn main() {
    let frames = std::env::args()
        .skip_while(|a| a != "--frames")
        .nth(1)
        .map(|n| n.parse::<u32>().expect("--frames takes a number"));
    App::new()
        // The picking backend turns pointer rays into hits through the same tree, so Bevy's pointer
        // events (`Pointer<Over>`, `Pointer<Click>`, ...) fire on what the BVH finds.
        .add_plugins((
            DefaultPlugins,
            SceneBvhPlugin::default(),
            SceneBvhPickingPlugin,
        ))
        .add_observer(|click: On<Pointer<Click>>, names: Query<&Name>| {
            if let Ok(name) = names.get(click.entity) {
                println!("clicked {name}");
            }
        })
        .insert_resource(ExitAfter(frames))
        .init_resource::<ScriptedHit>()
        .add_systems(Startup, setup)
        .add_systems(Update, (spin, report_hits, exit_after))
        .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let shapes = [
        meshes.add(Cuboid::new(0.8, 0.8, 0.8)),
        meshes.add(Sphere::new(0.5).mesh().ico(3).expect("valid subdivisions")),
        meshes.add(Torus::new(0.25, 0.5)),
    ];
    let material = materials.add(StandardMaterial {
        base_color: Color::srgb(0.8, 0.7, 0.6),
        ..default()
    });
    for i in 0..400 {
        let (x, z) = ((i % 20) as f32 - 9.5, (i / 20) as f32 - 9.5);
        let mut e = commands.spawn((
            Name::new(format!("object {i}")),
            Mesh3d(shapes[i % 3].clone()),
            MeshMaterial3d(material.clone()),
            Transform::from_xyz(x * 1.5, 0.0, z * 1.5),
        ));
        if i % 7 == 0 {
            e.insert(Spinner(i as f32));
        }
    }
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(3.0, 10.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 18.0, 22.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

/// Moves every seventh object each frame: the plugin re-inserts one instance node per move.
fn spin(time: Res<Time>, mut q: Query<(&Spinner, &mut Transform)>) {
    for (s, mut t) in &mut q {
        t.translation.y = (time.elapsed_secs() * 2.0 + s.0).sin();
        t.rotate_y(time.delta_secs());
    }
}

fn report_hits(
    scene: Res<SceneBvh>,
    names: Query<&Name>,
    window: Single<&Window, With<PrimaryWindow>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    mut last: Local<(Option<Entity>, Option<Entity>)>,
    mut hit: ResMut<ScriptedHit>,
) {
    let describe = |e: Option<Entity>| {
        e.and_then(|e| names.get(e).ok())
            .map_or("nothing".to_owned(), |n| n.to_string())
    };
    // A scripted ray straight down through the middle of the grid.
    let scripted = scene
        .cast_ray(Ray3d::new(Vec3::new(0.75, 10.0, 0.75), Dir3::NEG_Y))
        .map(|h| h.entity);
    // A miss is only news once the tree has caught up with the world (while meshes are still
    // arriving, the ray may pass where an object will be); a hit is news at once.
    if scripted != last.0 && (scripted.is_some() || scene.is_idle()) {
        hit.0 |= scripted.is_some();
        println!(
            "scripted ray hits {} (tree version {}, {} triangles)",
            describe(scripted),
            scene.version(),
            scene.stats().triangles
        );
        last.0 = scripted;
    }
    let (cam, cam_t) = *camera;
    let cursor = window
        .cursor_position()
        .and_then(|p| cam.viewport_to_world(cam_t, p).ok());
    let under = cursor.and_then(|ray| scene.cast_ray(ray)).map(|h| h.entity);
    if under != last.1 {
        println!("cursor is over {}", describe(under));
        last.1 = under;
    }
}

fn exit_after(
    mut frames: Local<u32>,
    limit: Res<ExitAfter>,
    hit: Res<ScriptedHit>,
    scene: Res<SceneBvh>,
    mut exit: MessageWriter<AppExit>,
) {
    *frames += 1;
    if let Some(n) = limit.0
        && *frames >= n
        && (hit.0 || *frames >= n.saturating_mul(20))
    {
        let s = scene.stats();
        println!(
            "exiting after {} frames: {} triangles, SAH cost {:.1}, {} pending",
            *frames, s.triangles, s.sah_cost, s.pending
        );
        exit.write(AppExit::Success);
    }
}
