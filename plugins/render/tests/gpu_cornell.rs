//! The path-tracing kernel against a CPU reference path tracer written here, on a Cornell box with an
//! emissive panel, a point light (and again with a spot light and a point light of short range), a rough metal box kept whole under a transform, a glowing copy of
//! it that shares its triangles (a second instance with its own material), and an open front
//! to a coloured sky. Both see the same tree, materials and BRDF model; the CPU samples directions
//! differently (cosine-weighted only, finding the glowing surfaces by chance, where the kernel also
//! draws points on them and weighs the two by multiple importance sampling), so agreement checks the
//! kernel's sampling and weights, not just its arithmetic. 32×32 pixels at 512 samples each, unbiased (no indirect clamp).
//!
//! Stated error: per 8×8-pixel block, the mean relative difference of the average radiance is below
//! 4%, no block differs by more than 10%, and the whole image's mean within 2%.

mod support;

use std::collections::HashMap;
use std::f32::consts::PI;
use support::brdf::brdf;
use support::{Gpu, Rng, floats, put_record};
use treelight_bvh::glam::{Affine3A, Mat3, Mat4, Quat, Vec2, Vec3};
use treelight_bvh::{Bvh, GroupId, Ray, Triangle};
use treelight_render::{
    EmitterList, MapTransformTable, OBJECT_BYTES, PATHTRACE_SPLIT_WGSL, PATHTRACE_WGSL, SceneLight,
    ShadingBuffers, SurfaceMaterial, TraceWork, ViewParams, attribute_record, light_bytes,
    object_bytes,
};

const SIZE: u32 = 32;
const SAMPLES: u32 = 512;
const PER_DISPATCH: u32 = 32;
const BOUNCES: u32 = 4;
const SKY: Vec3 = Vec3::new(0.2, 0.25, 0.35);
const POINT: Vec3 = Vec3::new(0.6, 1.6, 0.3);
const POINT_POWER: Vec3 = Vec3::new(4.0 * PI * 0.8, 4.0 * PI * 0.7, 4.0 * PI * 0.6);

fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Vec<Triangle> {
    vec![Triangle::new(a, b, c), Triangle::new(a, c, d)]
}

fn cuboid(half: Vec3) -> Vec<Triangle> {
    let p = |x: f32, y: f32, z: f32| Vec3::new(x * half.x, y * half.y, z * half.z);
    let mut t = Vec::new();
    for s in [-1.0, 1.0] {
        t.extend(quad(
            p(s, -1.0, -1.0),
            p(s, 1.0, -1.0),
            p(s, 1.0, 1.0),
            p(s, -1.0, 1.0),
        ));
        t.extend(quad(
            p(-1.0, s, -1.0),
            p(1.0, s, -1.0),
            p(1.0, s, 1.0),
            p(-1.0, s, 1.0),
        ));
        t.extend(quad(
            p(-1.0, -1.0, s),
            p(1.0, -1.0, s),
            p(1.0, 1.0, s),
            p(-1.0, 1.0, s),
        ));
    }
    t
}

fn lambert(r: f32, g: f32, b: f32) -> SurfaceMaterial {
    SurfaceMaterial {
        base_color: [r, g, b, 1.0],
        perceptual_roughness: 0.9,
        ..Default::default()
    }
}

struct Scene {
    bvh: Bvh,
    materials: HashMap<GroupId, SurfaceMaterial>,
    lights: Vec<SceneLight>,
}

