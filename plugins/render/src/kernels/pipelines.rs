//! The kernels' shaders, bind group layouts and pipelines, made once at render startup. The trace
//! kernel binds two groups: the scene (records and textures, shared by every view) and the view
//! (its uniform, its accumulation, its depth and preview).

use crate::types::parts::part_bindings;
use crate::types::upload::BufferKind;
use bevy::core_pipeline::core_3d::CORE_3D_DEPTH_FORMAT;
use bevy::prelude::*;
use bevy::render::RenderStartup;
use bevy::render::render_resource::BindGroupLayoutEntry;
use bevy::render::render_resource::binding_types::{
    sampler, storage_buffer_read_only_sized, storage_buffer_sized, texture_2d, texture_2d_array,
    uniform_buffer_sized,
};
use bevy::render::render_resource::{
    BindGroupLayoutDescriptor, BindGroupLayoutEntries, CachedComputePipelineId,
    CachedRenderPipelineId, ColorTargetState, ColorWrites, CompareFunction,
    ComputePipelineDescriptor, DepthStencilState, FragmentState, MultisampleState, PipelineCache,
    RenderPipelineDescriptor, SamplerBindingType, ShaderStages, TextureFormat, TextureSampleType,
    VertexState,
};
use bevy::render::renderer::RenderDevice;
use std::collections::HashMap;
use std::sync::Mutex;

/// The kernels' shader assets.
#[derive(Resource, Clone)]
pub(crate) struct PathTracerShaders {
    pub trace: Handle<Shader>,
    /// The trace kernel over records split across bindings.
    pub trace_split: Handle<Shader>,
    pub resolve: Handle<Shader>,
    pub denoise: Handle<Shader>,
    pub temporal: Handle<Shader>,
    pub texture_layer: Handle<Shader>,
}

pub(crate) fn build(render_app: &mut SubApp) {
    render_app.add_systems(RenderStartup, init_pipelines);
}

/// Layouts and pipelines of the trace and resolve passes.
#[derive(Resource)]
pub(crate) struct PathTracerPipelines {
    /// Group 0 of the trace kernel: the record buffers (the split kinds' parts at
    /// [`part_bindings`]), the texture array and its sampler, the per-map UV transforms, the energy
    /// table, the panorama sky.
    pub scene_layout: BindGroupLayoutDescriptor,
    /// Group 1 of the trace kernel: the view uniform, the accumulation, the depth and preview, and
    /// the denoiser's guides.
    pub view_layout: BindGroupLayoutDescriptor,
    /// The resolve pass's group: the accumulation, the depth, objects and preview, its uniform,
    /// the scene's outline bits, the denoiser's result, the guides and the temporal pass's picture.
    pub resolve_layout: BindGroupLayoutDescriptor,
    /// A denoiser pass's group: the accumulation, aux, the pass's uniform, its source and target,
    /// the guides, the taps the first pass keeps for the others.
    pub denoise_layout: BindGroupLayoutDescriptor,
    /// The denoiser's pass.
    pub denoise: CachedComputePipelineId,
    /// The temporal pass's group: the accumulation, aux, its uniform, the denoiser's result, the
    /// guides, the last frame's picture, this frame's, the prior.
    pub temporal_layout: BindGroupLayoutDescriptor,
    /// The temporal pass.
    pub temporal: CachedComputePipelineId,
    /// The trace kernel for a scene whose records fit one binding each.
    trace: CachedComputePipelineId,
    /// The trace kernel over split records, queued when a scene first needs it.
    trace_split: Mutex<Option<CachedComputePipelineId>>,
    trace_shader: Handle<Shader>,
    trace_split_shader: Handle<Shader>,
    resolve_shader: Handle<Shader>,
    /// Resolve pipelines by target format, sample count and whether they write depth.
    resolve: Mutex<HashMap<(TextureFormat, u32, bool), CachedRenderPipelineId>>,
}

fn init_pipelines(
    mut commands: Commands,
    shaders: Res<PathTracerShaders>,
    pipeline_cache: Res<PipelineCache>,
    device: Res<RenderDevice>,
) {
    if crate::types::parts::too_few_bindings(&device).is_some() {
        // The kernel cannot be made here (the scene says why): without pipelines nothing is traced.
        return;
    }
    let scene_layout = scene_layout();
    let view_layout = view_layout();
    let resolve_layout = BindGroupLayoutDescriptor::new(
        "treelight resolve",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
            ),
        ),
    );
    let temporal_layout = BindGroupLayoutDescriptor::new(
        "treelight temporal",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
    );
    let temporal = pipeline_cache.queue_compute_pipeline(compute_pipeline(
        "treelight temporal",
        vec![temporal_layout.clone()],
        shaders.temporal.clone(),
        "temporal",
    ));
    let denoise_layout = BindGroupLayoutDescriptor::new(
        "treelight denoise",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
    );
    let denoise = pipeline_cache.queue_compute_pipeline(compute_pipeline(
        "treelight denoise",
        vec![denoise_layout.clone()],
        shaders.denoise.clone(),
        "denoise",
    ));
    let trace = pipeline_cache.queue_compute_pipeline(whole_trace_descriptor(
        &scene_layout,
        &view_layout,
        shaders.trace.clone(),
    ));
    commands.insert_resource(PathTracerPipelines {
        scene_layout,
        view_layout,
        resolve_layout,
        denoise_layout,
        denoise,
        temporal_layout,
        temporal,
        trace,
        trace_split: Mutex::new(None),
        trace_shader: shaders.trace.clone(),
        trace_split_shader: shaders.trace_split.clone(),
        resolve_shader: shaders.resolve.clone(),
        resolve: Mutex::new(HashMap::new()),
    });
}

