//! The frame budget on the kernel: tracing an image a few tiles at a time, in the plugin's tile order
//! and in uneven runs, gives the image an unbudgeted trace gives (same samples per pixel, at most
//! 1/255 apart per channel, every pixel counted, so no seams between tiles); the preview covers the
//! image; the depth the resolve writes is the CPU's closest hit projected by the camera; each pixel
//! and preview block records the object its primary ray hits, and the resolve outlines exactly the
//! marked objects' silhouettes from those records.

mod support;

use std::collections::HashMap;
use std::f32::consts::PI;
use support::{Gpu, TraceTarget, floats, put_record};
use treelight_bvh::glam::{Affine3A, Mat3, Mat4, Vec2, Vec3, Vec4, Vec4Swizzles};
use treelight_bvh::{Bvh, GroupId, Ray, Triangle};
use treelight_render::{
    DebugView, MapTransformTable, OBJECT_BYTES, OutlineStyle, PATHTRACE_WGSL, ResolveParams,
    SceneLight, ShadingBuffers, SurfaceMaterial, TileCursor, TileOrder, TraceWork, ViewParams,
    attribute_record, light_bytes, object_bytes, outline_words, set_outline,
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
            range: None,
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
    buffers: [wgpu::Buffer; 9],
    pipeline: wgpu::ComputePipeline,
    layers: support::Layers,
    root: u32,
    lights: u32,
}

impl Tracer {
    fn new(scene: &Scene) -> Self {
        let gpu = Gpu::new();
        let bvh = &scene.bvh;
        let mut shading = ShadingBuffers::default();
        shading.reserve_triangles(bvh.triangle_capacity());
        let mut objects = vec![0u8; bvh.group_slots() as usize * OBJECT_BYTES as usize];
        let mut map_transforms = MapTransformTable::default();
        for (&g, m) in &scene.materials {
            for id in bvh.group_triangles(g).unwrap() {
                shading.put(id, &attribute_record(None, None));
            }
            put_record(
                &mut objects,
                g.index(),
                &object_bytes(Mat3::IDENTITY, m, &mut map_transforms),
            );
        }
        let lights: Vec<u8> = scene.lights.iter().flat_map(light_bytes).collect();
        Self {
            buffers: gpu.scene_buffers(bvh, &shading, &objects, &lights, &map_transforms.bytes()),
            pipeline: gpu.pipeline(PATHTRACE_WGSL, "path_trace"),
            layers: gpu.layers(4, 1),
            root: support::traced_root(bvh),
            lights: scene.lights.len() as u32,
            gpu,
        }
    }

    fn params(&self, mode: DebugView, samples: u32, work: TraceWork) -> ViewParams {
        ViewParams {
            world_from_clip: world_from_clip(),
            origin: Vec3::ZERO,
            sky: Vec3::new(0.3, 0.4, 0.6),
            exposure: 1.0,
            width: WIDTH,
            height: HEIGHT,
            root: self.root,
            max_bounces: 3,
            samples,
            mode: mode.shader_index(),
            light_count: self.lights,
            emitters: (0, 0.0),
            indirect_clamp: 4.0,
            work,
            part_shift: treelight_render::MAX_PART_SHIFT,
            seed: 0,
            environment: treelight_bvh::glam::Vec4::ZERO,
        }
    }

    /// One dispatch of `work` in `mode`, `samples` per pixel, into `target`.
    fn dispatch(&self, mode: DebugView, samples: u32, work: TraceWork, target: &TraceTarget) {
        let params = self.params(mode, samples, work);
        self.gpu
            .path_trace(&self.pipeline, &self.buffers, &params, target, &self.layers);
    }

    /// `work` in `mode`, one sample per pixel, into fresh buffers.
    fn fresh(&self, mode: DebugView, work: TraceWork) -> TraceTarget {
        let target = self.gpu.trace_target(WIDTH, HEIGHT);
        self.dispatch(mode, 1, work, &target);
        target
    }

