//! Prepare, the views: each path-traced view's buffers, uniforms and bind groups, with the share of
//! its work that fits this frame's budget: what the node is to dispatch and draw.

use crate::kernels::pipelines::PathTracerPipelines;
use crate::scene::gpu_scene::{GpuScene, max_binding_bytes, size_text};
use crate::scene::texture_layers::TextureLayers;
use crate::sky::environment::ExtractedEnvironment;
use crate::trace::kernel_warmup::{KernelWarmup, TraceKernel};
use crate::trace::timing::TraceTimer;
use crate::types::budget::{TILE, TileCursor, TileOrder, TraceClock, preview_scale};
use crate::types::figures::PathTracerStats;
use crate::types::figures::TraceFigures;
use crate::types::records::{ResolveParams, TemporalRestart, TraceWork, VIEW_BYTES, ViewParams};
use crate::types::upload::BufferKind;
use crate::types::view::DebugView;
use crate::types::view::OutlineStyle;
use crate::types::view::PathTraced;
use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, Buffer, BufferDescriptor, BufferInitDescriptor, BufferUsages,
    CachedComputePipelineId, CachedPipelineState, CachedRenderPipelineId, PipelineCache,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::sync_world::MainEntity;
use bevy::render::view::{ExtractedView, ViewDepthTexture, ViewTarget};
use bevy::render::{Render, RenderSystems};
use std::collections::HashMap;
use std::time::Instant;

pub(crate) fn build(render_app: &mut SubApp) {
    render_app.init_resource::<ViewStates>().add_systems(
        Render,
        (
            (crate::trace::kernel_warmup::start_warmups, prepare_views)
                .chain()
                .after(crate::scene::gpu_scene::prepare_scene_bind_group)
                .in_set(RenderSystems::PrepareBindGroups),
            (request_timings, forget_views)
                .chain()
                .in_set(RenderSystems::Cleanup),
        ),
    );
}
/// The view's clip-to-world matrix relative to the camera's position, and that position: made
/// from the projection and the camera's rotation alone, so rays keep their directions however
/// far from the world's origin the camera stands (the whole matrix's inverse, at 1e7 units out,
/// rounds a ray's near and far points to the same few units). A view with its own clip-from-world
/// matrix keeps it whole.
fn camera_relative(extracted: &bevy::render::view::ExtractedView) -> (Mat4, Vec3) {
    if let Some(clip_from_world) = extracted.clip_from_world {
        return (clip_from_world.inverse(), Vec3::ZERO);
    }
    let mut world_from_view = extracted.world_from_view.affine();
    let origin = Vec3::from(world_from_view.translation);
    world_from_view.translation = bevy::math::Vec3A::ZERO;
    (
        Mat4::from(world_from_view) * extracted.clip_from_view.inverse(),
        origin,
    )
}

/// What a view's accumulated samples depend on: any change restarts the accumulation.
#[derive(Clone, Copy, PartialEq)]
struct AccumulationKey {
    world_from_clip: Mat4,
    scene_generation: u64,
    texture_generation: u64,
    /// Only for the heatmap, which shows the tree itself.
    tree_generation: u64,
    /// The panorama uploaded, and its uniform word.
    environment: (u64, Vec4),
    /// The settings that change the image (not the sample limit or the budget).
    settings: PathTraced,
    exposure: f32,
    size: UVec2,
}

/// What the node does for a view this frame.
pub(crate) struct ViewFrame {
    /// The trace kernel for the scene's buffers (split across bindings or not).
    pub trace_pipeline: CachedComputePipelineId,
    /// Workgroups of the trace dispatch; `None` when the view has all its samples.
    pub dispatch: Option<UVec2>,
    /// Whether the accumulation restarts: the node clears it before the dispatch.
    pub clear: bool,
    /// The timer slot the pass writes its timestamps to.
    pub timing: Option<usize>,
    /// The resolve pipeline for the view's target.
    pub resolve_pipeline: CachedRenderPipelineId,
    /// Whether the resolve writes the view's depth buffer too.
    pub writes_depth: bool,
    /// The camera's viewport in target pixels: x, y, width, height.
    pub viewport: UVec4,
    /// The denoiser's pass this frame, when one runs (after the trace).
    pub denoise: Option<DenoisePass>,
    /// The temporal pass's pipeline, when it runs this frame (after the denoiser; not while the
    /// view is idle).
    pub temporal: Option<CachedComputePipelineId>,
    /// Which of the view's two pictures the resolve shows this frame (the one the temporal pass
    /// writes when it runs): the bind groups' index.
    pub parity: usize,
}

/// One pass of the denoiser: its pipeline, which pass of how many.
#[derive(Clone, Copy)]
pub(crate) struct DenoisePass {
    pub pipeline: CachedComputePipelineId,
    pub pass: u32,
    pub passes: u32,
}

/// A run of the denoiser over one picture of a view, one pass a frame: on a software adapter
/// its passes together cost more than a frame's trace, and a frame that carried them all would
/// stall the editor. Each pass reads what the one before wrote, and the first the samples then
/// accumulated; the samples traced meanwhile wait for the next run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct DenoiseRun {
    /// The sweeps over the image when its first pass ran: what its result is of.
    pub sweeps: u64,
    /// Its passes ([`crate::types::records::denoise_passes`] of the samples then).
    pub passes: u32,
    /// The pass it makes next.
    pub next: u32,
}

