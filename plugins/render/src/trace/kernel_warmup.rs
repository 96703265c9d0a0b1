//! The trace kernels' compiles, away from the views' queue. A software adapter (lavapipe)
//! compiles a compute kernel when a dispatch first uses it, on its queue's one thread, and every
//! later submission waits behind it: with a cold shader cache the whole-scene kernel takes most of
//! a minute to compile, the split one minutes, and an editor's frames would stop for as long. On
//! such an adapter each kernel's first dispatch is made instead on a second device of the same
//! adapter, on a thread of its own (at the frame's priority: the views wait for it), with textures
//! and samplers like the views'. The driver compiles a variant per texture state (its format and
//! kind, whether each side is a power of two, its mip levels), so stand-ins of one or three texels
//! a side serve for textures of any size, and a warm-up runs again when that state changes (a
//! panorama of another shape). The driver's shader cache then holds the compiled kernel, and the
//! views' device loads it from there. Views wait for their kernel; their frames, and the scene's
//! uploads, go on. An app may name a folder where warm-ups are recorded
//! ([`KernelCompileRecord`]): a later start on the same machine, driver, shader cache and binary
//! skips those, since with the driver's cache warm a warm-up only repeats the views' own work of
//! making the kernel, on the same few cores.

use crate::kernels::pipelines::{PathTracerPipelines, PathTracerShaders};
use crate::scene::texture_layers::TextureLayers;
use crate::sky::environment::GpuEnvironment;
use bevy::prelude::*;
use bevy::render::render_resource::{
    BindGroupEntry, BindingResource, BufferDescriptor, BufferUsages, ComputePassDescriptor,
    ComputePipelineDescriptor, PipelineCache, SamplerDescriptor, TextureDescriptor, TextureView,
    TextureViewDescriptor,
};
use bevy::render::renderer::{RenderAdapter, RenderAdapterInfo, RenderDevice};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;
use wgpu::{BindingType, BufferBindingType};

/// The trace kernels, by the records they read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TraceKernel {
    /// Each kind of record in one binding.
    Whole,
    /// Records split across bindings (a scene larger than one binding holds).
    Split,
}

impl TraceKernel {
    /// The kernel a scene split across bindings (`split`) or not is traced with.
    pub fn of(split: bool) -> Self {
        if split { Self::Split } else { Self::Whole }
    }

    /// Its WGSL.
    fn source(self) -> &'static str {
        match self {
            Self::Whole => crate::kernels::sources::PATHTRACE_WGSL,
            Self::Split => crate::kernels::sources::PATHTRACE_SPLIT_WGSL,
        }
    }
}

/// A folder where the path tracer records the kernels its warm-ups compiled into a software
/// adapter's shader cache (a file per kernel and texture state), so that later starts skip them.
/// Insert it into the main world before the app first updates (the editor gives a folder of its
/// cache); without it every start warms its kernels up. A record outlives the driver's cache only
/// if that is cleared by hand: the view then compiles its kernel once on its queue.
#[derive(Resource, Clone, Debug)]
pub struct KernelCompileRecord(pub PathBuf);

impl KernelCompileRecord {
    /// The file that records `kernel` compiled for `textures` on the driver `driver`, with this
    /// executable and this process's shader-cache settings.
    fn entry(&self, kernel: TraceKernel, textures: &TextureState, driver: &str) -> PathBuf {
        let mut h = blake3::Hasher::new();
        h.update(kernel.source().as_bytes());
        h.update(format!("{textures:?}\0{driver}\0").as_bytes());
        // Where Mesa keeps its cache, and whether it keeps one.
        for key in [
            "MESA_SHADER_CACHE_DIR",
            "MESA_SHADER_CACHE_DISABLE",
            "MESA_DISK_CACHE_SINGLE_FILE",
            "XDG_CACHE_HOME",
            "HOME",
        ] {
            let value = std::env::var_os(key).unwrap_or_default();
            h.update(key.as_bytes());
            h.update(value.as_encoded_bytes());
            h.update(b"\0");
        }
        // Another build may make another module of the same source (another naga).
        let exe = std::env::current_exe()
            .and_then(std::fs::metadata)
            .map(|m| format!("{:?} {}", m.modified().ok(), m.len()))
            .unwrap_or_default();
        h.update(exe.as_bytes());
        let name = h.finalize().to_hex();
        self.0
            .join(format!("{kernel:?}-{}", &name[..32]).to_lowercase())
    }
}

