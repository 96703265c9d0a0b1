//! The render node: a system in each path-traced camera's `Core3d` schedule. It runs after the opaque
//! pass and before the transparent pass, so gizmos and other transparent draws still land on top of
//! the traced image (depth-tested against the rasterised depth of the same meshes).

use crate::gpu_scene::GpuScene;
use crate::records::{VIEW_BYTES, ViewParams, resolve_bytes};
use crate::textures::TextureLayers;
use crate::{DebugView, PathTraced, PathTracerStats};
use bevy::core_pipeline::core_3d::{main_opaque_pass_3d, main_transparent_pass_3d};
use bevy::core_pipeline::schedule::{Core3d, Core3dSystems};
use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::render_resource::binding_types::{
    sampler, storage_buffer_read_only_sized, storage_buffer_sized, texture_2d_array,
    uniform_buffer_sized,
};
use bevy::render::render_resource::{
    BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries, Buffer, BufferDescriptor,
    BufferUsages, CachedComputePipelineId, CachedRenderPipelineId, ColorTargetState, ColorWrites,
    ComputePassDescriptor, ComputePipelineDescriptor, FragmentState, LoadOp, MultisampleState,
    Operations, PipelineCache, RenderPassDescriptor, RenderPipelineDescriptor, SamplerBindingType,
    ShaderStages, StoreOp, TextureFormat, TextureSampleType, VertexState,
};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::sync_world::MainEntity;
use bevy::render::view::{ExtractedView, ViewTarget};
use bevy::render::{RenderStartup, RenderSystems};
use std::collections::HashMap;
use std::sync::Mutex;

/// The kernels' shader assets.
#[derive(Resource, Clone)]
pub(crate) struct PathTracerShaders {
    pub trace: Handle<Shader>,
    pub resolve: Handle<Shader>,
    pub texture_layer: Handle<Shader>,
}

pub(crate) fn build(render_app: &mut SubApp) {
    render_app
        .init_resource::<ViewStates>()
        .add_systems(RenderStartup, init_pipelines)
        .add_systems(
            bevy::render::Render,
            forget_views.in_set(RenderSystems::Cleanup),
        )
        .add_systems(
            Core3d,
            path_trace
                .after(main_opaque_pass_3d)
                .before(main_transparent_pass_3d)
                .in_set(Core3dSystems::MainPass),
        );
}

#[derive(Resource)]
pub(crate) struct PathTracerPipelines {
    trace_layout: BindGroupLayoutDescriptor,
    resolve_layout: BindGroupLayoutDescriptor,
    trace: CachedComputePipelineId,
    resolve_shader: Handle<Shader>,
    /// Resolve pipelines by target format and sample count.
    resolve: Mutex<HashMap<(TextureFormat, u32), CachedRenderPipelineId>>,
}

fn init_pipelines(
    mut commands: Commands,
    shaders: Res<PathTracerShaders>,
    pipeline_cache: Res<PipelineCache>,
) {
    let trace_layout = BindGroupLayoutDescriptor::new(
        "treelight path trace",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                uniform_buffer_sized(false, None),
                storage_buffer_sized(false, None),
                texture_2d_array(TextureSampleType::Float { filterable: true }),
                sampler(SamplerBindingType::Filtering),
            ),
        ),
    );
    let resolve_layout = BindGroupLayoutDescriptor::new(
        "treelight resolve",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                storage_buffer_read_only_sized(false, None),
                uniform_buffer_sized(false, None),
            ),
        ),
    );
    let trace = pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
        label: Some("treelight path trace".into()),
        layout: vec![trace_layout.clone()],
        shader: shaders.trace.clone(),
        entry_point: Some("path_trace".into()),
        ..default()
    });
    commands.insert_resource(PathTracerPipelines {
        trace_layout,
        resolve_layout,
        trace,
        resolve_shader: shaders.resolve.clone(),
        resolve: Mutex::new(HashMap::new()),
    });
}

