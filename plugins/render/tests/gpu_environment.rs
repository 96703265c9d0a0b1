//! The panorama sky on the adapter, against independent truths:
//!
//! * Lighting: a floor under a dim sky and a small, very bright sun reflects what the panorama's
//!   light integrates to through the BRDF (a CPU quadrature over the hemisphere, reading the
//!   panorama as the kernel's sampler does). The sun covers a few thousandths of a steradian, so
//!   only sampling it directly gets there at 64 samples a pixel: the image must also be smooth.
//! * Background: camera rays that leave the scene see the panorama in the direction they go,
//!   turned by its rotation; hidden, they see the flat sky colour while the floor stays lit.

mod support;

use std::f32::consts::PI;
use support::Gpu;
use support::brdf::brdf;
use support::scenes::{Scene, Trace, camera, square, trace};
use treelight_bvh::glam::{Affine3A, DVec3, Mat4, Vec2, Vec3, Vec4};
use treelight_render::{
    DebugView, EnvironmentTexels, SurfaceMaterial, environment_uniform, panorama_coordinates,
    panorama_direction,
};

const W: u32 = 256;
const H: u32 = 128;

/// A dim blue sky over a darker ground, and a sun of 2×2 texels 45° up, 60° round from −Z.
fn sun_and_sky() -> EnvironmentTexels {
    EnvironmentTexels::new(W, H, |x, y| {
        if (106..108).contains(&x) && (31..33).contains(&y) {
            [20_000.0, 18_000.0, 15_000.0]
        } else if y < H / 2 {
            [0.3, 0.4, 0.6]
        } else {
            [0.1, 0.08, 0.05]
        }
    })
}

/// The panorama's radiance towards unrotated direction `d`, read as the kernel's sampler reads it:
/// bilinear between texel centres, wrapping around the horizon, holding the poles' rows.
fn radiance(env: &EnvironmentTexels, d: Vec3) -> Vec3 {
    let uv = panorama_coordinates(d);
    let (w, h) = (env.width as i64, env.height as i64);
    let x = uv.x * env.width as f32 - 0.5;
    let y = uv.y * env.height as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let texel = |i: i64, j: i64| {
        let i = i.rem_euclid(w);
        let j = j.clamp(0, h - 1);
        let k = ((j * w + i) * 4) as usize;
        let c = |o: usize| half::f16::from_bits(env.rgba16[k + o]).to_f32() * env.scale;
        Vec3::new(c(0), c(1), c(2))
    };
    let (i, j) = (x0 as i64, y0 as i64);
    let top = texel(i, j).lerp(texel(i + 1, j), fx);
    let bottom = texel(i, j + 1).lerp(texel(i + 1, j + 1), fx);
    top.lerp(bottom, fy)
}

/// A view straight down onto the floor through an orthographic camera: every ray leaves the
/// floor towards +Y.
fn looking_down(size: u32, samples: u32) -> Trace {
    let view = Mat4::look_at_rh(Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, Vec3::NEG_Z);
    // Reversed depth, as Bevy's: the near plane at 1.
    let proj = Mat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 10.0, 0.1);
    Trace {
        size,
        samples,
        bounces: 1,
        sky: Vec3::new(1.0, 0.0, 1.0),
        mode: DebugView::PathTraced.shader_index(),
        world_from_clip: (proj * view).inverse(),
        lights: Vec::new(),
    }
}

fn floor_material() -> SurfaceMaterial {
    SurfaceMaterial {
        base_color: [0.6, 0.6, 0.6, 1.0],
        perceptual_roughness: 0.7,
        ..Default::default()
    }
}

/// A floor far wider than the view, facing up.
fn floor() -> Scene {
    let mut s = Scene::new();
    s.add(
        &square(1000.0),
        Affine3A::from_rotation_x(-PI / 2.0),
        false,
        &floor_material(),
    );
    s
}