/// The state of the scene group's three textures (the texture layers, the panorama, its
/// distribution), as the driver compiles a kernel for it.
type TextureState = [TextureVariant; 3];

/// Where the trace kernels' warm-ups stand (render world).
#[derive(Resource)]
pub(crate) struct KernelWarmup {
    /// Whether this adapter needs them (a software adapter).
    needed: bool,
    /// The warm-up running: its kernel, and whether it has ended.
    running: Option<(TraceKernel, Arc<AtomicBool>)>,
    /// The texture state each kernel's latest warm-up compiled for (whole, split).
    warmed: [Option<TextureState>; 2],
    /// The texture state the views bind now.
    current: Option<TextureState>,
    /// Since when the views have waited, and for which kernel.
    waiting_since: Option<(TraceKernel, Instant)>,
    /// Where warm-ups are recorded, if the app keeps a record.
    record: Option<KernelCompileRecord>,
    /// The adapter's name and driver, part of a record's key.
    driver: String,
}

impl KernelWarmup {
    /// Whether a view may dispatch `kernel`: a warm-up of it for the textures bound now is over
    /// (or none is needed on this adapter; a failed one leaves the views' device to compile the
    /// kernel itself).
    pub fn ready(&self, kernel: TraceKernel) -> bool {
        if !self.needed {
            return true;
        }
        let running = self
            .running
            .as_ref()
            .is_some_and(|(k, done)| *k == kernel && !done.load(Ordering::Acquire));
        !running && self.current.is_some() && self.warmed[kernel as usize] == self.current
    }

    /// Notes whether the views wait for `kernel` this frame; the seconds they have waited so far
    /// when they do.
    pub fn wait(&mut self, kernel: TraceKernel) -> Option<f32> {
        if self.ready(kernel) {
            self.waiting_since = None;
            return None;
        }
        let since = match self.waiting_since {
            Some((k, since)) if k == kernel => since,
            _ => self.waiting_since.insert((kernel, Instant::now())).1,
        };
        Some(since.elapsed().as_secs_f32())
    }
}

pub(crate) fn build(render_app: &mut SubApp) {
    render_app.add_systems(bevy::render::RenderStartup, init_warmup);
}

fn init_warmup(
    mut commands: Commands,
    info: Res<RenderAdapterInfo>,
    record: Option<Res<KernelCompileRecord>>,
) {
    // Other adapters compile a kernel when its pipeline is made, which Bevy does off the frame.
    let needed = info.device_type == wgpu::DeviceType::Cpu;
    commands.insert_resource(KernelWarmup {
        needed,
        running: None,
        warmed: [None, None],
        current: None,
        waiting_since: None,
        record: record.map(|r| r.clone()),
        driver: format!("{} {} {}", info.name, info.driver, info.driver_info),
    });
}

/// What of a bound texture a software adapter compiles into a kernel that samples it (llvmpipe's
/// static texture state): its format and kind, whether each side is a power of two, its mip
/// levels, and an array's layers: one, or more and whether their count is a power of two. (A
/// stand-in of one layer for an array of five left the views' device to compile a kernel of its
/// own, on their queue, when a scene's textures came in; a stand-in of three layers served five;
/// one of a single layer did not serve eight. On such an adapter the texture layers are at least
/// two and counted in powers of two, so a scene's textures keep the state the kernel was warmed
/// up for at the start.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TextureVariant {
    binding: u32,
    format: wgpu::TextureFormat,
    dimension: wgpu::TextureDimension,
    view: Option<wgpu::TextureViewDimension>,
    /// Width and height.
    power_of_two: [bool; 2],
    /// A 3D texture's depth, or an array's layers.
    depth: DepthState,
    mip_levels: u32,
}

