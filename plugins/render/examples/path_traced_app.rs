//! A plain Bevy app (not the editor) with `SceneBvhPlugin` and `PathTracerPlugin`: a few objects of
//! different materials under a point light and the sun, seen by a path-traced camera. One sphere
//! bobs, so the BVH moves its instance and the accumulation restarts each frame; press Space to
//! pause it and watch the image converge. Tab cycles the debug views.
//!
//! `cargo run --release -p treelight_render --example path_traced_app -- [--frames N] [--screenshot PATH]
//!  [--view raster|path|albedo|normals|triangle-id|heatmap] [--still]`

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use std::path::PathBuf;
use treelight_render::{DebugView, PathTraced, PathTracerPlugin, PathTracerStats};
use treelight_scene::SceneBvhPlugin;

#[derive(Resource)]
struct Options {
    frames: Option<u32>,
    screenshot: Option<PathBuf>,
    view: Option<DebugView>,
    still: bool,
}

#[derive(Component)]
struct Bob;

fn arg(name: &str) -> Option<String> {
    std::env::args().skip_while(|a| a != name).nth(1)
}

fn parse_view(s: &str) -> Option<DebugView> {
    match s {
        "raster" => None,
        "path" => Some(DebugView::PathTraced),
        "albedo" => Some(DebugView::Albedo),
        "normals" => Some(DebugView::Normals),
        "triangle-id" => Some(DebugView::TriangleId),
        "heatmap" => Some(DebugView::Heatmap),
        other => {
            eprintln!(
                "unknown view '{other}': use raster, path, albedo, normals, triangle-id or heatmap"
            );
            std::process::exit(2);
        }
    }
}

fn main() {
    let options = Options {
        frames: arg("--frames").map(|n| n.parse().expect("--frames takes a number")),
        screenshot: arg("--screenshot").map(PathBuf::from),
        view: arg("--view").map_or(Some(DebugView::PathTraced), |v| parse_view(&v)),
        still: std::env::args().any(|a| a == "--still"),
    };
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "Treelight: path-traced Bevy app".into(),
                resolution: bevy::window::WindowResolution::new(640, 480),
                ..default()
            }),
            ..default()
        }))
        .add_plugins((SceneBvhPlugin::default(), PathTracerPlugin))
        .insert_resource(options)
        .add_systems(Startup, setup)
        .add_systems(Update, (bob, keys, report, finish))
        .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    options: Res<Options>,
) {
    let mut material = |base: Color, metallic: f32, roughness: f32, emissive: LinearRgba| {
        materials.add(StandardMaterial {
            base_color: base,
            metallic,
            perceptual_roughness: roughness,
            emissive,
            ..default()
        })
    };
    let ground = material(Color::srgb(0.7, 0.7, 0.68), 0.0, 0.8, LinearRgba::BLACK);
    let red = material(Color::srgb(0.8, 0.1, 0.08), 0.0, 0.6, LinearRgba::BLACK);
    let gold = material(Color::srgb(1.0, 0.78, 0.35), 1.0, 0.25, LinearRgba::BLACK);
    let glow = material(
        Color::BLACK,
        0.0,
        1.0,
        LinearRgba::rgb(1500.0, 1200.0, 800.0),
    );
    let sphere = meshes.add(Sphere::new(1.0).mesh().ico(4).expect("valid subdivisions"));
    commands.spawn((
        Mesh3d(meshes.add(Cuboid::new(12.0, 0.2, 12.0))),
        MeshMaterial3d(ground),
        Transform::from_xyz(0.0, -0.1, 0.0),
    ));
    commands.spawn((
        Mesh3d(sphere.clone()),
        MeshMaterial3d(red),
        Transform::from_xyz(0.0, 1.0, 0.0),
    ));
    commands.spawn((
        Mesh3d(sphere.clone()),
        MeshMaterial3d(gold),
        Transform::from_xyz(2.3, 0.8, -0.6).with_scale(Vec3::splat(0.8)),
        Bob,
    ));
    commands.spawn((
        Mesh3d(meshes.add(Cuboid::new(1.2, 1.2, 1.2))),
        MeshMaterial3d(glow),
        Transform::from_xyz(-2.4, 0.6, -0.8).with_rotation(Quat::from_rotation_y(0.6)),
    ));
    commands.spawn((
        PointLight {
            intensity: 400_000.0,
            radius: 0.2,
            ..default()
        },
        Transform::from_xyz(1.5, 4.0, 2.5),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 3_000.0,
            ..default()
        },
        Transform::from_xyz(-4.0, 8.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let mut camera = commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 3.0, 7.5).looking_at(Vec3::new(0.0, 0.8, 0.0), Vec3::Y),
    ));
    if let Some(view) = options.view {
        // A traced camera draws no meshes: multisampling would only hold a larger target.
        camera.insert((PathTraced { view, ..default() }, Msaa::Off));
    }
}

