//! The render node: a system in each path-traced camera's `Core3d` schedule that only binds and
//! dispatches what prepare made ready. It runs after the opaque pass and before the transparent
//! pass, so gizmos and other transparent draws land on top of the traced image, depth-tested
//! against the traced depth the resolve writes.

use crate::scene::gpu_scene::GpuScene;
use crate::trace::views::ViewStates;
use bevy::core_pipeline::core_3d::{main_opaque_pass_3d, main_transparent_pass_3d};
use bevy::core_pipeline::schedule::{Core3d, Core3dSystems};
use bevy::prelude::*;
use bevy::render::render_resource::{
    ComputePassDescriptor, LoadOp, Operations, PipelineCache, RenderPassDescriptor, StoreOp,
};
use bevy::render::renderer::{RenderContext, ViewQuery};
use bevy::render::view::{ViewDepthTexture, ViewTarget};

pub(crate) fn build(render_app: &mut SubApp) {
    render_app.add_systems(
        Core3d,
        path_trace
            .after(main_opaque_pass_3d)
            .before(main_transparent_pass_3d)
            .in_set(Core3dSystems::MainPass),
    );
}

/// Traces this frame's share of the view's work (clearing the accumulation first on a restart, and
/// timing the pass where the adapter can), makes the denoiser's pass and carries the last
/// frame's picture over when due, then draws the image and its depth into the view.
fn path_trace(
    view: ViewQuery<(&ViewTarget, Option<&ViewDepthTexture>)>,
    pipeline_cache: Res<PipelineCache>,
    scene: Option<Res<GpuScene>>,
    states: Res<ViewStates>,
    mut ctx: RenderContext,
) {
    let view_entity = view.entity();
    let (target, depth) = view.into_inner();
    let Some(scene) = scene else {
        return;
    };
    let Some(state) = states.0.get(&view_entity) else {
        return;
    };
    let Some(frame) = &state.frame else {
        return;
    };
    if let (Some(groups), Some(pipeline), Some(scene_group)) = (
        frame.dispatch,
        pipeline_cache.get_compute_pipeline(frame.trace_pipeline),
        &scene.bind_group,
    ) {
        let encoder = ctx.command_encoder();
        if frame.clear {
            encoder.clear_buffer(&state.buffers.accum, 0, None);
        }
        let timer = frame.timing.zip(state.timer.as_ref());
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("treelight path trace"),
            timestamp_writes: timer.map(|(slot, t)| t.pass_writes(slot)),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, scene_group, &[]);
        pass.set_bind_group(1, &state.buffers.trace_bind_group, &[]);
        pass.dispatch_workgroups(groups.x, groups.y, 1);
        drop(pass);
        if let Some((slot, t)) = timer {
            t.copy_out(slot, encoder);
        }
    }
    if let Some((pipeline, step)) = frame
        .denoise
        .and_then(|d| Some((pipeline_cache.get_compute_pipeline(d.pipeline)?, d)))
    {
        let size = state.buffers.size();
        let target = crate::types::records::denoise_target(step.pass, step.passes);
        let mut pass = ctx
            .command_encoder()
            .begin_compute_pass(&ComputePassDescriptor {
                label: Some("treelight denoise"),
                timestamp_writes: None,
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(
            0,
            &state.buffers.denoise_bind_groups[step.pass as usize][target],
            &[],
        );
        pass.dispatch_workgroups(size.x.div_ceil(8), size.y.div_ceil(8), 1);
    }
    if let Some(pipeline) = frame
        .temporal
        .and_then(|id| pipeline_cache.get_compute_pipeline(id))
    {
        let size = state.buffers.size();
        let mut pass = ctx
            .command_encoder()
            .begin_compute_pass(&ComputePassDescriptor {
                label: Some("treelight temporal"),
                timestamp_writes: None,
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &state.buffers.temporal_bind_groups[frame.parity], &[]);
        pass.dispatch_workgroups(size.x.div_ceil(8), size.y.div_ceil(8), 1);
    }
    let Some(resolve) = pipeline_cache.get_render_pipeline(frame.resolve_pipeline) else {
        return;
    };
    let mut attachment = target.get_color_attachment();
    attachment.ops = Operations {
        load: LoadOp::Load,
        store: StoreOp::Store,
    };
    let depth = depth.filter(|_| frame.writes_depth);
    let mut pass = ctx
        .command_encoder()
        .begin_render_pass(&RenderPassDescriptor {
            label: Some("treelight resolve"),
            color_attachments: &[Some(attachment)],
            depth_stencil_attachment: depth.map(|d| d.get_attachment(StoreOp::Store)),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
    let v = frame.viewport.as_vec4();
    pass.set_viewport(v.x, v.y, v.z, v.w, 0.0, 1.0);
    pass.set_pipeline(resolve);
    pass.set_bind_group(0, &state.buffers.resolve_bind_groups[frame.parity], &[]);
    pass.draw(0..3, 0..1);
}