/// What the floor sends straight up: the panorama's light over the upper hemisphere through the
/// BRDF, each direction's light times `through` (what lies between the floor and the sky lets
/// through), by the midpoint rule on a grid 16 times finer than the texels.
fn expected_floor_radiance(
    env: &EnvironmentTexels,
    intensity: f32,
    through: impl Fn(Vec3) -> Vec3,
) -> Vec3 {
    let m = floor_material();
    let (nu, nv) = (W * 16, H / 2 * 16);
    let (du, dv) = (1.0 / nu as f32, 0.5 / nv as f32);
    // In f64: millions of terms, the sky's far below a float's step at the sum the sun makes.
    let mut sum = DVec3::ZERO;
    for j in 0..nv {
        let v = (j as f32 + 0.5) * dv;
        let solid = (v * PI).sin() * (PI * dv) * (2.0 * PI * du);
        for i in 0..nu {
            let u = (i as f32 + 0.5) * du;
            let wi = panorama_direction(u, v);
            let f = brdf(&m, Vec3::Y, Vec3::Y, wi) * through(wi);
            sum += (f * radiance(env, wi) * (wi.y * solid)).as_dvec3();
        }
    }
    sum.as_vec3() * intensity
}

/// A clear pane's share of light crossing it at cosine `c`: the base colour's transmitted share of
/// what the dielectric (f0 0.04, Schlick's Fresnel) does not reflect.
fn pane_transmittance(tint: Vec3, c: f32) -> Vec3 {
    tint * (1.0 - (0.04 + 0.96 * (1.0 - c).powi(5)))
}

fn layers_with(
    gpu: &Gpu,
    env: &EnvironmentTexels,
    rotation: f32,
    intensity: f32,
    shown: bool,
) -> support::Layers {
    let mut layers = gpu.layers(4, 1);
    layers.environment = gpu.environment(Some(env));
    layers.environment_word = environment_uniform(Some(env), rotation, intensity, shown);
    layers
}

#[test]
fn a_floor_under_a_small_sun_reflects_the_panorama_s_light_and_is_smooth_at_64_samples() {
    let gpu = Gpu::new();
    let env = sun_and_sky();
    let scene = floor();
    let intensity = 0.5;
    let expected = expected_floor_radiance(&env, intensity, |_| Vec3::ONE);
    for shown in [true, false] {
        let layers = layers_with(&gpu, &env, 0.0, intensity, shown);
        let (image, slots) = trace(&gpu, &scene, &layers, &looking_down(32, 64));
        assert!(slots.iter().all(|&s| s == 0), "every ray meets the floor");
        let n = image.len() as f32;
        let mean = image.iter().copied().sum::<Vec3>() / n;
        let error = ((mean - expected).abs() / expected).max_element();
        assert!(
            error < 0.02,
            "shown {shown}: the floor is {mean}, the panorama's light gives {expected} ({:.2}% off)",
            error * 100.0
        );
        // Pixel to pixel, the noise of 64 samples: small only when the sun is sampled directly.
        let luminance = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let m = luminance(mean);
        let spread = (image
            .iter()
            .map(|c| (luminance(*c) - m).powi(2))
            .sum::<f32>()
            / n)
            .sqrt()
            / m;
        assert!(
            spread < 0.1,
            "shown {shown}: pixels spread {:.1}% about the mean",
            spread * 100.0
        );
    }
}

/// A clear pane (transmission 1, smooth, tinted) over the floor lets the sun and the sky through,
/// tinted and less what it reflects at each angle: shadow rays pass it, and the paths that pass it
/// to the sky are weighed against them, so nothing is counted twice.
#[test]
fn a_floor_under_a_clear_pane_gets_the_panorama_s_light_through_it() {
    let gpu = Gpu::new();
    let env = sun_and_sky();
    let tint = Vec3::new(0.9, 0.6, 0.3);
    let mut scene = floor();
    scene.add(
        &square(1000.0),
        Affine3A::from_translation(Vec3::Y) * Affine3A::from_rotation_x(-PI / 2.0),
        false,
        &SurfaceMaterial {
            base_color: [tint.x, tint.y, tint.z, 1.0],
            perceptual_roughness: 0.0,
            transmission: 1.0,
            ..Default::default()
        },
    );
    let intensity = 0.5;
    let expected = expected_floor_radiance(&env, intensity, |wi| pane_transmittance(tint, wi.y));
    let layers = layers_with(&gpu, &env, 0.0, intensity, true);
    // Looking down from under the pane.
    let view = Mat4::look_at_rh(Vec3::new(0.0, 0.5, 0.0), Vec3::ZERO, Vec3::NEG_Z);
    let proj = Mat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 10.0, 0.1);
    let frame = Trace {
        world_from_clip: (proj * view).inverse(),
        ..looking_down(32, 256)
    };
    let (image, slots) = trace(&gpu, &scene, &layers, &frame);
    assert!(slots.iter().all(|&s| s == 0), "every ray meets the floor");
    let mean = image.iter().copied().sum::<Vec3>() / image.len() as f32;
    let error = ((mean - expected).abs() / expected).max_element();
    eprintln!(
        "under the pane: {mean} against {expected} ({:.2}% off)",
        error * 100.0
    );
    assert!(
        error < 0.03,
        "the floor is {mean}, the panorama's light through the pane gives {expected} ({:.2}% off)",
        error * 100.0
    );
}