impl DenoiseRun {
    /// The run to start after `sweeps` sweeps of `samples_per_sweep` samples, if one is due: when
    /// none is in progress, and the sweeps have passed a power of two since the last result was
    /// made (`done`, its sweeps; the result improves most early) or reached the view's limit
    /// (`limit` samples, 0 for none).
    pub fn due(sweeps: u64, samples_per_sweep: u64, done: Option<u64>, limit: u64) -> Option<Self> {
        if sweeps == 0 {
            return None;
        }
        let done = done.unwrap_or(0);
        let risen = 1u64 << sweeps.ilog2() > done;
        let at_limit = limit > 0 && sweeps * samples_per_sweep >= limit && done != sweeps;
        (risen || at_limit).then(|| Self {
            sweeps,
            passes: crate::types::records::denoise_passes(sweeps * samples_per_sweep),
            next: 0,
        })
    }

    /// This frame's pass, and the run after it (`None` once it made its last pass).
    pub fn step(self) -> (u32, Option<Self>) {
        let next = Self {
            next: self.next + 1,
            ..self
        };
        (self.next, (next.next < self.passes).then_some(next))
    }
}

/// A view's buffers, made for one size: the accumulation (per pixel the sum of its samples and their
/// count), the primary hits' depth and object slots with the preview after them, the uniforms and
/// the bind groups over them.
pub(crate) struct ViewBuffers {
    /// Cleared by the node when the accumulation restarts.
    pub accum: Buffer,
    aux: Buffer,
    view_uniform: Buffer,
    resolve_params: Buffer,
    /// The denoiser's result (the first) and its two working images.
    denoised: [Buffer; crate::types::records::DENOISE_IMAGES],
    /// What the trace keeps for the denoiser: five words a pixel.
    guides: Buffer,
    /// Group 1 of the trace kernel.
    pub trace_bind_group: BindGroup,
    /// The denoiser's passes' groups, in order, the `t`-th writing image `t`.
    pub denoise_bind_groups: Vec<[BindGroup; crate::types::records::DENOISE_IMAGES]>,
    /// The temporal pass's pictures: the one each frame writes, the other the last frame's; per
    /// pixel rgb and weight in half floats, depth and object slot (as large as the accumulation).
    shown: [Buffer; 2],
    temporal_params: Buffer,
    /// The temporal pass's groups: the `k`-th writes picture `k`, reading the other.
    pub temporal_bind_groups: [BindGroup; 2],
    /// The resolve pass's groups: the `k`-th shows picture `k`.
    pub resolve_bind_groups: [BindGroup; 2],
    /// The scene's outline buffer version the resolve group was made with.
    outline_version: u64,
    size: UVec2,
}

/// One path-traced view's GPU state and its place in the frame budget.
pub(crate) struct ViewState {
    /// Remade when the view's size changes.
    pub buffers: ViewBuffers,
    order: TileOrder,
    cursor: TileCursor,
    clock: TraceClock,
    /// `None` where the adapter has no timestamp queries.
    pub timer: Option<TraceTimer>,
    key: Option<AccumulationKey>,
    /// The scale of the preview traced since the last restart; 0 when none was.
    preview_scale: u32,
    preview_seed: u32,
    /// When the previous frame was prepared, and the pixel samples it traced.
    last_frame: Option<(Instant, u64)>,
    seen: bool,
    /// This frame's work, when the trace pipeline is ready.
    pub frame: Option<ViewFrame>,
    /// The sweeps over the image the denoiser's result is of; `None` since the last restart until
    /// a run completes.
    denoised_sweeps: Option<u64>,
    /// The denoiser's run in progress, one pass a frame.
    denoise_run: Option<DenoiseRun>,
    /// The picture the temporal pass writes next; the other holds the last frame's.
    parity: usize,
    /// The camera the last frame's picture was seen through (its clip from world), when the
    /// temporal pass made it (it can be carried over).
    last_picture: Option<Mat4>,
}

/// Per-view state, by render-world view entity.
#[derive(Resource, Default)]
pub(crate) struct ViewStates(pub HashMap<Entity, ViewState>);