fn cornell() -> Scene {
    let mut bvh = Bvh::default();
    let mut materials = HashMap::new();
    let mut add = |tris: Vec<Triangle>, t: Affine3A, whole: bool, m: SurfaceMaterial| {
        let g = bvh.insert_group(&tris, t, whole).unwrap();
        materials.insert(g, m);
        g
    };
    let (l, h) = (-1.0f32, 1.0f32);
    let v = Vec3::new;
    let white = lambert(0.73, 0.73, 0.73);
    // Floor, ceiling, back wall; the front (+z) is open to the sky.
    add(
        quad(v(l, l, l), v(h, l, l), v(h, l, h), v(l, l, h)),
        Affine3A::IDENTITY,
        false,
        white,
    );
    add(
        quad(v(l, h, l), v(l, h, h), v(h, h, h), v(h, h, l)),
        Affine3A::IDENTITY,
        false,
        white,
    );
    add(
        quad(v(l, l, l), v(l, h, l), v(h, h, l), v(h, l, l)),
        Affine3A::IDENTITY,
        false,
        white,
    );
    add(
        quad(v(l, l, l), v(l, l, h), v(l, h, h), v(l, h, l)),
        Affine3A::IDENTITY,
        false,
        lambert(0.65, 0.05, 0.05),
    );
    add(
        quad(v(h, l, l), v(h, h, l), v(h, h, h), v(h, l, h)),
        Affine3A::IDENTITY,
        false,
        lambert(0.12, 0.45, 0.15),
    );
    // The emissive panel just under the ceiling.
    add(
        quad(
            v(-0.3, 0.98, -0.3),
            v(0.3, 0.98, -0.3),
            v(0.3, 0.98, 0.3),
            v(-0.3, 0.98, 0.3),
        ),
        Affine3A::IDENTITY,
        false,
        SurfaceMaterial {
            base_color: [0.0, 0.0, 0.0, 1.0],
            emissive: [4.0, 3.6, 3.0],
            ..lambert(0.0, 0.0, 0.0)
        },
    );
    // A white box, baked, and a rough metal one kept whole under a rotation and non-uniform scale.
    add(
        cuboid(v(0.3, 0.3, 0.3)),
        Affine3A::from_rotation_translation(Quat::from_rotation_y(0.3), v(0.35, -0.7, 0.2)),
        false,
        white,
    );
    let metal = add(
        cuboid(v(1.0, 1.0, 1.0)),
        Affine3A::from_scale_rotation_translation(
            v(0.3, 0.6, 0.3),
            Quat::from_rotation_y(-0.35),
            v(-0.35, -0.4, -0.3),
        ),
        true,
        SurfaceMaterial {
            base_color: [0.9, 0.75, 0.5, 1.0],
            metallic: 1.0,
            perceptual_roughness: 0.5,
            ..Default::default()
        },
    );
    // A duplicate of the metal box sharing its triangles, matte and glowing blue: its hits must
    // take its own material and normals, not those of the box whose triangles it shares.
    let copy = bvh
        .insert_instance(
            metal,
            Affine3A::from_scale_rotation_translation(
                v(0.2, 0.2, 0.2),
                Quat::from_rotation_y(0.6),
                v(0.55, -0.8, -0.55),
            ),
        )
        .unwrap();
    materials.insert(
        copy,
        SurfaceMaterial {
            emissive: [0.3, 0.5, 1.5],
            ..lambert(0.1, 0.2, 0.8)
        },
    );
    let lights = vec![SceneLight::Point {
        position: POINT,
        power: POINT_POWER,
        radius: 0.0,
        range: None,
    }];
    Scene {
        bvh,
        materials,
        lights,
    }
}

/// The box without its panel, lit by a narrow spot light from above aimed at the floor's left
/// half and a point light with a short range near the right wall: a cone and a range the kernel
/// must cut where the reference does.
fn spot_and_range() -> Scene {
    let mut scene = cornell();
    // No emissive panel: only the two lights and the sky light the box.
    let panel = scene
        .materials
        .iter()
        .find(|(_, m)| m.emissive == [4.0, 3.6, 3.0])
        .map(|(g, _)| *g)
        .unwrap();
    scene.bvh.remove_group(panel).unwrap();
    scene.materials.remove(&panel);
    scene.lights = vec![
        SceneLight::Spot {
            position: Vec3::new(-0.4, 0.95, 0.3),
            direction: Vec3::new(0.1, -1.0, 0.2).normalize(),
            power: Vec3::new(4.0 * PI * 1.5, 4.0 * PI * 1.4, 4.0 * PI * 1.2),
            radius: 0.0,
            range: None,
            inner_angle: 0.25,
            outer_angle: 0.45,
        },
        SceneLight::Point {
            position: Vec3::new(0.8, -0.2, 0.5),
            power: Vec3::new(4.0 * PI * 0.2, 4.0 * PI * 0.3, 4.0 * PI * 0.6),
            radius: 0.0,
            range: Some(0.9),
        },
    ];
    scene
}

