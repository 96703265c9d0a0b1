//! The temporal pass on the adapter, as the plugin runs it through a camera's move:
//!
//! * An orbit of preview frames (one sample per 2×2 block each, a new seed each frame, as the
//!   editor traces while the camera moves): with the last frame's picture carried over, each
//!   frame's error against the converged frame at its camera falls well below the preview's own.
//!   The figures are printed (frames to a fixed error, with and without).
//! * Disocclusion: a black sphere slides across a bright wall. What the move uncovers takes
//!   nothing from the sphere, and the sphere nothing from the wall (object slots and depths, read
//!   independently from the primary hits, say which pixel shows what).
//! * A still view converges to exactly its own samples: from the fade's sample count on, the
//!   picture is the accumulation's mean (in the half floats the picture holds).

mod support;

use support::scenes::{
    Frames, Scene, Trace, camera, lit_frame, mean_image, sphere, spheres_on_a_floor, square,
};
use support::temporal::Pictures;
use support::{Gpu, relative_mse};
use treelight_bvh::glam::{Affine3A, Mat4, Quat, Vec3};
use treelight_render::{SurfaceMaterial, TEMPORAL_FADE_SAMPLES, TemporalRestart, TraceWork};

const SIZE: u32 = 48;

/// [`lit_frame`]'s view of `SIZE`² through `world_from_clip`, `samples` a pixel, `bounces` deep.
fn lit(world_from_clip: Mat4, samples: u32, bounces: u32) -> Trace {
    Trace {
        world_from_clip,
        samples,
        bounces,
        ..lit_frame(SIZE, samples)
    }
}

/// The camera of frame `t` of an orbit about the spheres, `step` degrees a frame.
fn orbit(t: u32, step: f32) -> Mat4 {
    let a = (t as f32 * step).to_radians();
    let eye = Vec3::new(3.5 * a.sin(), 2.0, 3.5 * a.cos());
    camera(eye, Vec3::new(0.0, 0.4, 0.0), Vec3::Y, 45.0)
}

#[test]
fn an_orbit_carried_over_is_closer_to_the_converged_frames_than_its_previews() {
    let gpu = Gpu::new();
    let layers = gpu.layers(4, 1);
    let scene = spheres_on_a_floor();
    let frames = Frames::new(&gpu, &scene, &layers, &lit_frame(SIZE, 1).lights);
    let temporal = gpu.pipeline(treelight_render::TEMPORAL_WGSL, "temporal");
    let mut pictures = Pictures::new(&gpu, SIZE, SIZE);
    // The preview's light (one bounce, as the plugin traces it while the camera moves).
    const BOUNCES: u32 = 1;
    const FRAMES: u32 = 16;
    let mut table = String::from("frame  preview relMSE  carried over relMSE\n");
    let mut late = (0.0, 0.0);
    let mut previous: Option<Mat4> = None;
    for t in 0..FRAMES {
        let world_from_clip = orbit(t, 1.5);
        let reference = mean_image(
            &gpu,
            &frames.trace(&lit(world_from_clip, 256, BOUNCES), TraceWork::WHOLE_IMAGE),
        );
        let target = frames.trace(
            &lit(world_from_clip, 1, BOUNCES),
            TraceWork::Preview {
                scale: 2,
                seed: t + 1,
            },
        );
        let (restart, reproject) = match previous {
            Some(prev) => (TemporalRestart::Reproject, prev.inverse() * world_from_clip),
            None => (TemporalRestart::Clear, Mat4::IDENTITY),
        };
        previous = Some(world_from_clip);
        // Without the last frame: the preview alone (a restart with nothing to carry).
        let mut alone = Pictures::new(&gpu, SIZE, SIZE);
        let (preview, _) = alone.run(
            &gpu,
            &temporal,
            &target,
            Mat4::IDENTITY,
            2,
            TemporalRestart::Clear,
        );
        let (carried, _) = pictures.run(&gpu, &temporal, &target, reproject, 2, restart);
        assert!(carried.iter().all(|c| c.is_finite()));
        let (e_preview, e_carried) = (
            relative_mse(&preview, &reference),
            relative_mse(&carried, &reference),
        );
        table.push_str(&format!("{t:>5}  {e_preview:.5}         {e_carried:.5}\n"));
        if t >= FRAMES / 2 {
            late.0 += e_preview;
            late.1 += e_carried;
        }
    }
    eprintln!("{table}");
    assert!(
        late.1 < 0.5 * late.0,
        "carrying the picture over leaves more than half the preview's error:\n{table}"
    );
}