/// What of a texture's depth or layer count is in its state.
#[derive(Clone, Copy, Debug, PartialEq)]
enum DepthState {
    /// One (a 2D texture's, or an array of one layer).
    One,
    /// A power of two above one.
    PowerOfTwo,
    /// A count no power of two.
    Other,
}

impl DepthState {
    /// The state of a depth or layer count `n`.
    fn of(n: u32) -> Self {
        match n {
            1 => Self::One,
            n if n.is_power_of_two() => Self::PowerOfTwo,
            _ => Self::Other,
        }
    }
}

impl TextureVariant {
    /// The state of a texture described by `texture`, bound at `binding` through a view of
    /// `view` dimension.
    fn of(
        binding: u32,
        texture: &TextureDescriptor<'_>,
        view: Option<wgpu::TextureViewDimension>,
    ) -> Self {
        let size = texture.size;
        Self {
            binding,
            format: texture.format,
            dimension: texture.dimension,
            view,
            power_of_two: [size.width, size.height].map(u32::is_power_of_two),
            depth: DepthState::of(size.depth_or_array_layers),
            mip_levels: texture.mip_level_count,
        }
    }

    /// The smallest texture of this state: sides of 2^(levels-1) texels where a power of two,
    /// one more (at least 3) where not; a 3D texture's depth the same way; one layer, two, or three
    /// where the count is no power of two.
    fn stand_in(&self) -> (TextureDescriptor<'static>, TextureViewDescriptor<'static>) {
        let base = 1u32 << self.mip_levels.clamp(1, 16).saturating_sub(1);
        let side = |pot: bool| if pot { base } else { (base + 1).max(3) };
        let depth = match (self.dimension, self.depth) {
            (wgpu::TextureDimension::D3, DepthState::One) => 1,
            (wgpu::TextureDimension::D3, d) => side(d == DepthState::PowerOfTwo).max(2),
            (_, DepthState::One) => 1,
            (_, DepthState::PowerOfTwo) => 2,
            (_, DepthState::Other) => 3,
        };
        (
            TextureDescriptor {
                label: Some("treelight kernel warm-up"),
                size: wgpu::Extent3d {
                    width: side(self.power_of_two[0]),
                    height: side(self.power_of_two[1]),
                    depth_or_array_layers: depth,
                },
                mip_level_count: self.mip_levels,
                sample_count: 1,
                dimension: self.dimension,
                format: self.format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            TextureViewDescriptor {
                dimension: self.view,
                ..default()
            },
        )
    }
}

/// The textures and samplers of the scene group as a warm-up binds them, by binding.
struct Shapes {
    textures: TextureState,
    samplers: Vec<(u32, SamplerDescriptor<'static>)>,
}

/// The scene group's textures as the views bind them now.
fn texture_state(layers: &TextureLayers, environment: &GpuEnvironment) -> TextureState {
    let [env_image, _, env_cdf] = crate::types::bindings::ENVIRONMENT_BINDINGS;
    [
        variant(6, &layers.view, Some(wgpu::TextureViewDimension::D2Array)),
        variant(env_image, &environment.image, None),
        variant(env_cdf, &environment.distribution, None),
    ]
}

/// The scene group's samplers, by binding.
fn scene_samplers() -> Vec<(u32, SamplerDescriptor<'static>)> {
    let [_, env_sampler, _] = crate::types::bindings::ENVIRONMENT_BINDINGS;
    vec![
        (7, crate::scene::texture_layers::sampler_descriptor()),
        (env_sampler, crate::sky::environment::sampler_descriptor()),
    ]
}

fn variant(
    binding: u32,
    view: &TextureView,
    dimension: Option<wgpu::TextureViewDimension>,
) -> TextureVariant {
    let t = view.texture();
    TextureVariant::of(
        binding,
        &TextureDescriptor {
            label: None,
            size: t.size(),
            mip_level_count: t.mip_level_count(),
            sample_count: t.sample_count(),
            dimension: t.dimension(),
            format: t.format(),
            usage: t.usage(),
            view_formats: &[],
        },
        dimension,
    )
}

impl KernelWarmup {
    /// Starts a warm-up of `kernel` on its thread for the texture state `textures`, unless the
    /// record says an earlier start compiled it.
    fn start(
        &mut self,
        kernel: TraceKernel,
        adapter: &RenderAdapter,
        device: &RenderDevice,
        pipelines: &PathTracerPipelines,
        shaders: &PathTracerShaders,
        textures: TextureState,
    ) {
        let record = self
            .record
            .as_ref()
            .map(|r| r.entry(kernel, &textures, &self.driver));
        // Only a regular file is a record (a link or a pipe there is none of this editor's).
        if let Some(entry) = record
            .as_ref()
            .filter(|e| std::fs::symlink_metadata(e).is_ok_and(|m| m.is_file()))
        {
            info!(
                "the {kernel:?} trace kernel was compiled at an earlier start ({})",
                entry.display()
            );
            self.warmed[kernel as usize] = Some(textures);
            return;
        }
        self.warmed[kernel as usize] = Some(textures);
        let (descriptor, shader) = match kernel {
            TraceKernel::Whole => (
                pipelines.whole_trace_descriptor(),
                (
                    shaders.trace.id(),
                    crate::kernels::pipelines::whole_trace_shader(),
                ),
            ),
            TraceKernel::Split => (
                pipelines.split_trace_descriptor(),
                (
                    shaders.trace_split.id(),
                    crate::kernels::pipelines::split_trace_shader(),
                ),
            ),
        };
        let done = Arc::new(AtomicBool::new(false));
        self.running = Some((kernel, done.clone()));
        let shapes = Shapes {
            textures,
            samplers: scene_samplers(),
        };
        let adapter = adapter.clone();
        let (features, limits) = (device.features(), device.limits());
        let ended = done.clone();
        let spawned = std::thread::Builder::new()
            .name("treelight kernel warm-up".into())
            .spawn(move || {
                let started = Instant::now();
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    warm(adapter, features, limits, descriptor, shader, shapes)
                }))
                .unwrap_or_else(|_| Err("it panicked".into()));
                match result {
                    Ok(()) => {
                        info!(
                            "the {kernel:?} trace kernel was compiled in {:.1} s",
                            started.elapsed().as_secs_f64()
                        );
                        if let Some(entry) = record {
                            remember(&entry, kernel, started.elapsed().as_secs_f64());
                        }
                    }
                    // The views' device compiles it at its first dispatch instead.
                    Err(why) => warn!("the {kernel:?} trace kernel's warm-up failed: {why}"),
                }
                ended.store(true, Ordering::Release);
            });
        if spawned.is_err() {
            done.store(true, Ordering::Release);
        }
    }
}

