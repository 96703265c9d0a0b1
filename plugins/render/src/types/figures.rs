//! What the render world reports back to the main world: bytes, samples, kernels waited for.

use crate::types::budget::CostSource;
use bevy::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Figures the render world reports back for the UI.
#[derive(Clone, Debug, Default)]
pub struct PathTracerFigures {
    /// Bytes written to the scene buffers in the last frame that uploaded anything.
    pub last_upload_bytes: u64,
    /// Bytes written to the scene buffers since start.
    pub total_upload_bytes: u64,
    /// The most bytes one frame wrote to the scene buffers. A frame holds at most a round of
    /// them at once in its writes (`UploadRound`), and a round in staging.
    pub largest_upload_bytes: u64,
    /// Rounds of writes the extraction handed to the GPU before their frame's end, since start.
    pub upload_rounds: u64,
    /// Frames that uploaded anything.
    pub uploads: u64,
    /// Samples every pixel has accumulated so far, per path-traced camera.
    pub samples: HashMap<Entity, u32>,
    /// The frame budget's latest figures, per path-traced camera.
    pub traces: HashMap<Entity, TraceFigures>,
    /// Whether the GPU copy has caught up with the scene at least once.
    pub scene_ready: bool,
    /// The scene tree's version ([`treelight_scene::SceneBvh::version`]) the GPU copy holds: the
    /// copy is current when it equals the tree's.
    pub uploaded_version: u64,
    /// Why nothing is traced, when the scene or a view needs a buffer larger than the adapter can
    /// bind: the path tracer stops (the scene itself is untouched) and an app shows another view.
    pub trace_off: Option<String>,
    /// The trace kernel the scene's views wait for while it is compiled away from their queue,
    /// on a software adapter: at the start, when a scene first outgrows one binding, when a
    /// texture of another kind is bound (with a cold shader cache most of a minute for the
    /// whole-scene kernel and minutes for the split one; about a second once the driver's cache
    /// holds it).
    pub preparing_kernel: Option<PreparingKernel>,
    /// Waits for a trace kernel that have ended so far (a [`PathTracerFigures::preparing_kernel`]
    /// gone): a compile with a cold shader cache leaves hundreds of MiB of the compiler's freed
    /// memory with the allocator, which an app may hand back to the system then.
    pub kernels_prepared: u64,
    /// Bytes of the scene's GPU buffers (on a software adapter, in the process's own memory).
    pub scene_buffer_bytes: u64,
    /// Heap bytes of the node records' layout ([`treelight_bvh::WideRecords`]) the extraction
    /// keeps in step with the tree: which inner nodes own a record, and where.
    pub record_layout_bytes: u64,
    /// The side, in texels, every texture is traced at: `TEXTURE_LAYER_SIZE` until more
    /// textures are in use than its budget holds, then smaller (0 before any texture).
    pub texture_side: u32,
    /// Bytes of the device allocator's memory blocks, used or not: every buffer and texture of
    /// the app and the uploads' staging (read about once a second); `None` where the backend keeps
    /// no such report.
    pub gpu_reserved_bytes: Option<u64>,
    /// Mesh assets kept out of the render world while every active 3D camera is path traced
    /// (`HoldBackRasterMeshes`).
    pub meshes_held_back: usize,
}

impl PathTracerFigures {
    /// Sets the kernel the views wait for this frame, counting a wait that ends
    /// ([`PathTracerFigures::kernels_prepared`]).
    pub(crate) fn set_preparing_kernel(&mut self, kernel: Option<PreparingKernel>) {
        self.kernels_prepared += u64::from(self.preparing_kernel.is_some() && kernel.is_none());
        self.preparing_kernel = kernel;
    }
}

/// A trace kernel the views wait for ([`PathTracerFigures::preparing_kernel`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparingKernel {
    /// Whether it is the kernel over records split across bindings (a large scene), not the
    /// whole-scene one.
    pub split: bool,
    /// Seconds the views have waited for it so far.
    pub waited_s: f32,
}