/// A panorama whose every texel says where it is: red across, green down (linear, so bilinear
/// reads reproduce it exactly away from the seam behind the camera).
fn coordinates_panorama() -> EnvironmentTexels {
    EnvironmentTexels::new(W, H, |x, y| {
        [
            (x as f32 + 0.5) / W as f32,
            (y as f32 + 0.5) / H as f32,
            0.25,
        ]
    })
}

/// The kernel's camera ray through the centre of pixel (x, y) of a `size`² view.
fn ray_direction(world_from_clip: Mat4, size: u32, x: u32, y: u32) -> Vec3 {
    let uv = Vec2::new(
        (x as f32 + 0.5) / size as f32,
        (y as f32 + 0.5) / size as f32,
    );
    let ndc = Vec2::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    let near = world_from_clip * Vec4::new(ndc.x, ndc.y, 1.0, 1.0);
    let mid = world_from_clip * Vec4::new(ndc.x, ndc.y, 0.5, 1.0);
    let o = near.truncate() / near.w;
    (mid.truncate() / mid.w - o).normalize()
}

#[test]
fn camera_rays_that_leave_the_scene_see_the_panorama_turned_by_its_rotation() {
    let gpu = Gpu::new();
    let env = coordinates_panorama();
    // Nothing in view: a floor far below, out of the frame.
    let mut scene = Scene::new();
    scene.add(
        &square(1.0),
        Affine3A::from_translation(Vec3::new(0.0, -1000.0, 0.0))
            * Affine3A::from_rotation_x(-PI / 2.0),
        false,
        &floor_material(),
    );
    let size = 24;
    let world_from_clip = camera(Vec3::ZERO, Vec3::new(0.0, 0.2, -1.0), Vec3::Y, 60.0);
    let frame = Trace {
        size,
        samples: 16,
        bounces: 2,
        sky: Vec3::new(1.0, 0.0, 1.0),
        mode: DebugView::PathTraced.shader_index(),
        world_from_clip,
        lights: Vec::new(),
    };
    for (rotation, shown) in [(0.0, true), (PI / 2.0, true), (-0.7, true), (0.0, false)] {
        let intensity = 2.0;
        let layers = layers_with(&gpu, &env, rotation, intensity, shown);
        let (image, slots) = trace(&gpu, &scene, &layers, &frame);
        let turn = treelight_bvh::glam::Quat::from_rotation_y(rotation);
        let mut worst = 0.0f32;
        for y in 0..size {
            for x in 0..size {
                let k = (y * size + x) as usize;
                assert_eq!(slots[k], u32::MAX, "pixel ({x}, {y}) meets nothing");
                let d = ray_direction(world_from_clip, size, x, y);
                let expected = if shown {
                    radiance(&env, turn.inverse() * d) * intensity
                } else {
                    frame.sky
                };
                worst = worst.max((image[k] - expected).abs().max_element());
            }
        }
        // Jittered samples over a pixel of a panorama one texel of which spans about a pixel.
        assert!(
            worst < 0.02 * intensity,
            "rotation {rotation}, shown {shown}: a pixel {worst} off the panorama"
        );
    }
}