impl PathTracerPipelines {
    fn resolve_pipeline(
        &self,
        cache: &PipelineCache,
        format: TextureFormat,
        samples: u32,
    ) -> CachedRenderPipelineId {
        let mut map = self.resolve.lock().unwrap_or_else(|p| p.into_inner());
        *map.entry((format, samples)).or_insert_with(|| {
            cache.queue_render_pipeline(RenderPipelineDescriptor {
                label: Some("treelight resolve".into()),
                layout: vec![self.resolve_layout.clone()],
                vertex: VertexState {
                    shader: self.resolve_shader.clone(),
                    entry_point: Some("vertex".into()),
                    ..default()
                },
                fragment: Some(FragmentState {
                    shader: self.resolve_shader.clone(),
                    entry_point: Some("fragment".into()),
                    targets: vec![Some(ColorTargetState {
                        format,
                        blend: None,
                        write_mask: ColorWrites::ALL,
                    })],
                    ..default()
                }),
                multisample: MultisampleState {
                    count: samples,
                    ..default()
                },
                ..default()
            })
        })
    }
}

/// What a view's accumulated samples depend on: any change restarts the accumulation.
#[derive(Clone, Copy, PartialEq)]
struct AccumulationKey {
    world_from_clip: Mat4,
    scene_generation: u64,
    /// Only for the heatmap, which shows the tree itself.
    tree_generation: u64,
    settings: PathTraced,
    exposure: f32,
    size: UVec2,
}

struct ViewState {
    accum: Buffer,
    view_uniform: Buffer,
    resolve_uniform: Buffer,
    size: UVec2,
    samples: u32,
    key: Option<AccumulationKey>,
    seen: bool,
}

/// Per-view accumulation state, by render-world view entity.
#[derive(Resource, Default)]
struct ViewStates(HashMap<Entity, ViewState>);