/// Writes the record of a warm-up (what was compiled, for how long, when: for whoever opens it),
/// never through a link nor into a pipe or device planted under its name.
fn remember(entry: &std::path::Path, kernel: TraceKernel, seconds: f64) {
    use std::io::Write;
    let text = format!(
        "the {kernel:?} trace kernel, compiled in {seconds:.1} s at {:?}\n",
        std::time::SystemTime::now()
    );
    // Something else under the record's name (a link, a pipe): moved aside, never written
    // through or waited on.
    if std::fs::symlink_metadata(entry).is_ok_and(|m| !m.is_file()) {
        let mut aside = entry.as_os_str().to_owned();
        aside.push(".bad");
        if let Err(e) = std::fs::rename(entry, &aside) {
            warn!(
                "{}: not a record, and cannot be moved aside: {e}",
                entry.display()
            );
            return;
        }
        warn!(
            "{} was not a kernel record; it was moved to {}",
            entry.display(),
            std::path::Path::new(&aside).display()
        );
    }
    let written = entry
        .parent()
        .map_or(Ok(()), std::fs::create_dir_all)
        .and_then(|()| {
            let mut options = std::fs::OpenOptions::new();
            options.write(true).create(true).truncate(false);
            #[cfg(unix)]
            {
                use std::os::unix::fs::OpenOptionsExt;
                options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_NOCTTY);
            }
            let mut file = options.open(entry)?;
            if !file.metadata()?.is_file() {
                return Err(std::io::Error::other("it is not a regular file"));
            }
            file.set_len(0)?;
            file.write_all(text.as_bytes())
        });
    if let Err(e) = written {
        warn!(
            "cannot record the kernel's warm-up in {}: {e}",
            entry.display()
        );
    }
}

