//! What the frame budget costs in throughput: path-traced pixel samples per second through the WGSL
//! kernel when each dispatch traces the whole image, against dispatches of a few tiles each in the
//! plugin's tile order (as a frame under a budget does), at the same resolution and sample count.
//!
//! `cargo run --release -p treelight_render --example trace_budget -- [--resolution 384]
//!  [--sweeps 4] [--parts 16] SCENE...` where SCENE is a file or a generator of `treelight-bench`.

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::Instant;
use support::{Gpu, arg, scene_args, traced_root};
use treelight_bvh::glam::{Affine3A, Mat4, Vec3};
use treelight_bvh::{Bvh, BvhConfig};
use treelight_render::{
    DebugView, MapTransformTable, PATHTRACE_WGSL, SceneLight, ShadingBuffers, SurfaceMaterial,
    TileCursor, TileOrder, TraceWork, ViewParams, attribute_record, light_bytes, object_bytes,
};

fn main() {
    let resolution = arg("--resolution", 384);
    let sweeps = arg("--sweeps", 4).max(1);
    let parts = arg("--parts", 16).max(1);
    let specs = scene_args("give at least one scene (a file, or hairball:N, scatter:N:FILE)");
    let gpu = Gpu::new();
    let pipeline = gpu.pipeline(PATHTRACE_WGSL, "path_trace");
    let layers = gpu.layers(4, 1);
    let order = TileOrder::new(resolution, resolution);
    let per_run = order.total.div_ceil(parts);
    println!(
        "| scene | triangles | whole image, Msamples/s | {parts} runs of {per_run} tiles, Msamples/s | ratio |"
    );
    println!("|---|---|---|---|---|");
    for spec in &specs {
        let scene = treelight_bench::scenes::load(spec, 1).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1);
        });
        let mut bvh = Bvh::new(BvhConfig::incr_u());
        // One group, slot 0: the object record below is its material.
        bvh.insert_group(&scene.triangles, Affine3A::IDENTITY, false)
            .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
        let b = bvh.bounds();
        let diag = (b.max - b.min).length();
        // Grey Lambert everywhere (group 0), a point light above the centre, a blue sky.
        let mut shading = ShadingBuffers::default();
        for id in 0..bvh.triangle_capacity() {
            shading.put(id, &attribute_record(None, None));
        }
        let material = SurfaceMaterial {
            base_color: [0.7, 0.7, 0.7, 1.0],
            perceptual_roughness: 0.8,
            ..Default::default()
        };
        let mut map_transforms = MapTransformTable::default();
        let objects = object_bytes(
            treelight_bvh::glam::Mat3::IDENTITY,
            &material,
            &mut map_transforms,
        );
        let light = SceneLight::Point {
            position: b.center() + Vec3::Y * diag * 0.3,
            power: Vec3::splat(diag * diag * 40.0),
            radius: diag * 0.01,
            range: None,
        };
        let buffers = gpu.scene_buffers(
            &bvh,
            &shading,
            &objects,
            &light_bytes(&light),
            &map_transforms.bytes(),
        );
        let eye = b.center() + Vec3::new(0.35, 0.25, 0.6) * diag * 0.9;
        let view = Mat4::look_at_rh(eye, b.center(), Vec3::Y);
        let proj = Mat4::perspective_infinite_reverse_rh(50f32.to_radians(), 1.0, diag * 1e-3);
        let params = |work| ViewParams {
            world_from_clip: (proj * view).inverse(),
            origin: Vec3::ZERO,
            sky: Vec3::new(0.4, 0.5, 0.7),
            exposure: 1.0,
            width: resolution,
            height: resolution,
            root: traced_root(&bvh),
            max_bounces: 4,
            samples: 1,
            mode: DebugView::PathTraced.shader_index(),
            light_count: 1,
            emitters: (0, 0.0),
            indirect_clamp: 4.0,
            work,
            part_shift: treelight_render::MAX_PART_SHIFT,
            seed: 0,
            environment: bevy::math::Vec4::ZERO,
        };
        let run = |runs: &[u32]| {
            let target = gpu.trace_target(resolution, resolution);
            let mut cursor = TileCursor::default();
            let t = Instant::now();
            for &count in runs {
                let start = cursor.take(&order, count);
                let p = params(TraceWork::Tiles { start, count });
                gpu.path_trace(&pipeline, &buffers, &p, &target, &layers);
            }
            t.elapsed().as_secs_f64()
        };
        let whole: Vec<u32> = vec![order.total; sweeps as usize];
        let mut split = Vec::new();
        for _ in 0..sweeps {
            let mut left = order.total;
            while left > 0 {
                split.push(per_run.min(left));
                left -= per_run.min(left);
            }
        }
        // A warm-up (shader compilation, first touch of the buffers), then alternate the two,
        // keeping each one's best time.
        run(&whole[..1]);
        let (mut t_whole, mut t_split) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..3 {
            t_whole = t_whole.min(run(&whole));
            t_split = t_split.min(run(&split));
        }
        let samples = (resolution * resolution * sweeps) as f64;
        println!(
            "| {} | {} | {:.3} | {:.3} | {:.3} |",
            scene.name,
            scene.triangles.len(),
            samples / t_whole / 1e6,
            samples / t_split / 1e6,
            t_whole / t_split
        );
    }
}