#[test]
fn what_a_move_uncovers_takes_nothing_from_what_hid_it() {
    let gpu = Gpu::new();
    let layers = gpu.layers(4, 1);
    let mut scene = Scene::new();
    let wall = SurfaceMaterial {
        base_color: [0.0, 0.0, 0.0, 1.0],
        emissive: [4.0, 4.0, 4.0],
        ..Default::default()
    };
    let black = SurfaceMaterial {
        base_color: [0.0, 0.0, 0.0, 1.0],
        perceptual_roughness: 1.0,
        reflectance: 0.0,
        ..Default::default()
    };
    let wall_id = scene.add(
        &square(4.0),
        Affine3A::from_translation(Vec3::new(0.0, 0.0, -2.0)),
        false,
        &wall,
    );
    let ball_id = scene.add(
        &sphere(24),
        Affine3A::from_scale_rotation_translation(Vec3::splat(0.5), Quat::IDENTITY, Vec3::ZERO),
        false,
        &black,
    );
    let frames = Frames::new(&gpu, &scene, &layers, &[]);
    let temporal = gpu.pipeline(treelight_render::TEMPORAL_WGSL, "temporal");
    let at = |x: f32| {
        camera(
            Vec3::new(x, 0.0, 3.0),
            Vec3::new(x, 0.0, 0.0),
            Vec3::Y,
            45.0,
        )
    };
    let (before, after) = (at(0.0), at(0.4));
    // No light but the wall's own (and the sky).
    let dark = |world_from_clip: Mat4, samples: u32| Trace {
        lights: Vec::new(),
        ..lit(world_from_clip, samples, 2)
    };
    let mut pictures = Pictures::new(&gpu, SIZE, SIZE);
    let first = frames.trace(&dark(before, 16), TraceWork::WHOLE_IMAGE);
    pictures.run(
        &gpu,
        &temporal,
        &first,
        Mat4::IDENTITY,
        0,
        TemporalRestart::Clear,
    );
    // One sample a pixel after the move: the last picture weighs far more than the new sample.
    let second = frames.trace(&dark(after, 1), TraceWork::WHOLE_IMAGE);
    let (picture, prior) = pictures.run(
        &gpu,
        &temporal,
        &second,
        before.inverse() * after,
        0,
        TemporalRestart::Reproject,
    );
    let own = mean_image(&gpu, &second);
    let wall_level = own.iter().map(|c| c.max_element()).fold(0.0, f32::max);
    assert!(wall_level > 1.0, "the wall glows: {wall_level}");
    let objects_before = gpu.read_objects(&first);
    let objects_after = gpu.read_objects(&second);
    let (mut uncovered, mut covered, mut carried) = (0, 0, 0);
    for (i, c) in picture.iter().enumerate() {
        let o = objects_after[i];
        carried += usize::from(prior[i] > 1.0);
        if o == ball_id.index() {
            // The sphere stays dark wherever it is now, whatever was there before (a black
            // surface: only its Fresnel rim reflects the wall, at most a quarter of it).
            assert!(
                c.max_element() < 0.25 * wall_level,
                "pixel {i} on the sphere reads {c}, the wall {wall_level}"
            );
            covered += usize::from(objects_before[i] == wall_id.index());
        } else if o == wall_id.index() {
            // The wall glows the same wherever it is seen (its own sample here says how much).
            assert!(
                (*c - own[i]).abs().max_element() < 0.01 * own[i].max_element(),
                "pixel {i} on the wall reads {c}, its sample {}",
                own[i]
            );
            uncovered += usize::from(objects_before[i] == ball_id.index());
        }
    }
    // The move did uncover and cover pixels, and most pixels carried the last picture over.
    assert!(
        uncovered > 20 && covered > 20,
        "{uncovered} uncovered, {covered} covered"
    );
    assert!(carried > picture.len() / 2, "{carried} pixels carried over");
}

#[test]
fn a_still_view_shows_exactly_its_samples_once_it_has_enough() {
    let gpu = Gpu::new();
    let layers = gpu.layers(4, 1);
    let scene = spheres_on_a_floor();
    let frames = Frames::new(&gpu, &scene, &layers, &lit_frame(SIZE, 1).lights);
    let temporal = gpu.pipeline(treelight_render::TEMPORAL_WGSL, "temporal");
    let mut pictures = Pictures::new(&gpu, SIZE, SIZE);
    let (a, b) = (orbit(0, 0.0), orbit(1, 3.0));
    let first = frames.trace(&lit(a, 32, 4), TraceWork::WHOLE_IMAGE);
    pictures.run(
        &gpu,
        &temporal,
        &first,
        Mat4::IDENTITY,
        0,
        TemporalRestart::Clear,
    );
    let fade = TEMPORAL_FADE_SAMPLES as u32;
    for (samples, restart) in [
        (1, TemporalRestart::Reproject),
        (fade / 2, TemporalRestart::Keep),
        (fade, TemporalRestart::Keep),
        (2 * fade, TemporalRestart::Keep),
    ] {
        let target = frames.trace(&lit(b, samples, 4), TraceWork::WHOLE_IMAGE);
        let (picture, prior) = pictures.run(&gpu, &temporal, &target, a.inverse() * b, 0, restart);
        let mean = mean_image(&gpu, &target);
        // The picture holds half floats: the mean as a half float rounds it.
        let same = picture
            .iter()
            .zip(&mean)
            .filter(|(p, m)| {
                (**p - **m)
                    .abs()
                    .cmple(m.abs() / 1024.0 + Vec3::splat(1e-7))
                    .all()
            })
            .count();
        if samples >= fade {
            assert_eq!(same, picture.len(), "at {samples} samples a pixel");
        } else {
            // Before, the prior still counts where it was carried over.
            let carried = prior.iter().filter(|&&w| w > 0.0).count();
            assert!(carried > picture.len() / 2, "{carried} carried");
            assert!(
                same < picture.len() / 2,
                "{same} of {} unchanged",
                picture.len()
            );
        }
    }
}