fn world_from_clip() -> Mat4 {
    let eye = Vec3::new(0.0, 0.0, 3.4);
    let view = Mat4::look_at_rh(eye, Vec3::ZERO, Vec3::Y);
    let proj = Mat4::perspective_infinite_reverse_rh(40f32.to_radians(), 1.0, 0.1);
    (proj * view).inverse()
}

/// The image the path tracer traces, through the kernel for one binding per kind, or with
/// `split_shift` through the split kernel over records cut into parts of `1 << split_shift`.
fn gpu_image(scene: &Scene) -> Vec<Vec3> {
    gpu_image_through(scene, None)
}

fn gpu_image_through(scene: &Scene, split_shift: Option<u32>) -> Vec<Vec3> {
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
        let rec = object_bytes(
            Mat3::from(bvh.group_transform(g).unwrap().matrix3),
            m,
            &mut map_transforms,
        );
        put_record(&mut objects, g.index(), &rec);
    }
    let mut lights: Vec<u8> = scene.lights.iter().flat_map(light_bytes).collect();
    // The emissive panel and the glowing box follow the lights, sampled directly as the plugin
    // lists them.
    let list = EmitterList::of_groups(
        bvh,
        scene
            .materials
            .iter()
            .map(|(&g, m)| (g, Vec3::from(m.emissive))),
    );
    lights.extend_from_slice(&list.bytes());
    let table = map_transforms.bytes();
    let buffers = gpu.scene_buffers(bvh, &shading, &objects, &lights, &table);
    let split =
        split_shift.map(|s| gpu.split_scene_buffers(bvh, &shading, &objects, &lights, &table, s));
    let target = gpu.trace_target(SIZE, SIZE);
    let pipeline = gpu.pipeline(
        if split.is_some() {
            PATHTRACE_SPLIT_WGSL
        } else {
            PATHTRACE_WGSL
        },
        "path_trace",
    );
    // Untextured: an empty one-layer array fills the binding.
    let layers = gpu.layers(4, 1);
    for _ in 0..SAMPLES / PER_DISPATCH {
        let params = ViewParams {
            world_from_clip: world_from_clip(),
            origin: Vec3::ZERO,
            sky: SKY,
            exposure: 1.0,
            width: SIZE,
            height: SIZE,
            root: support::traced_root(bvh),
            max_bounces: BOUNCES,
            samples: PER_DISPATCH,
            mode: 0,
            light_count: scene.lights.len() as u32,
            emitters: (list.group_count(), list.total()),
            indirect_clamp: 0.0,
            work: TraceWork::WHOLE_IMAGE,
            part_shift: split_shift.unwrap_or(treelight_render::MAX_PART_SHIFT),
            seed: 0,
            environment: treelight_bvh::glam::Vec4::ZERO,
        };
        match &split {
            Some(parts) => gpu.path_trace_split(&pipeline, parts, &params, &target, &layers),
            None => gpu.path_trace(&pipeline, &buffers, &params, &target, &layers),
        }
    }
    floats(&gpu.read(&target.accum))
        .chunks_exact(4)
        .map(|c| Vec3::new(c[0], c[1], c[2]) / SAMPLES as f32)
        .collect()
}

/// The light a point-like light (radius 0) sends to `p`: the direction towards it, its distance
/// and the irradiance on a surface facing it, by KHR_lights_punctual's definitions (intensity in
/// candela is power / 4π; range as the window (1 - (d / range)^4)^2 over inverse square; a spot's
/// cone as saturate((cos θ - cos outer) / (cos inner - cos outer))^2).
fn light_at(light: &SceneLight, p: Vec3) -> Option<(Vec3, f32, Vec3)> {
    let local = |position: Vec3, power: Vec3, range: Option<f32>| {
        let to = position - p;
        let dist = to.length();
        let window = range.map_or(1.0, |r| (1.0 - (dist / r).powi(4)).clamp(0.0, 1.0).powi(2));
        (to / dist, dist, power / (4.0 * PI) / (dist * dist) * window)
    };
    match *light {
        SceneLight::Point {
            position,
            power,
            range,
            ..
        } => Some(local(position, power, range)),
        SceneLight::Spot {
            position,
            direction,
            power,
            range,
            inner_angle,
            outer_angle,
            ..
        } => {
            let (wi, dist, li) = local(position, power, range);
            let (cos_in, cos_out) = (inner_angle.cos(), outer_angle.cos());
            let cone = ((direction.dot(-wi) - cos_out) / (cos_in - cos_out)).clamp(0.0, 1.0);
            Some((wi, dist, li * cone * cone))
        }
        SceneLight::Directional {
            direction,
            illuminance,
        } => Some((-direction, f32::INFINITY, illuminance)),
    }
}