fn bob(time: Res<Time>, options: Res<Options>, mut q: Query<&mut Transform, With<Bob>>) {
    if options.still {
        return;
    }
    for mut t in &mut q {
        t.translation.y = 0.8 + 0.4 * (time.elapsed_secs() * 1.5).sin().abs();
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut options: ResMut<Options>,
    mut cameras: Query<&mut PathTraced>,
) {
    if input.just_pressed(KeyCode::Space) {
        options.still = !options.still;
    }
    if input.just_pressed(KeyCode::Tab) {
        for mut p in &mut cameras {
            let i = DebugView::ALL
                .iter()
                .position(|&v| v == p.view)
                .unwrap_or(0);
            p.view = DebugView::ALL[(i + 1) % DebugView::ALL.len()];
            info!("view: {}", p.view.label());
        }
    }
}

/// Prints the figures the path tracer reports, once a second.
fn report(
    time: Res<Time>,
    stats: Res<PathTracerStats>,
    cameras: Query<Entity, With<PathTraced>>,
    mut last: Local<f32>,
) {
    if time.elapsed_secs() - *last < 1.0 {
        return;
    }
    *last = time.elapsed_secs();
    let f = stats.figures();
    for e in &cameras {
        println!(
            "samples per pixel: {}; scene upload: {} bytes last, {} in all",
            stats.samples(e),
            f.last_upload_bytes,
            f.total_upload_bytes
        );
    }
}

fn finish(
    mut commands: Commands,
    options: Res<Options>,
    mut frame: Local<u32>,
    mut exit: MessageWriter<AppExit>,
    stats: Res<PathTracerStats>,
    cameras: Query<Entity, With<PathTraced>>,
) {
    // Frames count from the first traced samples: how long the kernels take to compile differs
    // between machines.
    if !cameras.iter().any(|e| stats.samples(e) > 0) {
        return;
    }
    *frame += 1;
    let Some(frames) = options.frames else {
        return;
    };
    if *frame != frames {
        return;
    }
    match options.screenshot.clone() {
        None => {
            println!("exiting after {frames} frames");
            exit.write(AppExit::Success);
        }
        Some(path) => {
            commands.spawn(Screenshot::primary_window()).observe(
                move |captured: On<ScreenshotCaptured>, mut exit: MessageWriter<AppExit>| {
                    let saved = captured
                        .image
                        .clone()
                        .try_into_dynamic()
                        .map_err(|e| e.to_string())
                        .and_then(|image| image.to_rgb8().save(&path).map_err(|e| e.to_string()));
                    match saved {
                        Ok(()) => {
                            println!("screenshot saved to {}", path.display());
                            exit.write(AppExit::Success);
                        }
                        Err(e) => {
                            eprintln!("cannot save the screenshot to {}: {e}", path.display());
                            exit.write(AppExit::error());
                        }
                    }
                },
            );
        }
    }
}
