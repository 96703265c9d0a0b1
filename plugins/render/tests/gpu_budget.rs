//! The frame budget on the kernel: tracing an image a few tiles at a time, in the plugin's tile order
//! and in uneven runs, gives the image an unbudgeted trace gives (same samples per pixel, at most
//! 1/255 apart per channel, every pixel counted, so no seams between tiles); the preview covers the
//! image; and the depth the resolve writes is the CPU's closest hit projected by the camera.

mod support;

use std::collections::HashMap;
use std::f32::consts::PI;
use support::{Gpu, floats, put_record, skip};
use treelight_bvh::glam::{Affine3A, Mat3, Mat4, Vec2, Vec3, Vec4, Vec4Swizzles};
use treelight_bvh::{Bvh, GroupId, Ray, Triangle};
use treelight_render::{
    ATTRIBUTE_BYTES, DebugView, OBJECT_BYTES, PATHTRACE_WGSL, SceneLight, SurfaceMaterial,
    TileCursor, TileOrder, TraceWork, ViewParams, attribute_bytes, light_bytes, object_bytes,
};

// Not a multiple of the tile size, so edge tiles are partly outside the image.
const WIDTH: u32 = 45;
const HEIGHT: u32 = 29;

fn cuboid(centre: Vec3, half: Vec3) -> Vec<Triangle> {
    let p = |x: f32, y: f32, z: f32| centre + Vec3::new(x, y, z) * half;
    let mut t = Vec::new();
    for s in [-1.0, 1.0] {
        let faces = [
            [
                p(s, -1.0, -1.0),
                p(s, 1.0, -1.0),
                p(s, 1.0, 1.0),
                p(s, -1.0, 1.0),
            ],
            [
                p(-1.0, s, -1.0),
                p(1.0, s, -1.0),
                p(1.0, s, 1.0),
                p(-1.0, s, 1.0),
            ],
            [
                p(-1.0, -1.0, s),
                p(1.0, -1.0, s),
                p(1.0, 1.0, s),
                p(-1.0, 1.0, s),
            ],
        ];
        for [a, b, c, d] in faces {
            t.push(Triangle::new(a, b, c));
            t.push(Triangle::new(a, c, d));
        }
    }
    t
}

struct Scene {
    bvh: Bvh,
    materials: HashMap<GroupId, SurfaceMaterial>,
    lights: Vec<SceneLight>,
}

/// A floor, a tall box and a rough metal cube under a point light, open to the sky.
fn scene() -> Scene {
    let mut bvh = Bvh::default();
    let mut materials = HashMap::new();
    let mut add = |tris: Vec<Triangle>, colour: [f32; 3], metallic: f32| {
        let g = bvh.insert_group(&tris, Affine3A::IDENTITY, false).unwrap();
        let m = SurfaceMaterial {
            base_color: [colour[0], colour[1], colour[2], 1.0],
            metallic,
            perceptual_roughness: 0.5,
            ..Default::default()
        };
        materials.insert(g, m);
    };
    add(
        cuboid(Vec3::new(0.0, -1.05, 0.0), Vec3::new(3.0, 0.05, 3.0)),
        [0.7, 0.7, 0.7],
        0.0,
    );
    add(
        cuboid(Vec3::new(-0.5, -0.2, -0.3), Vec3::new(0.3, 0.8, 0.3)),
        [0.8, 0.3, 0.2],
        0.0,
    );
    add(
        cuboid(Vec3::new(0.6, -0.6, 0.2), Vec3::new(0.4, 0.4, 0.4)),
        [0.9, 0.8, 0.5],
        1.0,
    );
    Scene {
        bvh,
        materials,
        lights: vec![SceneLight::Point {
            position: Vec3::new(0.3, 1.5, 1.0),
            power: Vec3::splat(4.0 * PI * 2.0),
            radius: 0.1,
        }],
    }
}

fn world_from_clip() -> Mat4 {
    let eye = Vec3::new(0.4, 0.8, 3.6);
    let view = Mat4::look_at_rh(eye, Vec3::new(0.0, -0.3, 0.0), Vec3::Y);
    let proj = Mat4::perspective_infinite_reverse_rh(
        45f32.to_radians(),
        WIDTH as f32 / HEIGHT as f32,
        0.1,
    );
    (proj * view).inverse()
}