fn cpu_radiance(scene: &Scene, mut o: Vec3, mut d: Vec3, rng: &mut Rng) -> Vec3 {
    let bvh = &scene.bvh;
    let mut throughput = Vec3::ONE;
    let mut radiance = Vec3::ZERO;
    for bounce in 0..=BOUNCES {
        let Some(hit) = bvh.closest_hit(&Ray::new(o, d)) else {
            radiance += throughput * SKY;
            break;
        };
        let tri = bvh.hit_world_triangle(&hit).unwrap();
        let m = &scene.materials[&bvh.hit_group(&hit).unwrap()];
        let p = o + d * hit.t;
        let mut n = tri.normal().normalize();
        if n.dot(d) > 0.0 {
            n = -n;
        }
        radiance += throughput * Vec3::from_array(m.emissive);
        if bounce == BOUNCES {
            break;
        }
        let wo = -d;
        let origin = p + n * 2e-4 * p.abs().max_element().max(1.0);
        for light in &scene.lights {
            let Some((wi, dist, li)) = light_at(light, p) else {
                continue;
            };
            if n.dot(wi) > 0.0
                && bvh
                    .any_hit(&Ray::new(origin, wi).with_range(0.0, dist * 0.999))
                    .is_none()
            {
                radiance += throughput * brdf(m, n, wo, wi) * li * n.dot(wi);
            }
        }
        // Cosine-weighted directions only: brdf * cos / pdf = brdf * π.
        let (u1, u2) = (rng.next(), rng.next());
        let (r, phi) = (u1.sqrt(), 2.0 * PI * u2);
        let local = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt());
        let t = n.any_orthonormal_vector();
        let wi = t * local.x + n.cross(t) * local.y + n * local.z;
        throughput *= brdf(m, n, wo, wi) * PI;
        if bounce >= 2 {
            let q = throughput.max_element().min(0.95);
            if rng.next() >= q {
                break;
            }
            throughput /= q;
        }
        o = origin;
        d = wi;
    }
    radiance
}

fn cpu_image(scene: &Scene) -> Vec<Vec3> {
    let inv = world_from_clip();
    let mut rng = Rng(0x5eed);
    let mut out = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let mut sum = Vec3::ZERO;
            for _ in 0..SAMPLES {
                let uv = (Vec2::new(x as f32, y as f32) + Vec2::new(rng.next(), rng.next()))
                    / SIZE as f32;
                let ndc = Vec2::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
                let near = inv.project_point3(ndc.extend(1.0));
                let mid = inv.project_point3(ndc.extend(0.5));
                sum += cpu_radiance(scene, near, (mid - near).normalize(), &mut rng);
            }
            out.push(sum / SAMPLES as f32);
        }
    }
    out
}

fn blocks(img: &[Vec3]) -> Vec<f32> {
    let mut out = Vec::new();
    for by in (0..SIZE).step_by(8) {
        for bx in (0..SIZE).step_by(8) {
            let mut s = 0.0;
            for y in by..by + 8 {
                for x in bx..bx + 8 {
                    let c = img[(y * SIZE + x) as usize];
                    s += c.x + c.y + c.z;
                }
            }
            out.push(s / 192.0);
        }
    }
    out
}