    /// Traces `runs` (samples per pixel per dispatch, tiles) in the plugin's order into fresh
    /// buffers; returns each pixel's (rgb sum, count) and depth.
    fn trace(&self, mode: DebugView, runs: &[(u32, u32)]) -> (Vec<[f32; 4]>, Vec<f32>) {
        let target = self.gpu.trace_target(WIDTH, HEIGHT);
        let order = TileOrder::new(WIDTH, HEIGHT);
        let mut cursor = TileCursor::default();
        for &(samples, count) in runs {
            let start = cursor.take(&order, count);
            self.dispatch(mode, samples, TraceWork::Tiles { start, count }, &target);
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
    let scene = scene();
    let tracer = Tracer::new(&scene);
    for scale in [2, 3, 7] {
        let target = tracer.fresh(DebugView::Normals, TraceWork::Preview { scale, seed: 1 });
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

/// Every tile of the image in one dispatch.
fn whole_image() -> TraceWork {
    TraceWork::Tiles {
        start: 0,
        count: TileOrder::new(WIDTH, HEIGHT).total,
    }
}

/// Where a non-jittered view's preview casts block (`bx`, `by`)'s one ray, at `scale` pixels a
/// block: the centre of the block's part inside the image.
fn block_centre(bx: u32, by: u32, scale: u32) -> Vec2 {
    let lo = Vec2::new((bx * scale) as f32, (by * scale) as f32);
    let hi = Vec2::new(
        ((bx + 1) * scale).min(WIDTH) as f32,
        ((by + 1) * scale).min(HEIGHT) as f32,
    );
    (lo + hi) * 0.5
}

/// The ray the kernel casts through image point `at` (pixels, continuous).
fn camera_ray(at: Vec2) -> Ray {
    let wfc = world_from_clip();
    let ndc = Vec2::new(
        at.x / WIDTH as f32 * 2.0 - 1.0,
        1.0 - at.y / HEIGHT as f32 * 2.0,
    );
    let near = wfc.project_point3(ndc.extend(1.0));
    let mid = wfc.project_point3(ndc.extend(0.5));
    Ray::new(near, (mid - near).normalize())
}

/// The usual scene plus a copy of the tall box sharing its triangles (an instance, so the kernel
/// must name the instance's group, not the triangles' owner); also the tall box's and the copy's
/// groups.
fn scene_with_a_copy() -> (Scene, GroupId, GroupId) {
    let mut scene = scene();
    let tall = *scene
        .materials
        .iter()
        .find(|(_, m)| m.base_color[0] == 0.8)
        .unwrap()
        .0;
    let copy = scene
        .bvh
        .insert_instance(tall, Affine3A::from_translation(Vec3::new(1.3, 0.0, -0.6)))
        .unwrap();
    scene.materials.insert(copy, scene.materials[&tall]);
    (scene, tall, copy)
}

/// The group slot the CPU's closest hit through image point `at` names (`u32::MAX`: none).
fn cpu_object(scene: &Scene, at: Vec2) -> u32 {
    scene
        .bvh
        .closest_hit(&camera_ray(at))
        .map_or(u32::MAX, |h| scene.bvh.hit_group(&h).unwrap().index())
}

#[test]
fn each_pixel_and_preview_block_records_the_object_its_primary_ray_hits() {
    let (scene, tall, copy) = scene_with_a_copy();
    let tracer = Tracer::new(&scene);
    let expected = |at: Vec2| cpu_object(&scene, at);

    // Whole pixels: the triangle-id view casts through pixel centres.
    let target = tracer.fresh(DebugView::TriangleId, whole_image());
    let objects = tracer.gpu.read_objects(&target);
    let mut seen = std::collections::HashSet::new();
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let want = expected(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            assert_eq!(objects[(y * WIDTH + x) as usize], want, "pixel ({x}, {y})");
            seen.insert(want);
        }
    }
    assert!(
        seen.contains(&copy.index()) && seen.contains(&tall.index()) && seen.contains(&u32::MAX),
        "the view shows the box, its copy and the sky: {seen:?}"
    );

    // Preview blocks: one ray through each block's centre.
    for scale in [2, 3] {
        let target = tracer.fresh(DebugView::TriangleId, TraceWork::Preview { scale, seed: 1 });
        let blocks = tracer.gpu.read_preview_objects(&target);
        let (pw, ph) = (WIDTH.div_ceil(scale), HEIGHT.div_ceil(scale));
        for by in 0..ph {
            for bx in 0..pw {
                assert_eq!(
                    blocks[(by * pw + bx) as usize],
                    expected(block_centre(bx, by, scale)),
                    "scale {scale}, block ({bx}, {by})"
                );
            }
        }
    }
}

/// What the resolve should draw at each pixel, from the CPU's objects per pixel: 0 no outline, else
/// the strongest outline value within `width` pixels, where the pixel itself shows no outlined
/// object.
fn expected_outline(objects: &[u32], value: impl Fn(u32) -> u32, width: f32) -> Vec<u32> {
    let at = |x: i32, y: i32| value(objects[(y as u32 * WIDTH + x as u32) as usize]);
    let r = width.ceil() as i32;
    let mut out = vec![0; objects.len()];
    for y in 0..HEIGHT as i32 {
        for x in 0..WIDTH as i32 {
            if at(x, y) != 0 {
                continue;
            }
            let mut best = 0;
            for dy in -r..=r {
                for dx in -r..=r {
                    let (nx, ny) = (x + dx, y + dy);
                    let inside =
                        (0..WIDTH as i32).contains(&nx) && (0..HEIGHT as i32).contains(&ny);
                    if inside && ((dx * dx + dy * dy) as f32) <= width * width + 0.25 {
                        best = best.max(at(nx, ny));
                    }
                }
            }
            out[(y as u32 * WIDTH + x as u32) as usize] = best;
        }
    }
    out
}

#[test]
fn the_resolve_outlines_exactly_the_marked_objects_silhouettes() {
    let (scene, tall, copy) = scene_with_a_copy();
    let tracer = Tracer::new(&scene);
    // The tall box selected, its copy the active object, the rest not outlined.
    let mut words = vec![0u32; outline_words(scene.bvh.group_slots() as usize)];
    set_outline(&mut words, tall.index(), 1);
    set_outline(&mut words, copy.index(), 2);
    let value = |slot: u32| {
        if slot == tall.index() {
            1
        } else if slot == copy.index() {
            2
        } else {
            0
        }
    };
    // Colours no id colour can take, so every pixel says which it is.
    let style = OutlineStyle {
        selected: bevy::color::LinearRgba::rgb(10.0, 20.0, 30.0),
        active: bevy::color::LinearRgba::rgb(40.0, 50.0, 60.0),
        width: 2.0,
    };
    let drawn = |image: &[[f32; 4]]| -> Vec<u32> {
        image
            .iter()
            .map(|p| match p[0] {
                10.0 => 1,
                40.0 => 2,
                _ => 0,
            })
            .collect()
    };
    let params = |preview_scale: u32| ResolveParams {
        origin: Vec2::ZERO,
        viewport: Vec2::new(WIDTH as f32, HEIGHT as f32),
        size: [WIDTH, HEIGHT],
        preview_scale,
        outline_slots: scene.bvh.group_slots(),
        outline: style,
        outline_rect: [Vec2::ZERO, Vec2::new(WIDTH as f32, HEIGHT as f32)],
        denoised: false,
        temporal: false,
    };

    // Every pixel traced (pixel centres, as the triangle-id view casts them).
    let target = tracer.fresh(DebugView::TriangleId, whole_image());
    let objects: Vec<u32> = (0..WIDTH * HEIGHT)
        .map(|i| {
            cpu_object(
                &scene,
                Vec2::new((i % WIDTH) as f32 + 0.5, (i / WIDTH) as f32 + 0.5),
            )
        })
        .collect();
    let want = expected_outline(&objects, value, style.width);
    let got = drawn(
        &tracer
            .gpu
            .resolve(&target, (WIDTH, HEIGHT), &params(0), &words),
    );
    assert!(
        want.iter().filter(|&&v| v == 1).count() > 10
            && want.iter().filter(|&&v| v == 2).count() > 10,
        "both objects are in sight"
    );
    assert_eq!(got, want, "outlines over traced pixels");

    // Outside the rectangle the prepare pass projects the outlined objects' bounds to, nothing is
    // searched or drawn; inside it, the same lines.
    let half = WIDTH as f32 / 2.0;
    let clipped = ResolveParams {
        outline_rect: [Vec2::new(half, 0.0), Vec2::new(WIDTH as f32, HEIGHT as f32)],
        ..params(0)
    };
    let got = drawn(
        &tracer
            .gpu
            .resolve(&target, (WIDTH, HEIGHT), &clipped, &words),
    );
    for (i, (&g, &w)) in got.iter().zip(&want).enumerate() {
        let inside = (i as u32 % WIDTH) as f32 + 0.5 >= half;
        assert_eq!(
            g,
            if inside { w } else { 0 },
            "pixel {i} with the rectangle"
        );
    }

    // Nothing marked: nothing drawn, though the slots are covered.
    let none = vec![0u32; words.len()];
    let got = drawn(
        &tracer
            .gpu
            .resolve(&target, (WIDTH, HEIGHT), &params(0), &none),
    );
    assert!(got.iter().all(|&v| v == 0), "no outline without marks");

    // Only the preview traced (as right after the camera or an object moved): the outline follows
    // the preview blocks' objects, so it is complete in that frame too.
    let scale = 3;
    let target = tracer.fresh(DebugView::TriangleId, TraceWork::Preview { scale, seed: 1 });
    let objects: Vec<u32> = (0..WIDTH * HEIGHT)
        .map(|i| {
            let (bx, by) = ((i % WIDTH) / scale, (i / WIDTH) / scale);
            cpu_object(&scene, block_centre(bx, by, scale))
        })
        .collect();
    let want = expected_outline(&objects, value, style.width);
    let got = drawn(
        &tracer
            .gpu
            .resolve(&target, (WIDTH, HEIGHT), &params(scale), &words),
    );
    assert!(want.iter().any(|&v| v != 0), "outlined in the preview");
    assert_eq!(got, want, "outlines over the preview");
}