/// Makes a trace kernel on a second device and dispatches it once (a view of no tiles, so it
/// returns at once), waiting until the driver has compiled it.
fn warm(
    adapter: RenderAdapter,
    features: wgpu::Features,
    limits: wgpu::Limits,
    descriptor: ComputePipelineDescriptor,
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
        .map(|variant| {
            let (texture, view) = variant.stand_in();
            (
                variant.binding,
                device.create_texture(&texture).create_view(&view),
            )
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

/// Starts a warm-up of the kernel the scene is traced with when a path-traced view will want it
/// and none has compiled it for the textures bound now (at the start, once the scene is split
/// across bindings, when a texture's state changes, when a view turns path traced), one at a
/// time. Without a path-traced view nothing is warmed: the raster view's start keeps its cores.
#[allow(clippy::too_many_arguments)]
pub(crate) fn start_warmups(
    traced_views: Query<(), With<crate::types::view::PathTraced>>,
    warmup: Option<ResMut<KernelWarmup>>,
    scene: Res<crate::scene::gpu_scene::GpuScene>,
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
    if !warmup.needed || scene.too_large.is_some() || traced_views.is_empty() {
        return;
    }
    let textures = texture_state(&layers, &environment);
    warmup.current = Some(textures);
    if warmup
        .running
        .as_ref()
        .is_some_and(|(_, done)| !done.load(Ordering::Acquire))
    {
        return;
    }
    warmup.running = None;
    let kernel = TraceKernel::of(scene.split());
    if warmup.warmed[kernel as usize] == Some(textures) {
        return;
    }
    warmup.start(kernel, &adapter, &device, &pipelines, &shaders, textures);
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::render::renderer::WgpuWrapper;

    fn texture(
        size: [u32; 3],
        mip_level_count: u32,
        dimension: wgpu::TextureDimension,
        format: wgpu::TextureFormat,
    ) -> TextureDescriptor<'static> {
        TextureDescriptor {
            label: None,
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: size[2],
            },
            mip_level_count,
            sample_count: 1,
            dimension,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        }
    }

    /// The scene group's textures: five layers of 1024², a sky panorama of `sky` texels a side
    /// and its distribution.
    fn scene_textures(sky: u32) -> TextureState {
        use wgpu::TextureDimension::D2;
        let [env_image, _, env_cdf] = crate::types::bindings::ENVIRONMENT_BINDINGS;
        [
            TextureVariant::of(
                6,
                &texture([1024, 1024, 5], 1, D2, wgpu::TextureFormat::Rgba8Unorm),
                Some(wgpu::TextureViewDimension::D2Array),
            ),
            TextureVariant::of(
                env_image,
                &texture([sky, sky, 1], 1, D2, wgpu::TextureFormat::Rgba16Float),
                None,
            ),
            TextureVariant::of(
                env_cdf,
                &texture([2, 1, 1], 1, D2, wgpu::TextureFormat::R32Float),
                None,
            ),
        ]
    }

    /// A texture's state keeps what the driver compiles in (sides a power of two or not, layers one
    /// or a power of two or neither, mip levels, format) and drops its size, and its stand-in is a
    /// texture of the same state.
    #[test]
    fn textures_of_one_state_share_a_stand_in_of_that_state() {
        use wgpu::TextureDimension::{D2, D3};
        use wgpu::TextureFormat::{R32Float, Rgba8Unorm, Rgba16Float};
        let array = Some(wgpu::TextureViewDimension::D2Array);
        let cases = [
            (texture([1024, 1024, 37], 1, D2, Rgba8Unorm), array),
            (texture([128, 128, 2], 1, D2, Rgba8Unorm), array),
            (texture([1, 1, 1], 1, D2, Rgba16Float), None),
            (texture([4000, 2000, 1], 1, D2, Rgba16Float), None),
            (texture([3, 5, 1], 1, D2, R32Float), None),
            (texture([2048, 1000, 1], 11, D2, Rgba16Float), None),
            (texture([1000, 2048, 1], 11, D2, Rgba16Float), None),
            (texture([9, 8, 6], 4, D3, Rgba8Unorm), None),
            (texture([2, 2, 1], 2, D2, Rgba8Unorm), None),
            (texture([1024, 1024, 64], 1, D2, Rgba8Unorm), array),
            (texture([1024, 1024, 1], 1, D2, Rgba8Unorm), array),
            (texture([8, 8, 4], 4, D3, Rgba8Unorm), None),
            (texture([4, 4, 1], 3, D3, Rgba8Unorm), None),
        ];
        for (t, view) in &cases {
            let state = TextureVariant::of(6, t, *view);
            let (stand_in, stand_in_view) = state.stand_in();
            assert_eq!(
                TextureVariant::of(6, &stand_in, stand_in_view.dimension),
                state
            );
            let s = stand_in.size;
            let largest = s.width.max(s.height).max(match stand_in.dimension {
                D3 => s.depth_or_array_layers,
                _ => 1,
            });
            assert!(
                largest >= 1 << (t.mip_level_count - 1) && largest <= 3 << t.mip_level_count,
                "{t:?}: a stand-in of {s:?} cannot hold its levels, or is larger than it needs"
            );
        }
        let of = |i: usize| TextureVariant::of(6, &cases[i].0, cases[i].1);
        assert_eq!(
            of(1),
            of(9),
            "sizes, and layer counts that are powers of two alike, are not part of it"
        );
        assert_ne!(
            of(9),
            of(10),
            "one layer is not an array of a power of two of them"
        );
        assert_ne!(
            of(0),
            of(1),
            "a layer count no power of two is: the driver compiles it in"
        );
        assert_ne!(of(2), of(3), "a side no power of two is");
        assert_ne!(of(5), of(6), "which side is");
    }

    /// A view waits for its kernel while a warm-up of it runs or none has compiled it for the
    /// textures bound now, and not for the other kernel's warm-up; the wait is timed from its
    /// start, and starts over for the other kernel.
    #[test]
    fn views_wait_for_their_own_kernel_warmed_for_the_textures_bound_now() {
        let mut w = KernelWarmup {
            needed: true,
            running: None,
            warmed: [None, None],
            current: None,
            waiting_since: None,
            record: None,
            driver: String::new(),
        };
        assert!(!w.ready(TraceKernel::Whole), "nothing bound yet");
        w.current = Some(scene_textures(4));
        let done = Arc::new(AtomicBool::new(false));
        w.warmed[0] = Some(scene_textures(4));
        w.running = Some((TraceKernel::Whole, done.clone()));
        assert!(!w.ready(TraceKernel::Whole), "its warm-up runs");
        let first = w.wait(TraceKernel::Whole).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert!(w.wait(TraceKernel::Whole).unwrap() >= first + 0.015);
        assert!(!w.ready(TraceKernel::Split), "never warmed");
        assert!(
            w.wait(TraceKernel::Split).unwrap() < 0.015,
            "another kernel's wait starts anew"
        );
        done.store(true, Ordering::Release);
        assert!(w.ready(TraceKernel::Whole));
        assert_eq!(w.wait(TraceKernel::Whole), None);
        w.current = Some(scene_textures(16));
        assert!(
            w.ready(TraceKernel::Whole),
            "another size of the same state"
        );
        w.current = Some(scene_textures(15));
        assert!(
            !w.ready(TraceKernel::Whole),
            "a side no longer a power of two"
        );
        w.warmed[1] = Some(scene_textures(15));
        w.running = Some((TraceKernel::Split, Arc::new(AtomicBool::new(false))));
        assert!(!w.ready(TraceKernel::Split) && !w.ready(TraceKernel::Whole));
        w.warmed[0] = Some(scene_textures(15));
        assert!(
            w.ready(TraceKernel::Whole),
            "the split kernel's warm-up holds only its views"
        );
        w.needed = false;
        assert!(
            w.ready(TraceKernel::Split),
            "a hardware adapter waits for none"
        );
    }

    /// A record names a kernel, the textures' state and the driver: each of them apart, another
    /// file; all of them alike, the same.
    #[test]
    fn a_record_entry_is_one_per_kernel_texture_state_and_driver() {
        let dir =
            std::env::temp_dir().join(format!("treelight-kernel-record-{}", std::process::id()));
        let record = KernelCompileRecord(dir.clone());
        let entry = record.entry(TraceKernel::Whole, &scene_textures(4), "llvmpipe Mesa 1");
        assert_eq!(entry.parent(), Some(dir.as_path()));
        assert_eq!(
            entry,
            record.entry(TraceKernel::Whole, &scene_textures(64), "llvmpipe Mesa 1")
        );
        for other in [
            record.entry(TraceKernel::Split, &scene_textures(4), "llvmpipe Mesa 1"),
            record.entry(TraceKernel::Whole, &scene_textures(5), "llvmpipe Mesa 1"),
            record.entry(TraceKernel::Whole, &scene_textures(4), "llvmpipe Mesa 2"),
        ] {
            assert_ne!(entry, other);
        }
        assert!(!entry.is_file());
        remember(&entry, TraceKernel::Whole, 1.5);
        assert!(entry.is_file(), "written, its folder made");
        // A link planted under a record's name is moved aside, its target untouched.
        #[cfg(unix)]
        {
            let victim = dir.join("victim");
            std::fs::write(&victim, "kept").unwrap();
            let other = record.entry(TraceKernel::Split, &scene_textures(4), "llvmpipe Mesa 1");
            std::os::unix::fs::symlink(&victim, &other).unwrap();
            remember(&other, TraceKernel::Split, 1.5);
            assert_eq!(std::fs::read_to_string(&victim).unwrap(), "kept");
            assert!(std::fs::symlink_metadata(&other).unwrap().is_file());
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The warm-up's dispatch is one the device accepts and runs: every binding of both groups
    /// gets a resource of its kind, writable storage apart from read-only, each texture a
    /// stand-in of its state. (The whole-scene kernel stands in for the split one, which a cold
    /// shader cache takes minutes to compile on a software adapter.)
    #[test]
    fn a_kernel_is_dispatched_on_a_device_of_its_own() {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
        let adapter = bevy::tasks::block_on(instance.request_adapter(&default()))
            .expect("an adapter (Mesa's software Vulkan: mesa-vulkan-drivers)");
        let limits = adapter.limits();
        let shader = Handle::<Shader>::default();
        let descriptor = crate::kernels::pipelines::whole_trace_descriptor(
            &crate::kernels::pipelines::scene_layout(),
            &crate::kernels::pipelines::view_layout(),
            shader.clone(),
        );
        let shapes = Shapes {
            textures: scene_textures(1),
            samplers: scene_samplers(),
        };
        warm(
            RenderAdapter(Arc::new(WgpuWrapper::new(adapter))),
            wgpu::Features::empty(),
            limits,
            descriptor,
            (shader.id(), crate::kernels::pipelines::whole_trace_shader()),
            shapes,
        )
        .expect("the warm-up's dispatch");
    }
}
