//! The temporal pass's buffers, as the plugin keeps them beside a view's, and its dispatch.

use super::{Gpu, TraceTarget, floats};
use treelight_bvh::glam::{Mat4, Vec3};
use treelight_render::{TemporalRestart, temporal_bytes};

/// The temporal pass's buffers beside a trace target: its two pictures and its prior.
pub struct Pictures {
    width: u32,
    height: u32,
    shown: [wgpu::Buffer; 2],
    prior: wgpu::Buffer,
    parity: usize,
}

impl Pictures {
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> Self {
        let pixels = (width * height) as usize;
        Self {
            width,
            height,
            shown: [
                gpu.storage("shown", &vec![0u8; pixels * 16]),
                gpu.storage("shown", &vec![0u8; pixels * 16]),
            ],
            prior: gpu.storage("prior", &vec![0u8; pixels * 16]),
            parity: 0,
        }
    }

    /// One temporal pass over `target` (as the plugin runs it after the trace); returns the
    /// picture (rgb per pixel) and the prior's weights.
    pub fn run(
        &mut self,
        gpu: &Gpu,
        pipeline: &wgpu::ComputePipeline,
        target: &TraceTarget,
        reproject: Mat4,
        preview_scale: u32,
        restart: TemporalRestart,
    ) -> (Vec<Vec3>, Vec<f32>) {
        let k = self.pass(gpu, pipeline, target, reproject, preview_scale, restart);
        // Two words of half floats a pixel: red and green, blue and the weight.
        let half = |w: u32, high: bool| {
            half::f16::from_bits(if high { (w >> 16) as u16 } else { w as u16 }).to_f32()
        };
        let picture = super::words(&gpu.read(&self.shown[k]))
            .chunks_exact(4)
            .map(|c| Vec3::new(half(c[0], false), half(c[0], true), half(c[1], false)))
            .collect();
        let prior = floats(&gpu.read(&self.prior))
            .chunks_exact(4)
            .map(|c| c[3])
            .collect();
        (picture, prior)
    }

    /// The pass alone, waited for: returns which picture it wrote.
    pub fn pass(
        &mut self,
        gpu: &Gpu,
        pipeline: &wgpu::ComputePipeline,
        target: &TraceTarget,
        reproject: Mat4,
        preview_scale: u32,
        restart: TemporalRestart,
    ) -> usize {
        let params = gpu.storage(
            "temporal",
            &temporal_bytes(
                reproject,
                self.width,
                self.height,
                preview_scale,
                false,
                restart,
            ),
        );
        let k = self.parity;
        gpu.dispatch_indexed(
            pipeline,
            vec![vec![
                (0, target.accum.as_entire_binding()),
                (1, target.aux.as_entire_binding()),
                (2, params.as_entire_binding()),
                (3, target.denoised[0].as_entire_binding()),
                (4, target.guides.as_entire_binding()),
                (5, self.shown[1 - k].as_entire_binding()),
                (6, self.shown[k].as_entire_binding()),
                (7, self.prior.as_entire_binding()),
            ]],
            (self.width.div_ceil(8), self.height.div_ceil(8)),
        );
        self.parity = 1 - k;
        k
    }
}
