//! The denoiser's cost per frame: its five passes over a traced image of 1080p's pixel count
//! (1440 × 1440 = 1920 × 1080 pixels), timed from submission to completion, on whatever adapter
//! the machine has. `cargo run -p treelight_render --example denoise_cost` (the dev profile is
//! optimised).

#[path = "../tests/support/mod.rs"]
mod support;

use std::f32::consts::PI;
use std::time::Instant;
use support::Gpu;
use support::scenes::{Scene, Trace, camera, sphere, square, trace_into};
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_render::{DebugView, SceneLight, SurfaceMaterial};

fn main() {
    let gpu = Gpu::new();
    let layers = gpu.layers(4, 1);
    let mut scene = Scene::new();
    scene.add(
        &square(3.0),
        Affine3A::from_rotation_x(-PI / 2.0),
        false,
        &SurfaceMaterial::default(),
    );
    scene.add(
        &sphere(32),
        Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0)),
        false,
        &SurfaceMaterial::default(),
    );
    let frame = Trace {
        size: 1440,
        samples: 1,
        bounces: 2,
        sky: Vec3::new(0.4, 0.5, 0.7),
        mode: DebugView::PathTraced.shader_index(),
        world_from_clip: camera(
            Vec3::new(0.0, 2.0, 4.0),
            Vec3::new(0.0, 0.6, 0.0),
            Vec3::Y,
            45.0,
        ),
        lights: vec![SceneLight::Point {
            position: Vec3::new(1.0, 3.0, 1.5),
            power: Vec3::splat(4.0 * PI * 6.0),
            radius: 0.3,
            range: None,
        }],
    };
    let (_, _, target) = trace_into(&gpu, &scene, &layers, &frame);
    let pipeline = gpu.pipeline(treelight_render::DENOISE_WGSL, "denoise");
    gpu.denoise_with(&pipeline, &target, 1);
    gpu.wait();
    let mut times: Vec<f64> = (0..7)
        .map(|_| {
            let start = Instant::now();
            gpu.denoise_with(&pipeline, &target, 1);
            gpu.wait();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    println!(
        "denoiser, 1440×1440 (1080p's pixels), 5 passes: median {:.1} ms, min {:.1} ms over {} runs",
        times[times.len() / 2],
        times[0],
        times.len()
    );
}