fn uniform(device: &RenderDevice, label: &'static str, size: u64) -> Buffer {
    device.create_buffer(&BufferDescriptor {
        label: Some(label),
        size,
        usage: BufferUsages::UNIFORM | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn storage(device: &RenderDevice, label: &'static str, size: u64) -> Buffer {
    device.create_buffer(&BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn resolve_group(
    device: &RenderDevice,
    pipelines: &PathTracerPipelines,
    cache: &PipelineCache,
    [accum, aux, uniform, denoised, guides, shown]: [&Buffer; 6],
    scene: &GpuScene,
) -> BindGroup {
    device.create_bind_group(
        "treelight resolve",
        &cache.get_bind_group_layout(&pipelines.resolve_layout),
        &BindGroupEntries::sequential((
            accum.as_entire_binding(),
            aux.as_entire_binding(),
            uniform.as_entire_binding(),
            scene.outlines.as_entire_binding(),
            denoised.as_entire_binding(),
            guides.as_entire_binding(),
            shown.as_entire_binding(),
        )),
    )
}

/// Both resolve groups of a view: the `k`-th shows picture `k` of `shown`.
fn resolve_groups(
    device: &RenderDevice,
    pipelines: &PathTracerPipelines,
    cache: &PipelineCache,
    [accum, aux, uniform, denoised, guides]: [&Buffer; 5],
    shown: &[Buffer; 2],
    scene: &GpuScene,
) -> [BindGroup; 2] {
    [0, 1].map(|k| {
        resolve_group(
            device,
            pipelines,
            cache,
            [accum, aux, uniform, denoised, guides, &shown[k]],
            scene,
        )
    })
}

fn view_buffers(
    device: &RenderDevice,
    pipelines: &PathTracerPipelines,
    cache: &PipelineCache,
    size: UVec2,
    scene: &GpuScene,
) -> ViewBuffers {
    let pixels = size.x as u64 * size.y as u64;
    let accum = storage(device, "treelight accumulation", pixels * 16);
    let aux = storage(
        device,
        "treelight depth, objects and preview",
        crate::types::records::aux_bytes(size.x, size.y),
    );
    let guides = storage(
        device,
        "treelight denoiser guides",
        crate::types::records::guide_bytes(size.x, size.y),
    );
    let denoised = [0; crate::types::records::DENOISE_IMAGES]
        .map(|_| storage(device, "treelight denoised", pixels * 16));
    let denoise_taps = storage(
        device,
        "treelight denoiser taps",
        crate::types::records::denoise_tap_bytes(size.x, size.y),
    );
    let view_uniform = uniform(device, "treelight view", VIEW_BYTES);
    // The per-frame passes' parameters are storage buffers, not uniform ones: lavapipe (Mesa 22)
    // inlines the uniform values a shader's branches test, compiling a new variant at every bind
    // where that halves the shader and never freeing the last, so a pass bound every frame with
    // uniform flags grew the heap by megabytes a frame.
    let resolve_params = storage(
        device,
        "treelight resolve",
        size_of::<crate::types::records::GpuResolve>() as u64,
    );
    let trace_bind_group = device.create_bind_group(
        "treelight view",
        &cache.get_bind_group_layout(&pipelines.view_layout),
        &BindGroupEntries::sequential((
            view_uniform.as_entire_binding(),
            accum.as_entire_binding(),
            aux.as_entire_binding(),
            guides.as_entire_binding(),
        )),
    );
    let shown = [
        storage(device, "treelight temporal picture", pixels * 16),
        storage(device, "treelight temporal picture", pixels * 16),
    ];
    // Per pixel (rgb, weight); its bind groups keep it.
    let prior = storage(device, "treelight temporal prior", pixels * 16);
    let temporal_params = storage(
        device,
        "treelight temporal",
        size_of::<crate::types::records::GpuTemporal>() as u64,
    );
    let temporal_bind_groups = [0, 1].map(|k| {
        device.create_bind_group(
            "treelight temporal",
            &cache.get_bind_group_layout(&pipelines.temporal_layout),
            &BindGroupEntries::sequential((
                accum.as_entire_binding(),
                aux.as_entire_binding(),
                temporal_params.as_entire_binding(),
                denoised[0].as_entire_binding(),
                guides.as_entire_binding(),
                shown[1 - k].as_entire_binding(),
                shown[k].as_entire_binding(),
                prior.as_entire_binding(),
            )),
        )
    });
    // Pass k writes any image (reading the one `denoise_source` names): the last pass of a run
    // writes the first.
    let denoise_bind_groups = (0..crate::types::records::DENOISE_PASSES)
        .map(|k| {
            let pass_params = device.create_buffer_with_data(&BufferInitDescriptor {
                label: Some("treelight denoise pass"),
                contents: &crate::types::records::denoise_pass_bytes(size.x, size.y, k),
                // Not a uniform buffer, as for the resolve's parameters above.
                usage: BufferUsages::STORAGE,
            });
            std::array::from_fn(|target| {
                device.create_bind_group(
                    "treelight denoise",
                    &cache.get_bind_group_layout(&pipelines.denoise_layout),
                    &BindGroupEntries::sequential((
                        accum.as_entire_binding(),
                        aux.as_entire_binding(),
                        pass_params.as_entire_binding(),
                        denoised[crate::types::records::denoise_source(target)].as_entire_binding(),
                        denoised[target].as_entire_binding(),
                        guides.as_entire_binding(),
                        denoise_taps.as_entire_binding(),
                    )),
                )
            })
        })
        .collect();
    let resolve_bind_groups = resolve_groups(
        device,
        pipelines,
        cache,
        [&accum, &aux, &resolve_params, &denoised[0], &guides],
        &shown,
        scene,
    );
    ViewBuffers {
        accum,
        aux,
        view_uniform,
        resolve_params,
        denoised,
        guides,
        denoise_bind_groups,
        trace_bind_group,
        shown,
        temporal_params,
        temporal_bind_groups,
        resolve_bind_groups,
        outline_version: scene.outline_version,
        size,
    }
}

impl ViewBuffers {
    /// The traced image's size in pixels.
    pub fn size(&self) -> UVec2 {
        self.size
    }
}

impl ViewState {
    fn new(buffers: ViewBuffers, timer: Option<TraceTimer>) -> Self {
        let order = TileOrder::new(buffers.size.x, buffers.size.y);
        Self {
            buffers,
            order,
            cursor: TileCursor::default(),
            clock: TraceClock::default(),
            timer,
            key: None,
            preview_scale: 0,
            preview_seed: 0,
            last_frame: None,
            seen: true,
            frame: None,
            denoised_sweeps: None,
            denoise_run: None,
            parity: 0,
            last_picture: None,
        }
    }

    /// Decides this frame's work: a preview after a restart the budget cannot cover with a whole
    /// sweep, else the next run of tiles the budget allows; `None` once the view has its samples.
    fn next_work(
        &mut self,
        settings: &PathTraced,
        restart: bool,
        filling: bool,
    ) -> Option<(TraceWork, u64)> {
        let spf = settings.samples_per_frame.clamp(1, 64);
        let sweeps = self.cursor.sweeps(&self.order);
        if settings.max_samples > 0 && sweeps * spf as u64 >= settings.max_samples as u64 {
            return None;
        }
        let allowed = self.clock.sample_budget(&settings.frame_budget(filling));
        let size = self.buffers.size;
        let pixels = size.x as u64 * size.y as u64;
        if restart && allowed < pixels * spf as u64 {
            let scale = preview_scale(size.x, size.y, allowed);
            self.preview_scale = scale;
            self.preview_seed = self.preview_seed.wrapping_add(1);
            let blocks = size.x.div_ceil(scale) as u64 * size.y.div_ceil(scale) as u64;
            let work = TraceWork::Preview {
                scale,
                seed: self.preview_seed,
            };
            return Some((work, blocks));
        }
        let per_tile = (TILE * TILE * spf) as u64;
        let count = self.clock.tiles(allowed, per_tile, self.order.total);
        let start = self.cursor.take(&self.order, count);
        Some((TraceWork::Tiles { start, count }, count as u64 * per_tile))
    }
}

/// What prepare reads of a path-traced view.
type TracedView = (
    Entity,
    &'static ExtractedCamera,
    &'static ExtractedView,
    &'static ViewTarget,
    Option<&'static ViewDepthTexture>,
    &'static PathTraced,
    &'static MainEntity,
);

/// What every view's preparation this frame shares.
struct FrameInputs<'a> {
    pipelines: &'a PathTracerPipelines,
    pipeline_cache: &'a PipelineCache,
    scene: &'a GpuScene,
    layers: &'a TextureLayers,
    device: &'a RenderDevice,
    queue: &'a RenderQueue,
    stats: &'a PathTracerStats,
    /// The panorama's uniform word ([`ExtractedEnvironment::uniform`]).
    environment_word: Vec4,
    environment_generation: u64,
    /// The trace kernel's pipeline, and whether it is ready to dispatch.
    trace_pipeline: CachedComputePipelineId,
    trace_ready: bool,
    max_bytes: u64,
    now: Instant,
}

/// For each path-traced view: its state made or remade for its size, its accumulation restarted
/// when what it shows changed, this frame's share of the work under its budget, its uniforms
/// written, and what the node is to do.
#[allow(clippy::too_many_arguments)]
fn prepare_views(
    views: Query<TracedView>,
    pipelines: Option<Res<PathTracerPipelines>>,
    pipeline_cache: Res<PipelineCache>,
    scene: Res<GpuScene>,
    layers: Option<Res<TextureLayers>>,
    mut states: ResMut<ViewStates>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    stats: Res<PathTracerStats>,
    environment: Res<ExtractedEnvironment>,
    warmup: Option<ResMut<KernelWarmup>>,
) {
    let (Some(pipelines), Some(layers)) = (pipelines, layers) else {
        return;
    };
    if scene.too_large.is_some() {
        // Nothing is traced, so nothing waits for a kernel.
        stats.update(|f| f.set_preparing_kernel(None));
        return;
    }
    let trace_pipeline = pipelines.trace_pipeline(&pipeline_cache, scene.split());
    // On a software adapter the views wait for their kernel's warm-up (`kernel_warmup.rs`).
    let kernel = TraceKernel::of(scene.split());
    // Without a path-traced view nothing waits.
    let waited = warmup
        .filter(|_| !views.is_empty())
        .and_then(|mut w| w.wait(kernel));
    stats.update(|f| {
        f.set_preparing_kernel(
            waited.map(|waited_s| crate::types::figures::PreparingKernel {
                split: kernel == TraceKernel::Split,
                waited_s,
            }),
        )
    });
    let frame = FrameInputs {
        trace_ready: pipeline_cache
            .get_compute_pipeline(trace_pipeline)
            .is_some()
            && scene.bind_group.is_some()
            && waited.is_none(),
        pipelines: &pipelines,
        pipeline_cache: &pipeline_cache,
        scene: &scene,
        layers: &layers,
        device: &device,
        queue: &queue,
        stats: &stats,
        environment_word: environment.uniform(),
        environment_generation: environment.generation,
        trace_pipeline,
        max_bytes: max_binding_bytes(&device),
        now: Instant::now(),
    };
    for view in &views {
        prepare_view(&frame, &mut states, view);
    }
}

/// The traced size of a view: its viewport scaled by the view's resolution scale.
fn traced_size(viewport: UVec4, settings: &PathTraced) -> UVec2 {
    let scale = if settings.resolution_scale.is_finite() {
        settings.resolution_scale.clamp(0.05, 4.0)
    } else {
        1.0
    };
    (Vec2::new(viewport.z as f32, viewport.w as f32) * scale)
        .round()
        .as_uvec2()
        .max(UVec2::ONE)
}

/// Why a view of `size` cannot be traced on this adapter, if its largest buffer (the denoiser's
/// guides or taps, one binding each) outgrows what one binding holds.
fn too_big(size: UVec2, max_bytes: u64) -> Option<String> {
    let view_bytes = crate::types::records::guide_bytes(size.x, size.y)
        .max(crate::types::records::denoise_tap_bytes(size.x, size.y))
        .max(crate::types::records::aux_bytes(size.x, size.y))
        .max(size.x as u64 * size.y as u64 * 16);
    (view_bytes > max_bytes).then(|| {
        format!(
            "a {}×{} view needs {} in one buffer and this adapter binds at most {}",
            size.x,
            size.y,
            size_text(view_bytes),
            size_text(max_bytes)
        )
    })
}

/// What a view's accumulated samples depend on: any change restarts them.
fn accumulation_key(
    frame: &FrameInputs,
    world_from_clip: Mat4,
    settings: &PathTraced,
    exposure: f32,
    size: UVec2,
) -> AccumulationKey {
    AccumulationKey {
        world_from_clip,
        scene_generation: frame.scene.generation,
        texture_generation: frame.layers.generation,
        tree_generation: if settings.view == DebugView::Heatmap {
            frame.scene.tree_generation
        } else {
            0
        },
        environment: (frame.environment_generation, frame.environment_word),
        settings: PathTraced {
            max_samples: 0,
            frame_budget_ms: 0.0,
            frame_budget_share: 0.0,
            frame_budget_share_while_filling: 0.0,
            // The outline is drawn by the resolve, over the samples, and the denoiser filters
            // them.
            outline: OutlineStyle::default(),
            denoise: false,
            temporal: false,
            ..*settings
        },
        exposure,
        size,
    }
}

/// The view's state, made for `size` (or remade after a resize), with its resolve bind groups
/// current for the scene's outline buffer, and what the last frame measured taken in.
fn ready_state<'s>(
    frame: &FrameInputs,
    states: &'s mut ViewStates,
    entity: Entity,
    size: UVec2,
) -> &'s mut ViewState {
    let (device, pipelines, cache, scene) = (
        frame.device,
        frame.pipelines,
        frame.pipeline_cache,
        frame.scene,
    );
    let state = states.0.entry(entity).or_insert_with(|| {
        ViewState::new(
            view_buffers(device, pipelines, cache, size, scene),
            TraceTimer::new(device, frame.queue),
        )
    });
    if state.buffers.size != size {
        // What a sample costs survives a resize; the tiles and the accumulation do not.
        state.buffers = view_buffers(device, pipelines, cache, size, scene);
        state.order = TileOrder::new(size.x, size.y);
        state.key = None;
        state.last_picture = None;
    }
    if state.buffers.outline_version != scene.outline_version {
        let b = &mut state.buffers;
        b.resolve_bind_groups = resolve_groups(
            device,
            pipelines,
            cache,
            [
                &b.accum,
                &b.aux,
                &b.resolve_params,
                &b.denoised[0],
                &b.guides,
            ],
            &b.shown,
            scene,
        );
        b.outline_version = scene.outline_version;
    }
    state.seen = true;
    state.frame = None;
    if let Some(timer) = &mut state.timer {
        timer.harvest(&mut state.clock);
    }
    if let Some((then, samples)) = state.last_frame.take() {
        state
            .clock
            .observe_frame(samples, (frame.now - then).as_secs_f64() * 1e9);
    }
    state
}

/// One path-traced view's preparation this frame.
fn prepare_view(
    frame: &FrameInputs,
    states: &mut ViewStates,
    (entity, camera, extracted, target, depth, settings, main_entity): bevy::ecs::query::QueryItem<
        TracedView,
    >,
) {
    let viewport = extracted.viewport;
    if viewport.z == 0 || viewport.w == 0 {
        return;
    }
    let size = traced_size(viewport, settings);
    if let Some(why) = too_big(size, frame.max_bytes) {
        frame.stats.update(|f| {
            f.trace_off.get_or_insert(why);
        });
        return;
    }
    let clip_from_world = extracted
        .clip_from_world
        .unwrap_or_else(|| extracted.clip_from_view * extracted.world_from_view.affine().inverse());
    let world_from_clip = clip_from_world.inverse();
    let key = accumulation_key(frame, world_from_clip, settings, camera.exposure, size);
    let state = ready_state(frame, states, entity, size);
    if !frame.trace_ready {
        return;
    }
    let restart = state.key != Some(key);
    // Whether the camera alone moved since the last frame's picture: it can be carried over.
    let camera_moved = restart
        && state.key.is_some_and(|old| {
            AccumulationKey {
                world_from_clip: key.world_from_clip,
                ..old
            } == key
        });
    if restart {
        state.key = Some(key);
        state.cursor = TileCursor::default();
        state.preview_scale = 0;
        state.denoised_sweeps = None;
        state.denoise_run = None;
    }
    let scene = frame.scene;
    state
        .clock
        .scene_size(scene.capacities[BufferKind::Triangles.index()]);
    let work = state.next_work(settings, restart, scene.filling);
    let traced = work.map_or(0, |(_, n)| n);
    state.last_frame = Some((frame.now, traced));
    let (dispatch, timing) = match work {
        Some((work, samples)) => {
            let params = view_params(
                frame,
                settings,
                camera_relative(extracted),
                camera.exposure,
                size,
                work,
            );
            frame
                .queue
                .write_buffer(&state.buffers.view_uniform, 0, &params.to_bytes());
            let epoch = state.clock.epoch();
            let timing = state.timer.as_mut().and_then(|t| t.assign(samples, epoch));
            let (x, y) = params.workgroups();
            (Some(UVec2::new(x, y)), timing)
        }
        None => (None, None),
    };
    let filters = filters(
        frame,
        state,
        settings,
        (restart, camera_moved, work.is_some()),
        clip_from_world,
        size,
    );
    frame.queue.write_buffer(
        &state.buffers.resolve_params,
        0,
        &ResolveParams {
            origin: Vec2::new(viewport.x as f32, viewport.y as f32),
            viewport: Vec2::new(viewport.z as f32, viewport.w as f32),
            size: [size.x, size.y],
            preview_scale: filters.shown_preview,
            outline_slots: scene.outline_slots,
            outline: settings.outline,
            outline_rect: outline_rect(
                scene.outline_bounds,
                clip_from_world,
                viewport,
                settings.outline.width + viewport.z as f32 / size.x as f32 + 1.0,
            ),
            denoised: filters.denoising && state.denoised_sweeps.is_some(),
            temporal: filters.temporal,
        }
        .to_bytes(),
    );
    let msaa = target
        .sampled_main_texture()
        .map_or(1, |t| t.sample_count());
    state.frame = Some(ViewFrame {
        trace_pipeline: frame.trace_pipeline,
        dispatch,
        clear: restart,
        timing,
        resolve_pipeline: frame.pipelines.resolve_pipeline(
            frame.pipeline_cache,
            target.main_texture_format(),
            msaa,
            depth.is_some(),
        ),
        writes_depth: depth.is_some(),
        viewport,
        denoise: filters.denoise,
        temporal: filters.run_temporal,
        parity: filters.parity,
    });
    let sweeps = state.cursor.sweeps(&state.order);
    let samples = (sweeps * settings.samples_per_frame.clamp(1, 64) as u64) as u32;
    let figures = TraceFigures {
        traced_per_frame: traced,
        cost: state.clock.cost(),
        previewing: work.is_some_and(|(w, _)| matches!(w, TraceWork::Preview { .. })),
        geometry: traced > 0 && scene.has_geometry(),
        panorama: frame.environment_word.w as u32 & 1 != 0,
        denoising: filters.denoise_owed,
        denoise_pass: filters.denoise.map(|d| (d.pass, d.passes)),
    };
    frame.stats.update(|f| {
        f.samples.insert(main_entity.id(), samples);
        f.traces.insert(main_entity.id(), figures);
    });
}

/// The most bounces a view's paths take, whatever its settings ask.
const MAX_BOUNCES: u32 = 256;

/// The trace's uniform for this frame's `work`. The preview is one sample per block, shown for a
/// frame: one bounce and a tight cap on indirect light keep it from flickering with fireflies
/// while the camera moves.
fn view_params(
    frame: &FrameInputs,
    settings: &PathTraced,
    (world_from_clip, origin): (Mat4, Vec3),
    exposure: f32,
    size: UVec2,
    work: TraceWork,
) -> ViewParams {
    let sky = settings.sky;
    let preview = matches!(work, TraceWork::Preview { .. });
    let (bounces, clamp) = if !preview {
        (
            settings.max_bounces.min(MAX_BOUNCES),
            settings.indirect_clamp.max(0.0),
        )
    } else {
        // The preview caps light at white as the camera exposes it (an uncapped view too): it is
        // shown for one frame, and a speckle would flicker.
        let white = 1.0 / exposure.max(f32::MIN_POSITIVE);
        let clamp = match settings.indirect_clamp {
            c if c > 0.0 => c.min(white),
            _ => white,
        };
        (settings.max_bounces.min(1), clamp)
    };
    let scene = frame.scene;
    ViewParams {
        world_from_clip,
        origin,
        sky: Vec3::new(sky.red, sky.green, sky.blue),
        exposure,
        width: size.x,
        height: size.y,
        root: scene.root,
        max_bounces: bounces,
        samples: settings.samples_per_frame.clamp(1, 64),
        mode: settings.view.shader_index(),
        light_count: scene.light_count,
        emitters: scene.emitters,
        indirect_clamp: clamp,
        work,
        part_shift: scene.layout.shift,
        seed: settings.seed,
        environment: frame.environment_word,
    }
}

/// What a view's picture goes through after the trace this frame.
struct Filters {
    /// The preview's block size the resolve shows, 0 once a sweep has run.
    shown_preview: u32,
    /// Whether the denoiser filters this view at all.
    denoising: bool,
    /// The denoiser's pass, when one runs this frame.
    denoise: Option<DenoisePass>,
    /// Whether the denoiser has passes to make after this frame's ([`TraceFigures::denoising`]).
    denoise_owed: bool,
    /// Whether temporal reuse is on, and its pipeline when it runs this frame.
    temporal: bool,
    run_temporal: Option<CachedComputePipelineId>,
    /// Which of the view's two pictures this frame writes.
    parity: usize,
}

/// The denoiser and temporal reuse for this frame, with the temporal pass's uniform written.
/// The preview stands in for pixels without a sample until a whole sweep has run. The denoiser,
/// in the path-traced view only, starts a run ([`DenoiseRun::due`]) when the sweeps over the image
/// (each gives every pixel new samples) have passed a power of two since its last result, and once
/// at a view's sample limit, and makes one pass a frame. Not over an empty scene (the sky has no
/// noise to filter), nor while the tree fills (the next frame's triangles restart the picture it
/// would filter).
fn filters(
    frame: &FrameInputs,
    state: &mut ViewState,
    settings: &PathTraced,
    (restart, camera_moved, traced): (bool, bool, bool),
    clip_from_world: Mat4,
    size: UVec2,
) -> Filters {
    let (pipelines, cache, scene) = (frame.pipelines, frame.pipeline_cache, frame.scene);
    let sweeps = state.cursor.sweeps(&state.order);
    let wanted = settings.denoise && settings.view == DebugView::PathTraced && scene.has_geometry();
    let denoising =
        wanted && !scene.filling && cache.get_compute_pipeline(pipelines.denoise).is_some();
    // A pipeline still compiling owes the picture its runs (one that failed owes nothing).
    let compiling = matches!(
        cache.get_compute_pipeline_state(pipelines.denoise),
        CachedPipelineState::Queued | CachedPipelineState::Creating(_)
    );
    let spf = u64::from(settings.samples_per_frame.clamp(1, 64));
    // The run due after the result `done`: the same rule starts a run and tells a waiter one is
    // owed.
    let due =
        |done: Option<u64>| DenoiseRun::due(sweeps, spf, done, u64::from(settings.max_samples));
    if !denoising {
        state.denoise_run = None;
    } else if state.denoise_run.is_none() {
        state.denoise_run = due(state.denoised_sweeps);
    }
    let denoise = state.denoise_run.map(|run| {
        let (pass, rest) = run.step();
        state.denoise_run = rest;
        if rest.is_none() {
            state.denoised_sweeps = Some(run.sweeps);
        }
        DenoisePass {
            pipeline: pipelines.denoise,
            pass,
            passes: run.passes,
        }
    });
    // The picture shows a new result in the frame a run makes its last pass.
    let new_result = denoise.is_some_and(|d| d.pass + 1 == d.passes);
    // A run ended this frame may leave another due (the sweeps passed a power of two, or the
    // limit, meanwhile): it starts next frame, and the picture is not finished before it ends.
    // Nor is it while the tree fills or the denoiser's pipeline compiles: its runs start after.
    let denoise_owed = state.denoise_run.is_some()
        || (wanted && (compiling || scene.filling))
        || (denoising && due(state.denoised_sweeps).is_some());
    let shown_preview = if sweeps == 0 { state.preview_scale } else { 0 };
    // Temporal reuse, with the denoiser, in the path-traced view.
    let temporal = (denoising && settings.temporal)
        .then(|| {
            cache
                .get_compute_pipeline(pipelines.temporal)
                .map(|_| pipelines.temporal)
        })
        .flatten();
    // The picture changes only with new samples, a denoised result or a restart: an idle view
    // shows the last one again without running the pass.
    let picture_changes = restart || traced || new_result || state.last_picture.is_none();
    let run_temporal = temporal.filter(|_| picture_changes);
    let parity = if run_temporal.is_some() || temporal.is_none() {
        state.parity
    } else {
        1 - state.parity
    };
    if run_temporal.is_some() {
        let carried = if !restart {
            TemporalRestart::Keep
        } else if camera_moved && state.last_picture.is_some() {
            TemporalRestart::Reproject
        } else {
            TemporalRestart::Clear
        };
        let reproject = state.last_picture.unwrap_or(Mat4::IDENTITY) * clip_from_world.inverse();
        frame.queue.write_buffer(
            &state.buffers.temporal_params,
            0,
            &crate::types::records::temporal_bytes(
                reproject,
                size.x,
                size.y,
                shown_preview,
                state.denoised_sweeps.is_some(),
                carried,
            ),
        );
        state.last_picture = Some(clip_from_world);
        state.parity = 1 - parity;
    } else if temporal.is_none() {
        state.last_picture = None;
    }
    Filters {
        shown_preview,
        denoising,
        denoise,
        denoise_owed,
        temporal: temporal.is_some(),
        run_temporal,
        parity,
    }
}

/// Where the outlined objects can show in the target (pixels): their bounds' corners projected,
/// widened by `margin`; the whole viewport when a corner is behind the camera or the bounds are
/// unknown.
fn outline_rect(
    bounds: Option<[Vec3; 2]>,
    clip_from_world: Mat4,
    viewport: UVec4,
    margin: f32,
) -> [Vec2; 2] {
    let origin = Vec2::new(viewport.x as f32, viewport.y as f32);
    let size = Vec2::new(viewport.z as f32, viewport.w as f32);
    let whole = [origin, origin + size];
    let Some([lo, hi]) = bounds else {
        return whole;
    };
    let (mut min, mut max) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
    for k in 0..8 {
        let p = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let c = clip_from_world * p.extend(1.0);
        if c.w <= 1e-6 {
            return whole;
        }
        let ndc = Vec2::new(c.x, c.y) / c.w;
        let at = origin + Vec2::new(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * size;
        (min, max) = (min.min(at), max.max(at));
    }
    [min - Vec2::splat(margin), max + Vec2::splat(margin)]
}

/// After the frame's submission: asks for the timestamps its passes wrote.
fn request_timings(mut states: ResMut<ViewStates>) {
    for state in states.0.values_mut() {
        if let Some(timer) = &mut state.timer {
            timer.request_readback();
        }
    }
}

/// Drops the state of views that were not drawn this frame (cameras despawned or switched off),
/// and every view's frame: what the node does is prepared anew each frame, so a camera that stops
/// being path traced (its state forgotten only after its node ran once more) or a view prepare
/// skips replays no old dispatch, nor copies timestamps into a buffer being mapped.
fn forget_views(mut states: ResMut<ViewStates>) {
    states.0.retain(|_, s| {
        s.frame = None;
        std::mem::replace(&mut s.seen, false)
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The runs a view's denoiser completes, as (frame, sweeps of its result), and the frames it
    /// made a pass in, tracing one sweep of one sample a frame up to `limit` samples.
    fn denoiser_runs(limit: u64, frames: u64) -> (Vec<(u64, u64)>, Vec<u64>) {
        let (mut run, mut done) = (None::<DenoiseRun>, None);
        let (mut results, mut busy) = (vec![], vec![]);
        for frame in 1..=frames {
            let sweeps = frame.min(limit);
            if run.is_none() {
                run = DenoiseRun::due(sweeps, 1, done, limit);
            }
            if let Some(r) = run {
                let (pass, rest) = r.step();
                assert_eq!(pass, r.next);
                busy.push(frame);
                run = rest;
                if rest.is_none() {
                    assert_eq!(pass + 1, r.passes, "a run ends with its last pass");
                    done = Some(r.sweeps);
                    results.push((frame, r.sweeps));
                }
            }
        }
        (results, busy)
    }

    #[test]
    fn the_denoiser_makes_one_pass_a_frame_and_ends_on_the_view_s_last_samples() {
        // Six passes over the first sweep (frames 1 to 6); then a run whenever the sweeps passed a
        // power of two since the last result (4 and 8 while the first two ran), with fewer
        // passes as the samples grow; the last over all 32.
        let (results, busy) = denoiser_runs(32, 60);
        assert_eq!(results, [(6, 1), (11, 7), (15, 12), (19, 16), (35, 32)]);
        assert_eq!(busy.len(), 6 + 5 + 4 + 4 + 4);
        assert_eq!(
            busy.last(),
            Some(&35),
            "nothing after the last samples' run"
        );
        // A limit off the powers of two gets a run of its own once reached.
        let (results, busy) = denoiser_runs(24, 60);
        assert_eq!(results.last(), Some(&(27, 24)));
        assert_eq!(busy.last(), Some(&27));
        // No sweep yet, no run.
        assert_eq!(DenoiseRun::due(0, 1, None, 16), None);
        // A result of the sweeps at the limit is the last.
        assert_eq!(DenoiseRun::due(16, 1, Some(16), 16), None);
    }

    #[test]
    fn the_outline_rectangle_covers_the_projected_bounds_or_the_whole_view() {
        let clip_from_world = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1)
            * Mat4::look_at_rh(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
        let viewport = UVec4::new(100, 50, 400, 400);
        let whole = [Vec2::new(100.0, 50.0), Vec2::new(500.0, 450.0)];
        // A unit box at the origin: centred in the view, inside it, widened by the margin.
        let [min, max] = outline_rect(
            Some([Vec3::splat(-0.5), Vec3::splat(0.5)]),
            clip_from_world,
            viewport,
            3.0,
        );
        let centre = (min + max) * 0.5;
        assert!(
            (centre - Vec2::new(300.0, 250.0)).length() < 1e-3,
            "{centre}"
        );
        assert!(min.cmpgt(whole[0]).all() && max.cmplt(whole[1]).all());
        let [tight_min, _] = outline_rect(
            Some([Vec3::splat(-0.5), Vec3::splat(0.5)]),
            clip_from_world,
            viewport,
            0.0,
        );
        assert_eq!(tight_min - min, Vec2::splat(3.0));
        // A box reaching behind the camera, or unknown bounds: the whole view is searched.
        let behind = outline_rect(
            Some([Vec3::splat(-0.5), Vec3::new(0.5, 0.5, 9.0)]),
            clip_from_world,
            viewport,
            3.0,
        );
        assert_eq!(behind, whole);
        assert_eq!(outline_rect(None, clip_from_world, viewport, 3.0), whole);
    }
}