struct Tracer {
    gpu: Gpu,
    buffers: [wgpu::Buffer; 6],
    pipeline: wgpu::ComputePipeline,
    layers: support::Layers,
    root: u32,
    lights: u32,
}

impl Tracer {
    fn new(scene: &Scene) -> Self {
        let gpu = Gpu::new();
        let bvh = &scene.bvh;
        let mut attrs = vec![0u8; bvh.triangle_capacity() as usize * ATTRIBUTE_BYTES as usize];
        let mut objects = vec![0u8; bvh.group_slots() as usize * OBJECT_BYTES as usize];
        for (&g, m) in &scene.materials {
            for &id in bvh.group_triangles(g).unwrap() {
                put_record(&mut attrs, id, &attribute_bytes(None, None, g.index()));
            }
            put_record(&mut objects, g.index(), &object_bytes(Mat3::IDENTITY, m));
        }
        let lights: Vec<u8> = scene.lights.iter().flat_map(light_bytes).collect();
        Self {
            buffers: gpu.scene_buffers(bvh, &attrs, &objects, &lights),
            pipeline: gpu.pipeline(PATHTRACE_WGSL, "path_trace"),
            layers: gpu.layers(4, 1),
            root: bvh.gpu_root(),
            lights: scene.lights.len() as u32,
            gpu,
        }
    }

    fn params(&self, mode: DebugView, samples: u32, work: TraceWork) -> ViewParams {
        ViewParams {
            world_from_clip: world_from_clip(),
            sky: Vec3::new(0.3, 0.4, 0.6),
            exposure: 1.0,
            width: WIDTH,
            height: HEIGHT,
            root: self.root,
            max_bounces: 3,
            samples,
            mode: mode.shader_index(),
            light_count: self.lights,
            indirect_clamp: 4.0,
            work,
        }
    }

    /// Traces `runs` (samples per pixel per dispatch, tiles) in the plugin's order into fresh
    /// buffers; returns each pixel's (rgb sum, count) and depth.
    fn trace(&self, mode: DebugView, runs: &[(u32, u32)]) -> (Vec<[f32; 4]>, Vec<f32>) {
        let target = self.gpu.trace_target(WIDTH, HEIGHT);
        let order = TileOrder::new(WIDTH, HEIGHT);
        let mut cursor = TileCursor::default();
        for &(samples, count) in runs {
            let start = cursor.take(&order, count);
            let work = TraceWork::Tiles { start, count };
            let params = self.params(mode, samples, work);
            self.gpu.path_trace(
                &self.pipeline,
                &self.buffers,
                &params,
                &target,
                &self.layers,
            );
        }
        let accum = floats(&self.gpu.read(&target.accum))
            .chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect();
        (accum, self.gpu.read_depth(&target))
    }
}

/// Runs of uneven tile counts adding up to exactly `sweeps` sweeps of `total` tiles.
fn uneven_runs(total: u32, sweeps: u32, samples: u32) -> Vec<(u32, u32)> {
    let pattern = [1, 3, 2, 7, 5, 11, 4, 1, 9];
    let mut left = total * sweeps;
    let mut runs = Vec::new();
    for &n in pattern.iter().cycle() {
        if left == 0 {
            break;
        }
        let n = n.min(left);
        runs.push((samples, n));
        left -= n;
    }
    runs
}

/// Largest difference of the averages, per channel (0..1 after a clamp, as a display shows).
fn worst_difference(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| {
            (0..3).map(move |c| (p[c] / p[3]).clamp(0.0, 1.0) - (q[c] / q[3]).clamp(0.0, 1.0))
        })
        .fold(0.0f32, |w, d| w.max(d.abs()))
}

