//! Light as the scene means it, on the adapter:
//!
//! * The indirect cap never touches direct light: a glowing floor under a sky, a point light and a
//!   sun, with nothing a path can reflect off twice, traces the same image with a cap far below
//!   every sample as without one; beside a white wall (light reflected twice) the same cap dims it.
//! * The exposure changes no radiance: the same paths at exposures 0 and +6 stops, with the
//!   default cap set low enough to bite, give the same radiance everywhere, highlights included.
//! * Emissive surfaces are lights: sampling the emissive triangles directly (weighed against the
//!   BSDF's samples) changes no expected value, in a room lit by a glowing panel and a glowing
//!   copy of a ball that shares its triangles (an instance); and the panel lights
//!   the room with noise comparable to a point light of the same power, where the BSDF's samples
//!   alone are several times noisier.

mod support;

use std::f32::consts::PI;
use support::Gpu;
use support::scenes::{Frames, Scene, Shot, Trace, camera, mean_image, spheres_on_a_floor};
use support::scenes::{lit_frame, square};
use treelight_bvh::glam::{Affine3A, Quat, Vec3};
use treelight_render::{DebugView, SceneLight, SurfaceMaterial, TraceWork};

fn rough(r: f32, g: f32, b: f32) -> SurfaceMaterial {
    SurfaceMaterial {
        base_color: [r, g, b, 1.0],
        perceptual_roughness: 0.8,
        ..Default::default()
    }
}

/// A glowing floor facing up at y = 0 (its own light is seen directly) and, with `wall`, a white
/// wall standing at x = 1 facing the floor's centre. Lit by [`floor_frame`]'s lights and sky, the
/// floor alone reflects every light once at most: a path that leaves it meets only the sky.
fn glowing_floor(wall: bool) -> Scene {
    let mut s = Scene::new();
    s.add(
        &square(2.0),
        Affine3A::from_rotation_x(-PI / 2.0),
        false,
        &SurfaceMaterial {
            emissive: [0.3, 0.2, 0.1],
            ..rough(0.7, 0.7, 0.7)
        },
    );
    if wall {
        s.add(
            &square(2.0),
            Affine3A::from_rotation_translation(
                Quat::from_rotation_y(-PI / 2.0),
                Vec3::new(1.0, 0.0, 0.0),
            ),
            false,
            &rough(0.9, 0.9, 0.9),
        );
    }
    s
}

/// A view of [`glowing_floor`] under a blue sky, a point light close to the floor and a sun.
fn floor_frame() -> Trace {
    Trace {
        size: 32,
        samples: 32,
        bounces: 16,
        sky: Vec3::new(0.2, 0.3, 0.5),
        mode: DebugView::PathTraced.shader_index(),
        world_from_clip: camera(Vec3::new(-0.5, 2.5, 2.0), Vec3::ZERO, Vec3::Y, 50.0),
        lights: vec![
            SceneLight::Point {
                position: Vec3::new(-0.6, 0.8, 0.3),
                power: Vec3::splat(4.0 * PI * 20.0),
                radius: 0.05,
                range: None,
            },
            SceneLight::Directional {
                direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
                illuminance: Vec3::splat(3.0),
            },
        ],
    }
}

fn image(gpu: &Gpu, scene: &Scene, t: &Trace, shot: Shot) -> Vec<Vec3> {
    image_sampling(gpu, scene, t, shot, true)
}

/// The mean image, with or without sampling the emissive triangles directly.
fn image_sampling(gpu: &Gpu, scene: &Scene, t: &Trace, shot: Shot, emitters: bool) -> Vec<Vec3> {
    let layers = gpu.layers(4, 1);
    let frames = Frames::sampling_emitters(gpu, scene, &layers, &t.lights, emitters);
    let target = frames.trace_shot(t, TraceWork::WHOLE_IMAGE, shot);
    mean_image(gpu, &target)
}

fn total(img: &[Vec3]) -> f32 {
    img.iter().map(|c| c.element_sum()).sum()
}

