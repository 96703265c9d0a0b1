//! The render node: a system in each path-traced camera's `Core3d` schedule that only binds and
//! dispatches what prepare made ready. It runs after the opaque pass and before the transparent
//! pass, so gizmos and other transparent draws still land on top of the traced image (depth-tested
//! against the rasterised depth of the same meshes).

use crate::pipelines::PathTracerPipelines;
use crate::prepare::{GpuScene, ViewStates};
use bevy::core_pipeline::core_3d::{main_opaque_pass_3d, main_transparent_pass_3d};
use bevy::core_pipeline::schedule::{Core3d, Core3dSystems};
use bevy::prelude::*;
use bevy::render::render_resource::{
    ComputePassDescriptor, LoadOp, Operations, PipelineCache, RenderPassDescriptor, StoreOp,
};
use bevy::render::renderer::{RenderContext, ViewQuery};
use bevy::render::view::ViewTarget;

pub(crate) fn build(render_app: &mut SubApp) {
    render_app.add_systems(
        Core3d,
        path_trace
            .after(main_opaque_pass_3d)
            .before(main_transparent_pass_3d)
            .in_set(Core3dSystems::MainPass),
    );
}

/// Traces the view's samples of this frame into its accumulation buffer, then draws the average
/// into the view target.
fn path_trace(
    view: ViewQuery<&ViewTarget>,
    pipelines: Option<Res<PathTracerPipelines>>,
    pipeline_cache: Res<PipelineCache>,
    scene: Option<Res<GpuScene>>,
    states: Res<ViewStates>,
    mut ctx: RenderContext,
) {
    let view_entity = view.entity();
    let target = view.into_inner();
    let (Some(pipelines), Some(scene)) = (pipelines, scene) else {
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
        pipeline_cache.get_compute_pipeline(pipelines.trace),
        &scene.bind_group,
    ) {
        let mut pass = ctx
            .command_encoder()
            .begin_compute_pass(&ComputePassDescriptor {
                label: Some("treelight path trace"),
                timestamp_writes: None,
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, scene_group, &[]);
        pass.set_bind_group(1, &state.trace_bind_group, &[]);
        pass.dispatch_workgroups(groups.x, groups.y, 1);
    }
    let Some(resolve) = pipeline_cache.get_render_pipeline(frame.resolve_pipeline) else {
        return;
    };
    let mut attachment = target.get_color_attachment();
    attachment.ops = Operations {
        load: LoadOp::Load,
        store: StoreOp::Store,
    };
    let mut pass = ctx
        .command_encoder()
        .begin_render_pass(&RenderPassDescriptor {
            label: Some("treelight resolve"),
            color_attachments: &[Some(attachment)],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
    let v = frame.viewport.as_vec4();
    pass.set_viewport(v.x, v.y, v.z, v.w, 0.0, 1.0);
    pass.set_pipeline(resolve);
    pass.set_bind_group(0, &state.resolve_bind_group, &[]);
    pass.draw(0..3, 0..1);
}