#[test]
fn tiled_accumulation_under_a_budget_gives_the_unbudgeted_image() {
    if skip() {
        return;
    }
    let scene = scene();
    let tracer = Tracer::new(&scene);
    let total = TileOrder::new(WIDTH, HEIGHT).total;
    const SWEEPS: u32 = 6;
    for mode in [DebugView::PathTraced, DebugView::Albedo] {
        let (whole, whole_depth) = tracer.trace(mode, &[(1, total); SWEEPS as usize]);
        assert!(whole.iter().all(|p| p[3] == SWEEPS as f32));
        // A few tiles a frame, in uneven runs, one sample each.
        let (tiled, tiled_depth) = tracer.trace(mode, &uneven_runs(total, SWEEPS, 1));
        // Two samples per pixel per run, as a frame with samples_per_frame = 2 traces.
        let (paired, _) = tracer.trace(mode, &uneven_runs(total, SWEEPS / 2, 2));
        for (name, image) in [("tiled", &tiled), ("two per run", &paired)] {
            let uncounted = image.iter().filter(|p| p[3] != SWEEPS as f32).count();
            assert_eq!(
                uncounted, 0,
                "{mode:?} {name}: pixels without {SWEEPS} samples"
            );
            let worst = worst_difference(&whole, image);
            assert!(worst <= 1.0 / 255.0, "{mode:?} {name}: {worst}");
        }
        assert_eq!(whole_depth, tiled_depth, "{mode:?}");
        // The image is not trivially equal: the path-traced pixels are noisy at 6 samples, and a
        // different sample sequence (a shifted count) would change them.
        if mode == DebugView::PathTraced {
            let (more, _) = tracer.trace(mode, &[(1, total); SWEEPS as usize + 1]);
            assert!(worst_difference(&whole, &more) > 0.05);
        }
    }
}

#[test]
fn depth_is_the_closest_hit_projected_by_the_camera() {
    if skip() {
        return;
    }
    let scene = scene();
    let tracer = Tracer::new(&scene);
    // The triangle-id view samples pixel centres, so the CPU can cast the same rays.
    let (_, depth) = tracer.trace(DebugView::TriangleId, &[(1, u32::MAX)]);
    let wfc = world_from_clip();
    let cfw = wfc.inverse();
    let (mut hits, mut worst) = (0, 0.0f32);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let ndc = Vec2::new(
                (x as f32 + 0.5) / WIDTH as f32 * 2.0 - 1.0,
                1.0 - (y as f32 + 0.5) / HEIGHT as f32 * 2.0,
            );
            let near = wfc.project_point3(ndc.extend(1.0));
            let mid = wfc.project_point3(ndc.extend(0.5));
            let ray = Ray::new(near, (mid - near).normalize());
            let expected = scene.bvh.closest_hit(&ray).map_or(0.0, |h| {
                let c = cfw * (near + ray.dir * h.t).extend(1.0);
                hits += 1;
                (c.z / c.w).clamp(0.0, 1.0)
            });
            let got = depth[(y * WIDTH + x) as usize];
            // Relative: reversed-z depth shrinks with distance.
            worst = worst.max((got - expected).abs() / expected.max(1e-3));
        }
    }
    assert!(hits > (WIDTH * HEIGHT / 2) as usize as u32, "{hits} hits");
    assert!(worst < 1e-3, "worst relative depth error {worst}");
}

#[test]
fn the_preview_covers_the_image_in_blocks() {
    if skip() {
        return;
    }
    let scene = scene();
    let tracer = Tracer::new(&scene);
    for scale in [2, 3, 7] {
        let target = tracer.gpu.trace_target(WIDTH, HEIGHT);
        let work = TraceWork::Preview { scale, seed: 1 };
        let params = tracer.params(DebugView::Normals, 1, work);
        tracer.gpu.path_trace(
            &tracer.pipeline,
            &tracer.buffers,
            &params,
            &target,
            &tracer.layers,
        );
        let preview = tracer.gpu.read_preview(&target);
        let (pw, ph) = (WIDTH.div_ceil(scale), HEIGHT.div_ceil(scale));
        // Normals map to 0..1 per channel; the sky to black: every block was written with a
        // value in range, and most show a surface.
        let blocks: Vec<_> = preview
            .chunks_exact(4)
            .take((pw * ph) as usize)
            .map(Vec4::from_slice)
            .collect();
        let lit = blocks.iter().filter(|b| b.xyz().length() > 0.1).count();
        assert!(
            blocks
                .iter()
                .all(|b| b.is_finite() && b.xyz().min_element() >= 0.0 && b.w >= 0.0),
            "scale {scale}"
        );
        assert!(
            lit * 2 > blocks.len(),
            "scale {scale}: {lit} of {}",
            blocks.len()
        );
    }
}
