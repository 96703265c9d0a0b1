//! The split trace kernel's first compile, away from the views' queue. A software adapter
//! (lavapipe) compiles a compute kernel when a dispatch first uses it, on its queue's one thread,
//! and every later submission waits behind it: with a cold shader cache the split kernel takes
//! minutes to compile, and an editor's frames would stop for as long. On such an adapter the
//! kernel's first dispatch is made instead on a second device of the same adapter, on a thread of
//! its own (at the frame's priority: the views wait for it), with textures and samplers shaped
//! like the views' (the driver compiles a variant per texture and sampler state). The driver's
//! shader cache then holds the compiled kernel, and the views' device loads it from there. Views
//! of a split scene wait for it; their frames, and the scene's uploads, go on.

use crate::environment::GpuEnvironment;
use crate::pipelines::{PathTracerPipelines, PathTracerShaders};
use crate::texture_layers::TextureLayers;
use bevy::prelude::*;
use bevy::render::render_resource::{
    BindGroupEntry, BindingResource, BufferDescriptor, BufferUsages, ComputePassDescriptor,
    PipelineCache, SamplerDescriptor, TextureDescriptor, TextureView, TextureViewDescriptor,
};
use bevy::render::renderer::{RenderAdapter, RenderAdapterInfo, RenderDevice};
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};
use wgpu::{BindingType, BufferBindingType};

const IDLE: u8 = 0;
const RUNNING: u8 = 1;
const DONE: u8 = 2;

/// Where the split kernel's warm-up stands (render world).
#[derive(Resource)]
pub(crate) struct SplitKernelWarmup {
    /// Whether this adapter needs it (a software adapter).
    needed: bool,
    state: Arc<AtomicU8>,
    /// The texture shapes the latest warm-up compiled for: the driver compiles the kernel again
    /// for others (a panorama or a texture array of another size), so the views wait again.
    warmed: Option<Vec<(u32, TextureShape)>>,
}

impl SplitKernelWarmup {
    /// Whether a view may dispatch the split kernel: the latest warm-up is over (or none is needed
    /// on this adapter; a failed one leaves the views' device to compile the kernel itself).
    pub fn ready(&self) -> bool {
        !self.needed || self.state.load(Ordering::Acquire) == DONE
    }
}

pub(crate) fn build(render_app: &mut SubApp) {
    render_app.add_systems(bevy::render::RenderStartup, init_warmup);
}

fn init_warmup(mut commands: Commands, info: Res<RenderAdapterInfo>) {
    // Other adapters compile a kernel when its pipeline is made, which Bevy does off the frame.
    let needed = info.device_type == wgpu::DeviceType::Cpu;
    commands.insert_resource(SplitKernelWarmup {
        needed,
        state: Arc::new(AtomicU8::new(IDLE)),
        warmed: None,
    });
}

/// A texture as a view of it is bound: what the driver's kernel variant depends on.
type TextureShape = (TextureDescriptor<'static>, TextureViewDescriptor<'static>);

/// The textures and samplers of the scene group as the views bind them, by binding.
struct Shapes {
    textures: Vec<(u32, TextureShape)>,
    samplers: Vec<(u32, SamplerDescriptor<'static>)>,
}

/// The scene group's textures as the views bind them now, by binding.
fn texture_shapes(
    layers: &TextureLayers,
    environment: &GpuEnvironment,
) -> Vec<(u32, TextureShape)> {
    let [env_image, _, env_cdf] = crate::ENVIRONMENT_BINDINGS;
    vec![
        (
            6,
            texture_shape(&layers.view, Some(wgpu::TextureViewDimension::D2Array)),
        ),
        (env_image, texture_shape(&environment.image, None)),
        (env_cdf, texture_shape(&environment.distribution, None)),
    ]
}

/// The scene group's samplers, by binding.
fn scene_samplers() -> Vec<(u32, SamplerDescriptor<'static>)> {
    let [_, env_sampler, _] = crate::ENVIRONMENT_BINDINGS;
    vec![
        (7, crate::texture_layers::sampler_descriptor()),
        (env_sampler, crate::environment::sampler_descriptor()),
    ]
}

fn texture_shape(
    view: &TextureView,
    dimension: Option<wgpu::TextureViewDimension>,
) -> TextureShape {
    let t = view.texture();
    (
        TextureDescriptor {
            label: Some("treelight kernel warm-up"),
            size: t.size(),
            mip_level_count: t.mip_level_count(),
            sample_count: t.sample_count(),
            dimension: t.dimension(),
            format: t.format(),
            usage: t.usage(),
            view_formats: &[],
        },
        TextureViewDescriptor {
            dimension,
            ..default()
        },
    )
}

impl SplitKernelWarmup {
    /// Starts a warm-up on its thread for the texture shapes `textures`.
    fn start(
        &mut self,
        adapter: &RenderAdapter,
        device: &RenderDevice,
        pipelines: &PathTracerPipelines,
        shaders: &PathTracerShaders,
        textures: Vec<(u32, TextureShape)>,
    ) {
        self.warmed = Some(textures.clone());
        self.state.store(RUNNING, Ordering::Release);
        let shapes = Shapes {
            textures,
            samplers: scene_samplers(),
        };
        let adapter = adapter.clone();
        let (features, limits) = (device.features(), device.limits());
        let descriptor = pipelines.split_trace_descriptor();
        let shader = (
            shaders.trace_split.id(),
            crate::pipelines::split_trace_shader(),
        );
        let state = self.state.clone();
        let spawned = std::thread::Builder::new()
            .name("treelight kernel warm-up".into())
            .spawn(move || {
                let started = std::time::Instant::now();
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    warm(adapter, features, limits, descriptor, shader, shapes)
                }))
                .unwrap_or_else(|_| Err("it panicked".into()));
                match result {
                    Ok(()) => info!(
                        "the split trace kernel was compiled in {:.1} s",
                        started.elapsed().as_secs_f64()
                    ),
                    // The views' device compiles it at its first dispatch instead.
                    Err(why) => warn!("the split trace kernel's warm-up failed: {why}"),
                }
                state.store(DONE, Ordering::Release);
            });
        if spawned.is_err() {
            self.state.store(DONE, Ordering::Release);
        }
    }
}