#[test]
fn the_indirect_cap_never_touches_direct_light() {
    let gpu = Gpu::new();
    let t = floor_frame();
    // Far below any sample the floor gets: a cap on direct light would black the image out.
    let capped = Shot {
        indirect_clamp: 1e-3,
        ..Shot::RADIANCE
    };
    let scene = glowing_floor(false);
    let free = image(&gpu, &scene, &t, Shot::RADIANCE);
    let held = image(&gpu, &scene, &t, capped);
    assert!(
        total(&free) > 1.0 * free.len() as f32,
        "the floor is lit: {}",
        total(&free)
    );
    // Nothing reflects twice here (the sky, met after one reflection, is direct light too), so the
    // cap has nothing to act on: the same samples.
    assert_eq!(free, held, "the cap changed direct light");
    // Beside a white wall, light reflected twice reaches the camera, and the same cap dims it.
    let scene = glowing_floor(true);
    let free = image(&gpu, &scene, &t, Shot::RADIANCE);
    let held = image(&gpu, &scene, &t, capped);
    let (a, b) = (total(&free), total(&held));
    assert!(
        b < a * 0.97,
        "the cap left light reflected twice as it was: {a} against {b}"
    );
}

#[test]
fn the_exposure_changes_no_radiance() {
    let gpu = Gpu::new();
    let scene = spheres_on_a_floor();
    let t = lit_frame(32, 32);
    let at = |exposure: f32| {
        let shot = Shot {
            exposure,
            // Low enough to cap some of the light bounced between the spheres and the floor.
            indirect_clamp: 0.05,
            seed: 0,
        };
        image(&gpu, &scene, &t, shot)
            .into_iter()
            .map(|c| c / exposure)
            .collect::<Vec<_>>()
    };
    let dark = at(1.0);
    let bright = at(64.0);
    let uncapped = image(&gpu, &scene, &t, Shot::RADIANCE);
    assert!(
        total(&uncapped) > total(&dark) * 1.001,
        "the cap bites somewhere: {} against {}",
        total(&uncapped),
        total(&dark)
    );
    let brightest = dark.iter().map(|c| c.max_element()).fold(0.0, f32::max);
    for (k, (a, b)) in dark.iter().zip(&bright).enumerate() {
        let err = (*a - *b).abs().max_element();
        assert!(
            err <= 0.01 * a.max_element().max(1e-3 * brightest),
            "pixel {k}: {a} at exposure 0, {b} at +6 stops"
        );
    }
}

/// A 2 m room open at the front (+z) to a black sky: floor, ceiling, back and side walls of grey
/// 0.7, and with `panel` a square panel of side 0.5 just under the ceiling glowing 50 nits (its
/// power 2π × 50 × 0.25 lumens, both sides), and with `balls` a small ball on the floor and a
/// glowing copy of it that shares its triangles (kept whole: an instance).
fn room(panel: bool, balls: bool) -> Scene {
    let mut s = Scene::new();
    let grey = rough(0.7, 0.7, 0.7);
    let wall = |s: &mut Scene, rotation: Quat, at: Vec3| {
        s.add(
            &square(1.0),
            Affine3A::from_rotation_translation(rotation, at),
            false,
            &grey,
        );
    };
    wall(
        &mut s,
        Quat::from_rotation_x(-PI / 2.0),
        Vec3::new(0.0, 0.0, 0.0),
    );
    wall(
        &mut s,
        Quat::from_rotation_x(PI / 2.0),
        Vec3::new(0.0, 2.0, 0.0),
    );
    wall(&mut s, Quat::IDENTITY, Vec3::new(0.0, 1.0, -1.0));
    wall(
        &mut s,
        Quat::from_rotation_y(PI / 2.0),
        Vec3::new(-1.0, 1.0, 0.0),
    );
    wall(
        &mut s,
        Quat::from_rotation_y(-PI / 2.0),
        Vec3::new(1.0, 1.0, 0.0),
    );
    if panel {
        s.add(
            &square(0.25),
            Affine3A::from_rotation_translation(Quat::from_rotation_x(PI / 2.0), Vec3::Y * 1.95),
            false,
            &SurfaceMaterial {
                emissive: [50.0; 3],
                ..rough(0.0, 0.0, 0.0)
            },
        );
    }
    if balls {
        let ball = support::scenes::sphere(4);
        let place = |x: f32| {
            Affine3A::from_scale_rotation_translation(
                Vec3::splat(0.2),
                Quat::IDENTITY,
                Vec3::new(x, 0.2, -0.3),
            )
        };
        s.add(&ball, place(-0.45), true, &rough(0.8, 0.3, 0.2));
        s.add(
            &ball,
            place(0.45),
            true,
            &SurfaceMaterial {
                emissive: [30.0, 20.0, 8.0],
                ..rough(0.3, 0.3, 0.3)
            },
        );
    }
    s
}