/// Group 0 of the trace kernel ([`PathTracerPipelines::scene_layout`]).
pub(crate) fn scene_layout() -> BindGroupLayoutDescriptor {
    // Each kind's parts (`parts::part_bindings`), then the texture array and its sampler.
    let mut scene_entries: Vec<BindGroupLayoutEntry> = BufferKind::ALL
        .iter()
        .flat_map(|&k| part_bindings(k).iter())
        .map(|&binding| {
            storage_buffer_read_only_sized(false, None).build(binding, ShaderStages::COMPUTE)
        })
        .collect();
    scene_entries.push(
        texture_2d_array(TextureSampleType::Float { filterable: true })
            .build(6, ShaderStages::COMPUTE),
    );
    scene_entries.push(sampler(SamplerBindingType::Filtering).build(7, ShaderStages::COMPUTE));
    scene_entries.push(storage_buffer_read_only_sized(false, None).build(
        crate::types::map_transforms::MAP_TRANSFORMS_BINDING,
        ShaderStages::COMPUTE,
    ));
    scene_entries.push(
        uniform_buffer_sized(false, None)
            .build(crate::types::energy::ENERGY_BINDING, ShaderStages::COMPUTE),
    );
    let [env_image, env_sampler, env_cdf] = crate::types::bindings::ENVIRONMENT_BINDINGS;
    scene_entries.push(
        texture_2d(TextureSampleType::Float { filterable: true })
            .build(env_image, ShaderStages::COMPUTE),
    );
    scene_entries
        .push(sampler(SamplerBindingType::Filtering).build(env_sampler, ShaderStages::COMPUTE));
    scene_entries.push(
        texture_2d(TextureSampleType::Float { filterable: false })
            .build(env_cdf, ShaderStages::COMPUTE),
    );
    scene_entries.sort_by_key(|e| e.binding);
    BindGroupLayoutDescriptor::new("treelight scene", &scene_entries)
}

/// Group 1 of the trace kernel ([`PathTracerPipelines::view_layout`]).
pub(crate) fn view_layout() -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new(
        "treelight view",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer_sized(false, None),
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
    )
}

/// The whole-scene trace kernel's shader asset.
pub(crate) fn whole_trace_shader() -> Shader {
    Shader::from_wgsl(
        crate::kernels::sources::PATHTRACE_WGSL,
        "treelight/pathtrace.wgsl",
    )
}

/// The whole-scene trace kernel's pipeline over `scene` and `view`.
pub(crate) fn whole_trace_descriptor(
    scene: &BindGroupLayoutDescriptor,
    view: &BindGroupLayoutDescriptor,
    shader: Handle<Shader>,
) -> ComputePipelineDescriptor {
    compute_pipeline(
        "treelight path trace",
        vec![scene.clone(), view.clone()],
        shader,
        "path_trace",
    )
}

/// The split trace kernel's shader asset.
pub(crate) fn split_trace_shader() -> Shader {
    Shader::from_wgsl(
        crate::kernels::sources::PATHTRACE_SPLIT_WGSL,
        "treelight/pathtrace_split.wgsl",
    )
}

/// A compute pipeline of `shader`'s `entry` over `layout`.
pub(crate) fn compute_pipeline(
    label: &'static str,
    layout: Vec<BindGroupLayoutDescriptor>,
    shader: Handle<Shader>,
    entry: &'static str,
) -> ComputePipelineDescriptor {
    ComputePipelineDescriptor {
        label: Some(label.into()),
        layout,
        shader,
        entry_point: Some(entry.into()),
        ..default()
    }
}

impl PathTracerPipelines {
    /// The trace kernel for a scene split across bindings (`split`) or not; the split one is
    /// queued on first use.
    pub fn trace_pipeline(&self, cache: &PipelineCache, split: bool) -> CachedComputePipelineId {
        if !split {
            return self.trace;
        }
        let mut id = self.trace_split.lock().unwrap_or_else(|p| p.into_inner());
        *id.get_or_insert_with(|| cache.queue_compute_pipeline(self.split_trace_descriptor()))
    }

    /// The whole-scene trace kernel's pipeline (`kernel_warmup.rs` makes it on a second device
    /// too).
    pub fn whole_trace_descriptor(&self) -> ComputePipelineDescriptor {
        whole_trace_descriptor(
            &self.scene_layout,
            &self.view_layout,
            self.trace_shader.clone(),
        )
    }

    /// The split trace kernel's pipeline (`kernel_warmup.rs` makes it on a second device too).
    pub fn split_trace_descriptor(&self) -> ComputePipelineDescriptor {
        compute_pipeline(
            "treelight path trace, split records",
            vec![self.scene_layout.clone(), self.view_layout.clone()],
            self.trace_split_shader.clone(),
            "path_trace",
        )
    }

    /// The resolve pipeline for a target of `format` with `samples` samples, writing the view's
    /// depth buffer too when `depth`, queued on first use.
    pub fn resolve_pipeline(
        &self,
        cache: &PipelineCache,
        format: TextureFormat,
        samples: u32,
        depth: bool,
    ) -> CachedRenderPipelineId {
        let mut map = self.resolve.lock().unwrap_or_else(|p| p.into_inner());
        *map.entry((format, samples, depth)).or_insert_with(|| {
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
                    entry_point: Some(if depth { "fragment_depth" } else { "fragment" }.into()),
                    targets: vec![Some(ColorTargetState {
                        format,
                        blend: None,
                        write_mask: ColorWrites::ALL,
                    })],
                    ..default()
                }),
                // Every traced pixel's depth replaces what is there.
                depth_stencil: depth.then(|| DepthStencilState {
                    format: CORE_3D_DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(CompareFunction::Always),
                    stencil: default(),
                    bias: default(),
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