/// Makes the split kernel on a second device and dispatches it once (a view of no tiles, so it
/// returns at once), waiting until the driver has compiled it.
fn warm(
    adapter: RenderAdapter,
    features: wgpu::Features,
    limits: wgpu::Limits,
    descriptor: bevy::render::render_resource::ComputePipelineDescriptor,
    (shader_id, shader): (AssetId<Shader>, Shader),
    shapes: Shapes,
) -> Result<(), String> {
    let (device, queue) = bevy::tasks::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("treelight kernel warm-up"),
        required_features: features,
        required_limits: limits,
        // SAFETY: the features the views' device was made with, which Bevy requests this way.
        experimental_features: unsafe { wgpu::ExperimentalFeatures::enabled() },
        memory_hints: wgpu::MemoryHints::MemoryUsage,
        trace: wgpu::Trace::Off,
    }))
    .map_err(|e| format!("no second device: {e}"))?;
    let failed = Arc::new(std::sync::Mutex::new(None::<String>));
    let sink = failed.clone();
    device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
        sink.lock()
            .unwrap_or_else(|p| p.into_inner())
            .get_or_insert(e.to_string());
    }));
    let device = RenderDevice::from(device);
    // A cache of its own, so the module is made from the source exactly as the views' is.
    let mut cache = PipelineCache::new(device.clone(), adapter, true);
    cache.set_shader(shader_id, shader);
    let id = cache.queue_compute_pipeline(descriptor.clone());
    cache.process_queue();
    let pipeline = cache
        .get_compute_pipeline(id)
        .ok_or("the kernel did not build")?
        .clone();
    let uniform = device.create_buffer(&BufferDescriptor {
        label: Some("treelight kernel warm-up"),
        size: 16 << 10,
        usage: BufferUsages::UNIFORM,
        mapped_at_creation: false,
    });
    let views: Vec<(u32, TextureView)> = shapes
        .textures
        .iter()
        .map(|(binding, (texture, view))| {
            (*binding, device.create_texture(texture).create_view(view))
        })
        .collect();
    let samplers: Vec<_> = shapes
        .samplers
        .iter()
        .map(|(binding, s)| (*binding, device.create_sampler(s)))
        .collect();
    // A buffer per storage binding: one bound writable and read-only at once is refused.
    let storage: Vec<Vec<_>> = descriptor
        .layout
        .iter()
        .map(|layout| {
            layout
                .entries
                .iter()
                .map(|_| {
                    device.create_buffer(&BufferDescriptor {
                        label: Some("treelight kernel warm-up"),
                        size: 64 << 10,
                        usage: BufferUsages::STORAGE,
                        mapped_at_creation: false,
                    })
                })
                .collect()
        })
        .collect();
    let mut groups = Vec::new();
    for (layout, storage) in descriptor.layout.iter().zip(&storage) {
        let mut entries = Vec::new();
        for (entry, storage) in layout.entries.iter().zip(storage) {
            let resource = match entry.ty {
                BindingType::Buffer {
                    ty: BufferBindingType::Uniform,
                    ..
                } => uniform.as_entire_binding(),
                BindingType::Buffer { .. } => storage.as_entire_binding(),
                BindingType::Texture { .. } => BindingResource::TextureView(
                    &views
                        .iter()
                        .find(|(b, _)| *b == entry.binding)
                        .ok_or_else(|| format!("no texture for binding {}", entry.binding))?
                        .1,
                ),
                BindingType::Sampler(_) => BindingResource::Sampler(
                    &samplers
                        .iter()
                        .find(|(b, _)| *b == entry.binding)
                        .ok_or_else(|| format!("no sampler for binding {}", entry.binding))?
                        .1,
                ),
                ref other => return Err(format!("a binding of type {other:?}")),
            };
            entries.push(BindGroupEntry {
                binding: entry.binding,
                resource,
            });
        }
        groups.push(device.create_bind_group(
            "treelight kernel warm-up",
            &cache.get_bind_group_layout(layout),
            &entries,
        ));
    }
    let mut encoder = device.create_command_encoder(&default());
    {
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor::default());
        pass.set_pipeline(&pipeline);
        for (i, group) in groups.iter().enumerate() {
            pass.set_bind_group(i as u32, group, &[]);
        }
        pass.dispatch_workgroups(1, 1, 1);
    }
    queue.submit([encoder.finish()]);
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| format!("the dispatch did not finish: {e}"))?;
    match failed.lock().unwrap_or_else(|p| p.into_inner()).take() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Starts a warm-up once the scene is split across bindings, and again when the textures the