fn room_frame(samples: u32, lights: Vec<SceneLight>) -> Trace {
    Trace {
        size: 32,
        samples,
        bounces: 16,
        sky: Vec3::ZERO,
        mode: DebugView::PathTraced.shader_index(),
        world_from_clip: camera(
            Vec3::new(0.0, 1.0, 2.6),
            Vec3::new(0.0, 0.9, 0.0),
            Vec3::Y,
            55.0,
        ),
        lights,
    }
}

/// Per 8×8 block, the mean radiance.
fn blocks(img: &[Vec3]) -> Vec<f32> {
    (0..16)
        .map(|b| {
            let (bx, by) = (b % 4 * 8, b / 4 * 8);
            let mut sum = 0.0;
            for y in by..by + 8 {
                for x in bx..bx + 8 {
                    sum += img[(y * 32 + x) as usize].element_sum();
                }
            }
            sum / 64.0
        })
        .collect()
}

#[test]
fn sampling_emissive_triangles_changes_no_expected_value() {
    let gpu = Gpu::new();
    let scene = room(true, true);
    let t = room_frame(512, Vec::new());
    let (listed, _) = scene.emitters();
    assert!(!listed.is_empty());
    let direct = image_sampling(&gpu, &scene, &t, Shot::RADIANCE, true);
    // The BSDF's samples alone, from other random numbers.
    let alone = image_sampling(
        &gpu,
        &scene,
        &t,
        Shot {
            seed: 7,
            ..Shot::RADIANCE
        },
        false,
    );
    let (a, b) = (total(&direct), total(&alone));
    assert!(
        a > 0.0 && (a / b - 1.0).abs() < 0.02,
        "the whole image: {a} against {b}"
    );
    for (k, (x, y)) in blocks(&direct).iter().zip(blocks(&alone)).enumerate() {
        assert!(
            (x / y - 1.0).abs() < 0.08,
            "block {k}: {x} sampling the emitters, {y} without"
        );
    }
}

/// The relative noise of a 64-sample image: the RMS difference of two with independent samples
/// (twice the variance of each), over the mean.
fn noise(gpu: &Gpu, scene: &Scene, t: &Trace, emitters: bool) -> f32 {
    let a = image_sampling(gpu, scene, t, Shot::RADIANCE, emitters);
    let b = image_sampling(
        gpu,
        scene,
        t,
        Shot {
            seed: 1,
            ..Shot::RADIANCE
        },
        emitters,
    );
    let n = a.len() as f32;
    let var: f32 = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (*x - *y).length_squared())
        .sum::<f32>()
        / (2.0 * n);
    let mean = (total(&a) + total(&b)) / (2.0 * n);
    var.sqrt() / mean
}

#[test]
fn an_emissive_panel_lights_a_room_as_quietly_as_a_point_light_of_its_power() {
    let gpu = Gpu::new();
    let panel = room(true, false);
    let t = room_frame(64, Vec::new());
    let sampled = noise(&gpu, &panel, &t, true);
    let found = noise(&gpu, &panel, &t, false);
    let point = room_frame(
        64,
        vec![SceneLight::Point {
            position: Vec3::Y * 1.95,
            power: Vec3::splat(2.0 * PI * 50.0 * 0.25),
            radius: 0.0,
            range: None,
        }],
    );
    let bulb = noise(&gpu, &room(false, false), &point, true);
    eprintln!(
        "relative noise at 64 spp: panel sampled {sampled:.4}, panel found {found:.4}, point {bulb:.4}"
    );
    assert!(sampled < 2.0 * bulb, "panel {sampled}, point light {bulb}");
    assert!(
        found > 2.0 * sampled,
        "the BSDF's samples alone: {found} against {sampled}"
    );
}