impl PreparingKernel {
    /// Whether the wait has lasted long enough to tell the user of it: with a warm shader cache
    /// it is over in about a second, unnoticed.
    pub fn noticeable(&self) -> bool {
        self.waited_s >= 1.5
    }
}

/// One path-traced camera's latest frame under its budget.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceFigures {
    /// Pixel samples the frame traced.
    pub traced_per_frame: u64,
    /// What a pixel sample costs, nanoseconds, and how that was measured, once it was.
    pub cost: Option<(f64, CostSource)>,
    /// Whether the frame traced the coarse preview (the view had just changed).
    pub previewing: bool,
    /// Whether the frame traced triangles: it traced samples and the scene's tree was not empty.
    pub geometry: bool,
    /// Whether the camera's samples were traced under a sky panorama (not the flat sky colour):
    /// read with [`PathTracerFigures::samples`], it tells which sky those samples show.
    pub panorama: bool,
    /// Whether the denoiser has passes to make after this frame's (a run part way, one due to
    /// start next frame, the tree still filling or its pipeline compiling; it makes one pass a
    /// frame): the picture changes again when they are made, so a view at its sample limit is
    /// finished only once this is false.
    pub denoising: bool,
    /// The denoiser's pass the frame made, of how many its run makes, when it made one.
    pub denoise_pass: Option<(u32, u32)>,
}

/// Figures about the path tracer (bytes uploaded, samples per camera), readable from the main world.
#[derive(Resource, Clone, Default)]
pub struct PathTracerStats(Arc<Mutex<PathTracerFigures>>);

impl PathTracerStats {
    /// A copy of the current figures.
    pub fn figures(&self) -> PathTracerFigures {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Samples per pixel the camera has accumulated.
    pub fn samples(&self, camera: Entity) -> u32 {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .samples
            .get(&camera)
            .copied()
            .unwrap_or(0)
    }

    /// Whether the camera's picture is finished at `samples` a pixel: it has them, and the
    /// denoiser owes it no pass ([`TraceFigures::denoising`]; the last samples' run ends a few
    /// frames after them).
    pub fn finished(&self, camera: Entity, samples: u32) -> bool {
        let figures = self.0.lock().unwrap_or_else(|p| p.into_inner());
        figures.samples.get(&camera).is_some_and(|&n| n >= samples)
            && !figures.traces.get(&camera).is_some_and(|t| t.denoising)
    }

    /// Why nothing is traced, once the path tracer stopped ([`PathTracerFigures::trace_off`]).
    pub fn trace_off(&self) -> Option<String> {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .trace_off
            .clone()
    }

    /// The trace kernel the views wait for ([`PathTracerFigures::preparing_kernel`]).
    pub fn preparing_kernel(&self) -> Option<PreparingKernel> {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .preparing_kernel
    }

    /// The side every texture is traced at ([`PathTracerFigures::texture_side`]).
    pub fn texture_side(&self) -> u32 {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .texture_side
    }

    pub(crate) fn update(&self, f: impl FnOnce(&mut PathTracerFigures)) {
        f(&mut self.0.lock().unwrap_or_else(|p| p.into_inner()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wait_for_a_kernel_is_counted_when_it_ends() {
        let waiting = Some(PreparingKernel {
            split: true,
            waited_s: 1.0,
        });
        let mut f = PathTracerFigures::default();
        f.set_preparing_kernel(None);
        assert_eq!(f.kernels_prepared, 0, "no wait, none ended");
        f.set_preparing_kernel(waiting);
        f.set_preparing_kernel(waiting);
        assert_eq!(f.kernels_prepared, 0, "still waiting");
        f.set_preparing_kernel(None);
        assert_eq!(f.kernels_prepared, 1);
        assert!(f.preparing_kernel.is_none());
        f.set_preparing_kernel(None);
        assert_eq!(f.kernels_prepared, 1, "one wait counts once");
        f.set_preparing_kernel(waiting);
        f.set_preparing_kernel(None);
        assert_eq!(f.kernels_prepared, 2);
    }
}