/// kernel binds change shape after one.
#[allow(clippy::too_many_arguments)]
pub(crate) fn start_when_split(
    warmup: Option<ResMut<SplitKernelWarmup>>,
    scene: Res<crate::prepare::GpuScene>,
    adapter: Res<RenderAdapter>,
    device: Res<RenderDevice>,
    pipelines: Option<Res<PathTracerPipelines>>,
    shaders: Res<PathTracerShaders>,
    layers: Option<Res<TextureLayers>>,
    environment: Option<Res<GpuEnvironment>>,
) {
    let (Some(mut warmup), Some(pipelines), Some(layers), Some(environment)) =
        (warmup, pipelines, layers, environment)
    else {
        return;
    };
    if !warmup.needed || !scene.split() || warmup.state.load(Ordering::Acquire) == RUNNING {
        return;
    }
    let textures = texture_shapes(&layers, &environment);
    if warmup.warmed.as_ref() != Some(&textures) {
        warmup.start(&adapter, &device, &pipelines, &shaders, textures);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::render::renderer::WgpuWrapper;

    fn texture(
        size: [u32; 3],
        format: wgpu::TextureFormat,
        dimension: Option<wgpu::TextureViewDimension>,
    ) -> (TextureDescriptor<'static>, TextureViewDescriptor<'static>) {
        (
            TextureDescriptor {
                label: None,
                size: wgpu::Extent3d {
                    width: size[0],
                    height: size[1],
                    depth_or_array_layers: size[2],
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            TextureViewDescriptor {
                dimension,
                ..default()
            },
        )
    }

    /// The warm-up's dispatch is one the device accepts and runs: every binding of both groups
    /// gets a resource of its kind, writable storage apart from read-only. (The whole-scene kernel
    /// over the same groups stands in for the split one, which a cold shader cache takes minutes
    /// to compile on a software adapter.)
    #[test]
    fn a_kernel_is_dispatched_on_a_device_of_its_own() {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
        let adapter = bevy::tasks::block_on(instance.request_adapter(&default()))
            .expect("an adapter (Mesa's software Vulkan: mesa-vulkan-drivers)");
        let limits = adapter.limits();
        let shader = Handle::<Shader>::default();
        let descriptor = crate::pipelines::compute_pipeline(
            "treelight path trace",
            vec![
                crate::pipelines::scene_layout(),
                crate::pipelines::view_layout(),
            ],
            shader.clone(),
            "path_trace",
        );
        let [env_image, _, env_cdf] = crate::ENVIRONMENT_BINDINGS;
        let shapes = Shapes {
            textures: vec![
                (
                    6,
                    texture(
                        [4, 4, 1],
                        wgpu::TextureFormat::Rgba8Unorm,
                        Some(wgpu::TextureViewDimension::D2Array),
                    ),
                ),
                (
                    env_image,
                    texture([1, 1, 1], wgpu::TextureFormat::Rgba16Float, None),
                ),
                (
                    env_cdf,
                    texture([2, 1, 1], wgpu::TextureFormat::R32Float, None),
                ),
            ],
            samplers: scene_samplers(),
        };
        let whole = Shader::from_wgsl(crate::PATHTRACE_WGSL, "treelight/pathtrace.wgsl");
        warm(
            RenderAdapter(Arc::new(WgpuWrapper::new(adapter))),
            wgpu::Features::empty(),
            limits,
            descriptor,
            (shader.id(), whole),
            shapes,
        )
        .expect("the warm-up's dispatch");
    }
}