fn uniform(device: &RenderDevice, label: &'static str, size: u64) -> Buffer {
    device.create_buffer(&BufferDescriptor {
        label: Some(label),
        size,
        usage: BufferUsages::UNIFORM | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn view_state(device: &RenderDevice, size: UVec2) -> ViewState {
    ViewState {
        accum: device.create_buffer(&BufferDescriptor {
            label: Some("treelight accumulation"),
            size: size.x as u64 * size.y as u64 * 16,
            usage: BufferUsages::STORAGE,
            mapped_at_creation: false,
        }),
        view_uniform: uniform(device, "treelight view", VIEW_BYTES),
        resolve_uniform: uniform(device, "treelight resolve", 32),
        size,
        samples: 0,
        key: None,
        seen: true,
    }
}

/// Drops the state of views that were not drawn this frame (cameras despawned or switched off).
fn forget_views(mut states: ResMut<ViewStates>) {
    states
        .0
        .retain(|_, s| std::mem::replace(&mut s.seen, false));
}

#[allow(clippy::too_many_arguments)]
fn path_trace(
    view: ViewQuery<(
        &ExtractedCamera,
        &ExtractedView,
        &ViewTarget,
        &PathTraced,
        &MainEntity,
    )>,
    pipelines: Option<Res<PathTracerPipelines>>,
    pipeline_cache: Res<PipelineCache>,
    scene: Option<Res<GpuScene>>,
    layers: Option<Res<TextureLayers>>,
    mut states: ResMut<ViewStates>,
    queue: Res<RenderQueue>,
    stats: Res<PathTracerStats>,
    mut ctx: RenderContext,
) {
    let view_entity = view.entity();
    let (camera, extracted, target, settings, main_entity) = view.into_inner();
    let (Some(pipelines), Some(scene), Some(layers)) = (pipelines, scene, layers) else {
        return;
    };
    let Some(trace_pipeline) = pipeline_cache.get_compute_pipeline(pipelines.trace) else {
        return;
    };
    let viewport = extracted.viewport;
    if viewport.z == 0 || viewport.w == 0 {
        return;
    }
    let scale = if settings.resolution_scale.is_finite() {
        settings.resolution_scale.clamp(0.05, 4.0)
    } else {
        1.0
    };
    let size = (Vec2::new(viewport.z as f32, viewport.w as f32) * scale)
        .round()
        .as_uvec2()
        .max(UVec2::ONE);
    let clip_from_world = extracted
        .clip_from_world
        .unwrap_or_else(|| extracted.clip_from_view * extracted.world_from_view.affine().inverse());
    let world_from_clip = clip_from_world.inverse();
    let key = AccumulationKey {
        world_from_clip,
        scene_generation: scene.generation,
        tree_generation: if settings.view == DebugView::Heatmap {
            scene.tree_generation
        } else {
            0
        },
        settings: PathTraced {
            max_samples: 0,
            ..*settings
        },
        exposure: camera.exposure,
        size,
    };
    let device = ctx.render_device().clone();
    let state = states
        .0
        .entry(view_entity)
        .or_insert_with(|| view_state(&device, size));
    if state.size != size {
        *state = view_state(&device, size);
    }
    state.seen = true;
    if state.key != Some(key) {
        state.key = Some(key);
        state.samples = 0;
    }
    let spf = settings.samples_per_frame.clamp(1, 64);
    let done = settings.max_samples > 0 && state.samples >= settings.max_samples;
    let sky = settings.sky;
    if !done {
        let params = ViewParams {
            world_from_clip,
            sky: Vec3::new(sky.red, sky.green, sky.blue),
            exposure: camera.exposure,
            width: size.x,
            height: size.y,
            frame: state.samples,
            root: scene.root,
            max_bounces: settings.max_bounces.min(64),
            samples: spf,
            mode: settings.view.shader_index(),
            light_count: scene.light_count,
            indirect_clamp: settings.indirect_clamp.max(0.0),
        };
        queue.write_buffer(&state.view_uniform, 0, &params.to_bytes());
        let layout = pipeline_cache.get_bind_group_layout(&pipelines.trace_layout);
        let b = &scene.buffers;
        let bind_group = device.create_bind_group(
            "treelight path trace",
            &layout,
            &BindGroupEntries::sequential((
                b[0].as_entire_binding(),
                b[1].as_entire_binding(),
                b[2].as_entire_binding(),
                b[3].as_entire_binding(),
                b[4].as_entire_binding(),
                b[5].as_entire_binding(),
                state.view_uniform.as_entire_binding(),
                state.accum.as_entire_binding(),
                &layers.view,
                &layers.sampler,
            )),
        );
        let mut pass = ctx
            .command_encoder()
            .begin_compute_pass(&ComputePassDescriptor {
                label: Some("treelight path trace"),
                timestamp_writes: None,
            });
        pass.set_pipeline(trace_pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(size.x.div_ceil(8), size.y.div_ceil(8), 1);
        drop(pass);
        state.samples += spf;
    }
    // Debug views show a single sample's worth of data as well as the average.
    let shown = if settings.view == DebugView::PathTraced {
        state.samples
    } else {
        state.samples.max(1)
    };
    let msaa = target
        .sampled_main_texture()
        .map_or(1, |t| t.sample_count());
    let resolve_id =
        pipelines.resolve_pipeline(&pipeline_cache, target.main_texture_format(), msaa);
    let Some(resolve_pipeline) = pipeline_cache.get_render_pipeline(resolve_id) else {
        return;
    };
    queue.write_buffer(
        &state.resolve_uniform,
        0,
        &resolve_bytes(
            Vec2::new(viewport.x as f32, viewport.y as f32),
            Vec2::new(viewport.z as f32, viewport.w as f32),
            [size.x, size.y],
            shown,
        ),
    );
    let layout = pipeline_cache.get_bind_group_layout(&pipelines.resolve_layout);
    let bind_group = device.create_bind_group(
        "treelight resolve",
        &layout,
        &BindGroupEntries::sequential((
            state.accum.as_entire_binding(),
            state.resolve_uniform.as_entire_binding(),
        )),
    );
    let mut attachment = target.get_color_attachment();
    attachment.ops = Operations {
        load: LoadOp::Load,
        store: StoreOp::Store,
    };
    {
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
        pass.set_viewport(
            viewport.x as f32,
            viewport.y as f32,
            viewport.z as f32,
            viewport.w as f32,
            0.0,
            1.0,
        );
        pass.set_pipeline(resolve_pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
    let samples = state.samples;
    stats.update(|f| {
        f.samples.insert(main_entity.id(), samples);
    });
}