#[test]
fn path_tracer_matches_a_cpu_reference_on_a_cornell_box() {
    let scene = cornell();
    let gpu = gpu_image(&scene);
    let cpu = cpu_image(&scene);
    let (g, c) = (blocks(&gpu), blocks(&cpu));
    let rel: Vec<f32> = g
        .iter()
        .zip(&c)
        .map(|(a, b)| (a - b).abs() / b.max(1e-3))
        .collect();
    let mean_rel = rel.iter().sum::<f32>() / rel.len() as f32;
    let worst = rel.iter().cloned().fold(0.0, f32::max);
    let (gm, cm) = (
        g.iter().sum::<f32>() / g.len() as f32,
        c.iter().sum::<f32>() / c.len() as f32,
    );
    eprintln!(
        "image mean GPU {gm:.4} CPU {cm:.4}; block error mean {:.2}% worst {:.2}%",
        mean_rel * 100.0,
        worst * 100.0
    );
    assert!(cm > 0.05, "the reference image is nearly black ({cm})");
    assert!((gm - cm).abs() / cm < 0.02, "image means {gm} vs {cm}");
    assert!(mean_rel < 0.04, "mean block error {:.2}%", mean_rel * 100.0);
    assert!(worst < 0.10, "worst block error {:.2}%", worst * 100.0);
}

#[test]
fn the_split_kernel_traces_the_image_of_the_whole_one() {
    let scene = cornell();
    let bvh = &scene.bvh;
    // The smallest parts that hold the box's records in the eight bindings each kind has: every
    // kind lies in several.
    let most = (bvh.inner_capacity() as u64).max(bvh.triangle_capacity() as u64);
    let shift = most.div_ceil(8).next_power_of_two().ilog2();
    assert!(
        most > 2 << shift,
        "{most} records in parts of {}",
        1 << shift
    );
    let whole = gpu_image(&scene);
    let split = gpu_image_through(&scene, Some(shift));
    let worst = whole
        .iter()
        .zip(&split)
        .map(|(a, b)| (*a - *b).abs().max_element() / a.max_element().max(1e-3))
        .fold(0.0, f32::max);
    assert!(worst < 1e-5, "the images differ by up to {worst}");
}

#[test]
fn spot_cones_and_light_ranges_match_the_reference() {
    let scene = spot_and_range();
    let gpu = gpu_image(&scene);
    let cpu = cpu_image(&scene);
    let (g, c) = (blocks(&gpu), blocks(&cpu));
    let (gm, cm) = (
        g.iter().sum::<f32>() / g.len() as f32,
        c.iter().sum::<f32>() / c.len() as f32,
    );
    // Blocks the lights reach: the dim ones (sky light only) carry more noise than signal.
    let lit: Vec<f32> = g
        .iter()
        .zip(&c)
        .filter(|(_, b)| **b > 0.25 * cm)
        .map(|(a, b)| (a - b).abs() / b)
        .collect();
    let mean_rel = lit.iter().sum::<f32>() / lit.len() as f32;
    eprintln!(
        "image mean GPU {gm:.4} CPU {cm:.4}; {} lit blocks, error mean {:.2}%",
        lit.len(),
        mean_rel * 100.0
    );
    assert!((gm - cm).abs() / cm < 0.03, "image means {gm} vs {cm}");
    assert!(mean_rel < 0.06, "mean block error {:.2}%", mean_rel * 100.0);
    // The cone is cut: the brightest block is twice the image's mean and more, as in the reference.
    let (gmax, cmax) = (
        g.iter().cloned().fold(0.0, f32::max),
        c.iter().cloned().fold(0.0, f32::max),
    );
    assert!(
        cmax > 2.0 * cm,
        "the reference shows no spot ({cmax} vs mean {cm})"
    );
    assert!(
        (gmax - cmax).abs() / cmax < 0.1,
        "brightest block {gmax} vs {cmax}"
    );
    // Without their cone and range the same lights give another image.
    let mut open = spot_and_range();
    for l in &mut open.lights {
        match l {
            SceneLight::Spot { outer_angle, .. } => *outer_angle = 1.5,
            SceneLight::Point { range, .. } => *range = None,
            SceneLight::Directional { .. } => {}
        }
    }
    let open_mean = blocks(&gpu_image(&open)).iter().sum::<f32>() / g.len() as f32;
    assert!(
        open_mean > 1.3 * gm,
        "cone and range cut nothing: {open_mean} vs {gm}"
    );
}
