//! The denoiser's cost per frame: all its passes (the first, then five filter passes) over a
//! traced image of 1080p's pixel count (1440 × 1440 = 1920 × 1080 pixels), and the temporal pass
//! after them (carrying the last frame's picture through a camera move), each timed from
//! submission to completion, on whatever adapter the machine has. `cargo run -p treelight_render
//! --example denoise_cost [-- SIDE [SAMPLES]]` (the dev profile is optimised): SIDE × SIDE pixels,
//! 1440 unless given, traced at SAMPLES a pixel (1 unless given); the square whose pixel count is
//! a view's traced one prices that view (the editor's 1280 × 800 window traces its viewport at
//! half resolution on a software adapter).

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::Instant;
use support::Gpu;
use support::scenes::{lit_frame, spheres_on_a_floor, trace_into};
use support::temporal::Pictures;
use treelight_render::TemporalRestart;

/// The `k`-th argument, a number in `range`, or `default` where it is not given; anything else
/// ends the run with a message naming it.
fn number_arg(k: usize, name: &str, range: std::ops::RangeInclusive<u32>, default: u32) -> u32 {
    let Some(text) = std::env::args().nth(k) else {
        return default;
    };
    match text.parse() {
        Ok(n) if range.contains(&n) => n,
        _ => {
            eprintln!(
                "denoise_cost: {name} is a number from {} to {}, not {text:?}",
                range.start(),
                range.end()
            );
            std::process::exit(2);
        }
    }
}

fn main() {
    let side = number_arg(1, "SIDE (pixels)", 8..=8192, 1440);
    // The samples a pixel of the traced image: from 16 a pixel has the four parts the filter
    // compares (denoise.wgsl's `quarters`).
    let samples = number_arg(2, "SAMPLES", 1..=1024, 1);
    let gpu = Gpu::new();
    let layers = gpu.layers(4, 1);
    let scene = spheres_on_a_floor();
    let frame = lit_frame(side, samples);
    let (_, _, target) = trace_into(&gpu, &scene, &layers, &frame);
    let pipeline = gpu.pipeline(treelight_render::DENOISE_WGSL, "denoise");
    gpu.denoise_with(&pipeline, &target, 1);
    gpu.wait();
    let median = |mut run: Box<dyn FnMut()>| {
        let mut times: Vec<f64> = (0..7)
            .map(|_| {
                let start = Instant::now();
                run();
                gpu.wait();
                start.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        times.sort_by(f64::total_cmp);
        (times[times.len() / 2], times[0], times.len())
    };
    let (m, min, n) = median(Box::new(|| gpu.denoise_with(&pipeline, &target, 1)));
    println!(
        "denoiser, {side}×{side} at {samples} samples, the first and 5 filter passes: median {m:.1} ms, min {min:.1} ms over {n} runs"
    );
    // One frame's share in the editor, which makes a pass a frame: the first, and the costliest
    // filter pass (the widest, its taps furthest apart).
    for (pass, name) in [(0, "the first pass"), (5, "the last filter pass")] {
        let (gpu, pipeline, target) = (&gpu, &pipeline, &target);
        let (m, min, n) = median(Box::new(move || {
            gpu.denoise_pass(pipeline, target, pass, 6)
        }));
        println!(
            "denoiser, {side}×{side} at {samples} samples, {name} alone: median {m:.1} ms, min {min:.1} ms over {n} runs"
        );
    }
    let temporal = gpu.pipeline(treelight_render::TEMPORAL_WGSL, "temporal");
    let mut pictures = Pictures::new(&gpu, side, side);
    let step = frame.world_from_clip.inverse() * frame.world_from_clip;
    pictures.pass(&gpu, &temporal, &target, step, 0, TemporalRestart::Clear);
    let (m, min, n) = median(Box::new(|| {
        pictures.pass(
            &gpu,
            &temporal,
            &target,
            step,
            0,
            TemporalRestart::Reproject,
        );
    }));
    println!(
        "temporal pass, {side}×{side}, reprojecting every pixel: median {m:.1} ms, min {min:.1} ms over {n} runs"
    );
}
