//! The denoiser's cost per frame: its five passes over a traced image of 1080p's pixel count
//! (1440 × 1440 = 1920 × 1080 pixels), timed from submission to completion, on whatever adapter
//! the machine has. `cargo run -p treelight_render --example denoise_cost` (the dev profile is
//! optimised).

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::Instant;
use support::Gpu;
use support::scenes::{lit_frame, spheres_on_a_floor, trace_into};

fn main() {
    let gpu = Gpu::new();
    let layers = gpu.layers(4, 1);
    let scene = spheres_on_a_floor();
    let frame = lit_frame(1440, 1);
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
