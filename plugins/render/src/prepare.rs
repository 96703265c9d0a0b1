//! Prepare: the scene's GPU buffers (grown by doubling, old contents copied on the GPU, then patched
//! with the frame's writes), the scene bind group (made again only when a buffer or the texture
//! array grew), and each path-traced view's buffers, uniforms and bind groups, with the share of its
//! work that fits this frame's budget: what the node is to dispatch and draw.

use crate::budget::{TILE, TileCursor, TileOrder, TraceClock, preview_scale};
use crate::environment::{ExtractedEnvironment, GpuEnvironment};
use crate::extract::SceneSync;
use crate::kernel_warmup::{KernelWarmup, TraceKernel};
use crate::parts::{PartLayout, part_bindings, part_count, trace_storage_buffers};
use crate::pipelines::PathTracerPipelines;
use crate::records::{ResolveParams, TemporalRestart, TraceWork, VIEW_BYTES, ViewParams};
use crate::staging::UploadBelt;
use crate::texture_layers::TextureLayers;
use crate::timing::TraceTimer;
use crate::upload::BufferKind;
use crate::{DebugView, OutlineStyle, PathTraced, PathTracerStats, TraceFigures};
use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, BindGroupEntry, BindingResource, Buffer, BufferDescriptor,
    BufferInitDescriptor, BufferUsages, CachedComputePipelineId, CachedRenderPipelineId,
    CommandEncoderDescriptor, PipelineCache,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::sync_world::MainEntity;
use bevy::render::view::{ExtractedView, ViewDepthTexture, ViewTarget};
use bevy::render::{Render, RenderStartup, RenderSystems};
use std::collections::HashMap;
use std::time::Instant;

pub(crate) fn build(render_app: &mut SubApp) {
    render_app
        .init_resource::<ViewStates>()
        .add_systems(RenderStartup, init_gpu_scene)
        .add_systems(
            Render,
            (
                apply_scene_uploads.in_set(RenderSystems::PrepareResources),
                (
                    prepare_scene_bind_group,
                    crate::kernel_warmup::start_warmups,
                    prepare_views,
                )
                    .chain()
                    .in_set(RenderSystems::PrepareBindGroups),
                (request_timings, forget_views)
                    .chain()
                    .in_set(RenderSystems::Cleanup),
            ),
        );
}

/// The scene as the kernels read it.
#[derive(Resource)]
pub(crate) struct GpuScene {
    /// In [`BufferKind::ALL`] order, each kind's parts (one until a part is full).
    buffers: Vec<Vec<Buffer>>,
    /// Records each kind holds, all its parts together.
    capacities: [u64; 6],
    /// How the large kinds are split across bindings on this adapter.
    pub layout: PartLayout,
    /// Bound where a kind has fewer parts than the kernel declares.
    stand_in: Buffer,
    /// The GGX lobe's albedo table (`energy.rs`), written once.
    energy: Buffer,
    pub root: u32,
    pub light_count: u32,
    /// Raised by every upload that changes what a ray sees (geometry, materials, lights, textures):
    /// views restart their accumulation when it changes.
    pub generation: u64,
    /// Raised by every upload that changes the tree, including pure restructurings, which leave
    /// the traced image as it was but not the traversal heatmap.
    pub tree_generation: u64,
    /// Group 0 of the trace kernel over the current buffers and texture array; `None` after a
    /// buffer grew, until it is made again.
    pub bind_group: Option<BindGroup>,
    /// The texture array's and the panorama's versions the bind group was made with.
    bound_array: u64,
    bound_environment: u64,
    /// Two bits of outline per object slot, read by the views' resolve passes.
    outlines: Buffer,
    /// Words `outlines` holds.
    outline_capacity: u64,
    /// Slots the outline words cover; 0 when nothing is outlined.
    pub outline_slots: u32,
    /// Raised when `outlines` is replaced by a bigger buffer: views make their resolve groups again.
    outline_version: u64,
    /// World-space bounds of the outlined meshes; `None` when unknown.
    outline_bounds: Option<[Vec3; 2]>,
    /// The sets of per-map UV transforms the object records name (`map_transforms.rs`), written
    /// whole when the table grows.
    map_transforms: Buffer,
    /// Why the scene cannot be traced on this adapter (a buffer larger than it can bind), once
    /// that happened: nothing is bound or written from then on, and no view is traced.
    pub too_large: Option<String>,
    /// Whether new geometry was on its way into the scene's tree as of this frame's extract.
    pub filling: bool,
    /// Where the frame's record writes are staged.
    staging: UploadBelt,
}

impl GpuScene {
    /// Whether a kind's records lie in more than one buffer: the split kernel reads them.
    pub fn split(&self) -> bool {
        self.buffers.iter().any(|parts| parts.len() > 1)
    }

    /// Whether the uploaded tree holds anything (its root is a node).
    pub fn has_geometry(&self) -> bool {
        self.root != treelight_bvh::NONE
    }
}

/// The most bytes one storage buffer the kernels bind may hold on this device.
fn max_binding_bytes(device: &RenderDevice) -> u64 {
    let limits = device.limits();
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
}

/// A size for messages: whole MiB, or KiB below one MiB.
fn size_text(bytes: u64) -> String {
    if bytes < 1 << 20 {
        format!("{} KiB", bytes.div_ceil(1 << 10))
    } else {
        format!("{} MiB", bytes.div_ceil(1 << 20))
    }
}

fn map_transform_buffer(device: &RenderDevice, bytes: &[u8]) -> Buffer {
    device.create_buffer_with_data(&BufferInitDescriptor {
        label: Some("treelight map transforms"),
        contents: bytes,
        usage: BufferUsages::STORAGE,
    })
}

fn outline_buffer(device: &RenderDevice, words: u64) -> Buffer {
    device.create_buffer(&BufferDescriptor {
        label: Some("treelight outlines"),
        size: words * 4,
        usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn create(device: &RenderDevice, kind: BufferKind, records: u64) -> Buffer {
    // A binding may not be empty.
    let records = records.max(1);
    device.create_buffer(&BufferDescriptor {
        label: Some(match kind {
            BufferKind::Nodes => "treelight nodes",
            BufferKind::Triangles => "treelight triangles",
            BufferKind::Instances => "treelight instances",
            BufferKind::Attributes => "treelight triangle shading",
            BufferKind::Objects => "treelight objects",
            BufferKind::Lights => "treelight lights",
        }),
        size: records * kind.record_bytes(),
        usage: BufferUsages::STORAGE | BufferUsages::COPY_DST | BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

fn init_gpu_scene(mut commands: Commands, device: Res<RenderDevice>, stats: Res<PathTracerStats>) {
    let layout = PartLayout::for_binding_limit(max_binding_bytes(&device));
    // Lights start small; the rest at the doubling floor (or a part, if that is smaller).
    let capacities = BufferKind::ALL.map(|k| match k {
        BufferKind::Lights => 16,
        _ => layout.grown(k, 0, 1).unwrap_or(1),
    });
    let buffers = BufferKind::ALL
        .iter()
        .zip(capacities)
        .map(|(&k, c)| vec![create(&device, k, c)])
        .collect();
    let too_large = too_few_bindings(&device);
    if let Some(why) = &too_large {
        error!("treelight: path tracing is off: {why}");
        stats.update(|f| f.trace_off = Some(why.clone()));
    }
    commands.insert_resource(GpuScene {
        buffers,
        capacities,
        layout,
        stand_in: create(&device, BufferKind::Instances, 2),
        energy: device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("treelight energy table"),
            contents: crate::energy::energy_bytes(),
            usage: BufferUsages::UNIFORM,
        }),
        root: u32::MAX,
        light_count: 0,
        generation: 0,
        tree_generation: 0,
        bind_group: None,
        bound_array: 0,
        bound_environment: 0,
        outlines: outline_buffer(&device, 64),
        outline_capacity: 64,
        outline_slots: 0,
        outline_version: 0,
        outline_bounds: None,
        map_transforms: map_transform_buffer(&device, &crate::MapTransformTable::default().bytes()),
        too_large,
        filling: false,
        staging: UploadBelt::new(device.wgpu_device()),
    });
}

/// Why the trace kernel cannot run on this device, if it binds fewer storage buffers per shader
/// stage than the kernel declares.
pub(crate) fn too_few_bindings(device: &RenderDevice) -> Option<String> {
    let have = device.limits().max_storage_buffers_per_shader_stage;
    let need = trace_storage_buffers();
    (have < need).then(|| {
        format!(
            "this adapter binds {have} storage buffers per shader stage and the path tracer needs \
             {need}"
        )
    })
}

/// Grows the buffers that must hold more records, then writes the frame's records.
fn apply_scene_uploads(
    mut sync: ResMut<SceneSync>,
    mut scene: ResMut<GpuScene>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    stats: Res<PathTracerStats>,
) {
    let mut pending = std::mem::take(&mut sync.pending);
    scene.filling = pending.filling;
    let scene = &mut *scene;
    if scene.too_large.is_some() {
        return;
    }
    // A buffer grows up to what the adapter binds, then the large kinds add parts, each a
    // binding of its own; past the parts the kernel declares, tracing stops.
    let layout = scene.layout;
    let mut grown = Vec::new();
    for (i, &kind) in BufferKind::ALL.iter().enumerate() {
        let need = pending.needed[i];
        if need <= scene.capacities[i] {
            continue;
        }
        let Some(cap) = layout.grown(kind, scene.capacities[i], need) else {
            let parts = part_count(kind);
            let why = format!(
                "the scene's {} need {} and this adapter binds at most {} in each of the \
                 {parts} buffer{} the path tracer has for them",
                kind.label(),
                size_text(need * kind.record_bytes()),
                size_text(layout.max_binding_bytes),
                if parts == 1 { "" } else { "s" },
            );
            error!("treelight: path tracing stops: {why}");
            scene.too_large = Some(why.clone());
            scene.bind_group = None;
            stats.update(|f| f.trace_off = Some(why));
            return;
        };
        let old_sizes = layout.part_sizes(kind, scene.capacities[i]);
        for (k, &records) in layout.part_sizes(kind, cap).iter().enumerate() {
            if old_sizes.get(k) == Some(&records) {
                continue;
            }
            let bigger = create(&device, kind, records);
            match scene.buffers[i].get_mut(k) {
                Some(part) => {
                    let old = std::mem::replace(part, bigger);
                    grown.push((old, old_sizes[k] * kind.record_bytes(), i, k));
                }
                None => scene.buffers[i].push(bigger),
            }
        }
        scene.capacities[i] = cap;
        scene.bind_group = None;
    }
    if scene.bind_group.is_none() {
        // A buffer grew or a part was added.
        let total: u64 = scene.buffers.iter().flatten().map(|b| b.size()).sum();
        stats.update(|f| f.scene_buffer_bytes = total);
    }
    // Growth copies first, then the writes, all in one submission.
    let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor {
        label: Some("treelight scene upload"),
    });
    // Keep what is already on the GPU: records outside this frame's writes stay valid.
    for (old, bytes, i, k) in &grown {
        encoder.copy_buffer_to_buffer(old, 0, &scene.buffers[*i][*k], 0, *bytes);
    }
    let mut bytes = 0u64;
    for w in pending.writes.iter() {
        let i = w.buffer.index();
        let end = w.offset + w.bytes.len() as u64;
        if end > scene.capacities[i] * w.buffer.record_bytes() {
            // Extraction sized every buffer for its writes; a write past the end is a bug, and
            // skipping it beats a device error that would stop all rendering.
            error!(
                "treelight: dropped a {:?} write past the buffer's end",
                w.buffer
            );
            continue;
        }
        for (part, at, range) in layout.pieces(w.buffer, w.offset, w.bytes.len() as u64) {
            let piece = &w.bytes[range];
            if !scene
                .staging
                .write(&mut encoder, &scene.buffers[i][part], at, piece)
            {
                error!(
                    "treelight: dropped a {:?} write of {} bytes at {at}: not whole words",
                    w.buffer,
                    piece.len()
                );
            }
        }
        bytes += w.bytes.len() as u64;
    }
    scene.staging.finish();
    if !grown.is_empty() || bytes > 0 {
        queue.submit([encoder.finish()]);
    }
    scene.staging.recall(pending.filling);
    let mut tree_changed = pending.writes.iter().any(|w| w.buffer == BufferKind::Nodes);
    if let Some(root) = pending.root
        && root != scene.root
    {
        scene.root = root;
        tree_changed = true;
    }
    if let Some(n) = pending.light_count {
        scene.light_count = n;
    }
    if let Some((words, covered)) = &pending.outlines {
        let need = words.len() as u64;
        if need > scene.outline_capacity {
            // Written whole each time it changes, so nothing needs copying over.
            scene.outline_capacity = need.next_power_of_two();
            scene.outlines = outline_buffer(&device, scene.outline_capacity);
            scene.outline_version += 1;
        }
        if !words.is_empty() {
            queue.write_buffer(&scene.outlines, 0, bytemuck::cast_slice(words));
        }
        scene.outline_slots = *covered;
    }
    scene.outline_bounds = pending.outline_bounds;
    if let Some(table) = &pending.map_transforms {
        // Sets are only ever added, so the table is made again whole, and bound anew.
        scene.map_transforms = map_transform_buffer(&device, table);
        scene.bind_group = None;
    }
    if pending.geometry_changed {
        scene.generation += 1;
    }
    if tree_changed || pending.geometry_changed {
        scene.tree_generation += 1;
    }
    let ready = pending.root.is_some();
    let version = pending.version.take();
    stats.update(|f| {
        if bytes > 0 {
            f.last_upload_bytes = bytes;
            f.total_upload_bytes += bytes;
            f.uploads += 1;
        }
        f.scene_ready |= ready;
        if let Some(v) = version {
            f.uploaded_version = f.uploaded_version.max(v);
        }
    });
    // The writes' memory serves the next frame's; once nothing streams in, a large one goes.
    let mut writes = std::mem::take(&mut pending.writes);
    writes.clear();
    if pending.filling || writes.capacity_bytes() <= KEPT_WRITE_BYTES {
        sync.pending.writes = writes;
    }
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

/// The most bytes of write buffer kept from frame to frame while nothing streams in.
const KEPT_WRITE_BYTES: u64 = 4 << 20;

/// Makes the scene bind group again when a buffer grew or the texture array was replaced.
fn prepare_scene_bind_group(
    mut scene: ResMut<GpuScene>,
    layers: Option<Res<TextureLayers>>,
    environment: Option<Res<GpuEnvironment>>,
    pipelines: Option<Res<PathTracerPipelines>>,
    pipeline_cache: Res<PipelineCache>,
    device: Res<RenderDevice>,
) {
    let (Some(layers), Some(environment), Some(pipelines)) = (layers, environment, pipelines)
    else {
        return;
    };
    if scene.too_large.is_some()
        || (scene.bind_group.is_some()
            && scene.bound_array == layers.array_version
            && scene.bound_environment == environment.version)
    {
        return;
    }
    let layout = pipeline_cache.get_bind_group_layout(&pipelines.scene_layout);
    // Each kind's parts at their bindings, the stand-in where a kind has fewer.
    let mut entries: Vec<BindGroupEntry> = Vec::new();
    for (i, &kind) in BufferKind::ALL.iter().enumerate() {
        for (k, &binding) in part_bindings(kind).iter().enumerate() {
            let buffer = scene.buffers[i].get(k).unwrap_or(&scene.stand_in);
            entries.push(BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            });
        }
    }
    entries.push(BindGroupEntry {
        binding: 6,
        resource: BindingResource::TextureView(&layers.view),
    });
    entries.push(BindGroupEntry {
        binding: 7,
        resource: BindingResource::Sampler(&layers.sampler),
    });
    entries.push(BindGroupEntry {
        binding: crate::MAP_TRANSFORMS_BINDING,
        resource: scene.map_transforms.as_entire_binding(),
    });
    entries.push(BindGroupEntry {
        binding: crate::energy::ENERGY_BINDING,
        resource: scene.energy.as_entire_binding(),
    });
    let [env_image, env_sampler, env_cdf] = crate::ENVIRONMENT_BINDINGS;
    entries.extend([
        BindGroupEntry {
            binding: env_image,
            resource: BindingResource::TextureView(&environment.image),
        },
        BindGroupEntry {
            binding: env_sampler,
            resource: BindingResource::Sampler(&environment.sampler),
        },
        BindGroupEntry {
            binding: env_cdf,
            resource: BindingResource::TextureView(&environment.distribution),
        },
    ]);
    let group = device.create_bind_group("treelight scene", &layout, &entries);
    scene.bind_group = Some(group);
    scene.bound_array = layers.array_version;
    scene.bound_environment = environment.version;
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
    /// The denoiser's pipeline and how many passes it makes, when it runs this frame (after the
    /// trace).
    pub denoise: Option<(CachedComputePipelineId, u32)>,
    /// The temporal pass's pipeline, when it runs this frame (after the denoiser; not while the
    /// view is idle).
    pub temporal: Option<CachedComputePipelineId>,
    /// Which of the view's two pictures the resolve shows this frame (the one the temporal pass
    /// writes when it runs): the bind groups' index.
    pub parity: usize,
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
    /// The denoiser's two working images (the last pass leaves its result in the first).
    denoised: [Buffer; 2],
    /// What the trace keeps for the denoiser: five words a pixel.
    guides: Buffer,
    /// Group 1 of the trace kernel.
    pub trace_bind_group: BindGroup,
    /// The denoiser's passes' groups, in order, each writing the first image or the second.
    pub denoise_bind_groups: Vec<[BindGroup; 2]>,
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
    /// it runs.
    denoised_sweeps: Option<u64>,
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
        crate::aux_bytes(size.x, size.y),
    );
    let guides = storage(
        device,
        "treelight denoiser guides",
        crate::guide_bytes(size.x, size.y),
    );
    let denoised = [
        storage(device, "treelight denoised", pixels * 16),
        storage(device, "treelight denoised", pixels * 16),
    ];
    let view_uniform = uniform(device, "treelight view", VIEW_BYTES);
    // The per-frame passes' parameters are storage buffers, not uniform ones: lavapipe (Mesa 22)
    // inlines the uniform values a shader's branches test, compiling a new variant at every bind
    // where that halves the shader and never freeing the last, so a pass bound every frame with
    // uniform flags grew the heap by megabytes a frame.
    let resolve_params = storage(
        device,
        "treelight resolve",
        size_of::<crate::GpuResolve>() as u64,
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
        size_of::<crate::GpuTemporal>() as u64,
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
    // Pass k writes either image (reading the other): the last pass of a run writes the first.
    let denoise_bind_groups = (0..crate::DENOISE_PASSES)
        .map(|k| {
            let pass_params = device.create_buffer_with_data(&BufferInitDescriptor {
                label: Some("treelight denoise pass"),
                contents: &crate::denoise_pass_bytes(size.x, size.y, k),
                // Not a uniform buffer, as for the resolve's parameters above.
                usage: BufferUsages::STORAGE,
            });
            [0, 1].map(|target| {
                device.create_bind_group(
                    "treelight denoise",
                    &cache.get_bind_group_layout(&pipelines.denoise_layout),
                    &BindGroupEntries::sequential((
                        accum.as_entire_binding(),
                        aux.as_entire_binding(),
                        pass_params.as_entire_binding(),
                        denoised[1 - target].as_entire_binding(),
                        denoised[target].as_entire_binding(),
                        guides.as_entire_binding(),
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
    let environment_word = environment.uniform();
    if scene.too_large.is_some() {
        // Nothing is traced, so nothing waits for a kernel.
        stats.update(|f| f.preparing_kernel = None);
        return;
    }
    let max_bytes = max_binding_bytes(&device);
    let trace_pipeline = pipelines.trace_pipeline(&pipeline_cache, scene.split());
    // On a software adapter the views wait for their kernel's warm-up (`kernel_warmup.rs`).
    let kernel = TraceKernel::of(scene.split());
    // Without a path-traced view nothing waits.
    let waited = warmup
        .filter(|_| !views.is_empty())
        .and_then(|mut w| w.wait(kernel));
    stats.update(|f| {
        f.preparing_kernel = waited.map(|waited_s| crate::PreparingKernel {
            split: kernel == TraceKernel::Split,
            waited_s,
        })
    });
    let trace_ready = pipeline_cache
        .get_compute_pipeline(trace_pipeline)
        .is_some()
        && scene.bind_group.is_some()
        && waited.is_none();
    let now = Instant::now();
    for (entity, camera, extracted, target, depth, settings, main_entity) in &views {
        let viewport = extracted.viewport;
        if viewport.z == 0 || viewport.w == 0 {
            continue;
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
        // The denoiser's guides, a view's largest buffer, are one binding too.
        let view_bytes = crate::guide_bytes(size.x, size.y)
            .max(crate::aux_bytes(size.x, size.y))
            .max(size.x as u64 * size.y as u64 * 16);
        if view_bytes > max_bytes {
            let why = format!(
                "a {}×{} view needs {} in one buffer and this adapter binds at most {}",
                size.x,
                size.y,
                size_text(view_bytes),
                size_text(max_bytes)
            );
            stats.update(|f| {
                f.trace_off.get_or_insert(why);
            });
            continue;
        }
        let clip_from_world = extracted.clip_from_world.unwrap_or_else(|| {
            extracted.clip_from_view * extracted.world_from_view.affine().inverse()
        });
        let world_from_clip = clip_from_world.inverse();
        let camera_relative = camera_relative(extracted);
        let key = AccumulationKey {
            world_from_clip,
            scene_generation: scene.generation,
            texture_generation: layers.generation,
            tree_generation: if settings.view == DebugView::Heatmap {
                scene.tree_generation
            } else {
                0
            },
            environment: (environment.generation, environment_word),
            settings: PathTraced {
                max_samples: 0,
                frame_budget_ms: 0.0,
                frame_budget_share: 0.0,
                frame_budget_share_while_filling: 0.0,
                // The outline is drawn by the resolve, over the samples, and the denoiser
                // filters them.
                outline: OutlineStyle::default(),
                denoise: false,
                temporal: false,
                ..*settings
            },
            exposure: camera.exposure,
            size,
        };
        let state = states.0.entry(entity).or_insert_with(|| {
            ViewState::new(
                view_buffers(&device, &pipelines, &pipeline_cache, size, &scene),
                TraceTimer::new(&device, &queue),
            )
        });
        if state.buffers.size != size {
            // What a sample costs survives a resize; the tiles and the accumulation do not.
            state.buffers = view_buffers(&device, &pipelines, &pipeline_cache, size, &scene);
            state.order = TileOrder::new(size.x, size.y);
            state.key = None;
            state.last_picture = None;
        }
        if state.buffers.outline_version != scene.outline_version {
            let b = &mut state.buffers;
            b.resolve_bind_groups = resolve_groups(
                &device,
                &pipelines,
                &pipeline_cache,
                [
                    &b.accum,
                    &b.aux,
                    &b.resolve_params,
                    &b.denoised[0],
                    &b.guides,
                ],
                &b.shown,
                &scene,
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
                .observe_frame(samples, (now - then).as_secs_f64() * 1e9);
        }
        if !trace_ready {
            continue;
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
        }
        state
            .clock
            .scene_size(scene.capacities[BufferKind::Triangles.index()]);
        let work = state.next_work(settings, restart, scene.filling);
        let traced = work.map_or(0, |(_, n)| n);
        state.last_frame = Some((now, traced));
        let mut timing = None;
        let dispatch = work.map(|(work, samples)| {
            let sky = settings.sky;
            // The preview is one sample per block, shown for a frame: one bounce and a tight cap
            // on indirect light keep it from flickering with fireflies while the camera moves.
            let preview = matches!(work, TraceWork::Preview { .. });
            let (bounces, clamp) = if !preview {
                (
                    settings.max_bounces.min(64),
                    settings.indirect_clamp.max(0.0),
                )
            } else if settings.indirect_clamp > 0.0 {
                (
                    settings.max_bounces.min(1),
                    settings.indirect_clamp.min(1.0),
                )
            } else {
                // An uncapped view still gets the cap in its preview.
                (settings.max_bounces.min(1), 1.0)
            };
            let params = ViewParams {
                world_from_clip: camera_relative.0,
                origin: camera_relative.1,
                sky: Vec3::new(sky.red, sky.green, sky.blue),
                exposure: camera.exposure,
                width: size.x,
                height: size.y,
                root: scene.root,
                max_bounces: bounces,
                samples: settings.samples_per_frame.clamp(1, 64),
                mode: settings.view.shader_index(),
                light_count: scene.light_count,
                indirect_clamp: clamp,
                work,
                part_shift: scene.layout.shift,
                seed: settings.seed,
                environment: environment_word,
            };
            queue.write_buffer(&state.buffers.view_uniform, 0, &params.to_bytes());
            let epoch = state.clock.epoch();
            timing = state.timer.as_mut().and_then(|t| t.assign(samples, epoch));
            let (x, y) = params.workgroups();
            UVec2::new(x, y)
        });
        // The preview stands in for pixels without a sample until a whole sweep has run.
        let sweeps = state.cursor.sweeps(&state.order);
        // The denoiser, in the path-traced view only, runs when a sweep over the image completes
        // (every pixel has new samples) and the sweeps have doubled since it last ran, and once at
        // a view's sample limit: its result improves most early, and on a software adapter one
        // run costs about a frame. Not over an empty scene (the sky has no noise to filter), nor
        // while the tree fills (the next frame's triangles restart the picture it would filter).
        let denoising = settings.denoise
            && settings.view == DebugView::PathTraced
            && scene.has_geometry()
            && !scene.filling
            && pipeline_cache
                .get_compute_pipeline(pipelines.denoise)
                .is_some();
        let spf = u64::from(settings.samples_per_frame.clamp(1, 64));
        let due = sweeps.is_power_of_two()
            || (settings.max_samples > 0 && sweeps * spf >= u64::from(settings.max_samples));
        let denoise = (denoising && sweeps > 0 && due && state.denoised_sweeps != Some(sweeps))
            .then_some((pipelines.denoise, crate::denoise_passes(sweeps * spf)));
        if denoise.is_some() {
            state.denoised_sweeps = Some(sweeps);
        }
        let shown_preview = if sweeps == 0 { state.preview_scale } else { 0 };
        // Temporal reuse, with the denoiser, in the path-traced view.
        let temporal = (denoising && settings.temporal)
            .then(|| {
                pipeline_cache
                    .get_compute_pipeline(pipelines.temporal)
                    .map(|_| pipelines.temporal)
            })
            .flatten();
        // The picture changes only with new samples, a denoised result or a restart: an idle view
        // shows the last one again without running the pass.
        let picture_changes =
            restart || work.is_some() || denoise.is_some() || state.last_picture.is_none();
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
            let reproject = state.last_picture.unwrap_or(Mat4::IDENTITY) * world_from_clip;
            queue.write_buffer(
                &state.buffers.temporal_params,
                0,
                &crate::temporal_bytes(
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
        queue.write_buffer(
            &state.buffers.resolve_params,
            0,
            &ResolveParams {
                origin: Vec2::new(viewport.x as f32, viewport.y as f32),
                viewport: Vec2::new(viewport.z as f32, viewport.w as f32),
                size: [size.x, size.y],
                preview_scale: shown_preview,
                outline_slots: scene.outline_slots,
                outline: settings.outline,
                outline_rect: outline_rect(
                    scene.outline_bounds,
                    clip_from_world,
                    viewport,
                    settings.outline.width + viewport.z as f32 / size.x as f32 + 1.0,
                ),
                denoised: denoising && state.denoised_sweeps.is_some(),
                temporal: temporal.is_some(),
            }
            .to_bytes(),
        );
        let msaa = target
            .sampled_main_texture()
            .map_or(1, |t| t.sample_count());
        state.frame = Some(ViewFrame {
            trace_pipeline,
            dispatch,
            clear: restart,
            timing,
            resolve_pipeline: pipelines.resolve_pipeline(
                &pipeline_cache,
                target.main_texture_format(),
                msaa,
                depth.is_some(),
            ),
            writes_depth: depth.is_some(),
            viewport,
            denoise,
            temporal: run_temporal,
            parity,
        });
        let samples = (sweeps * settings.samples_per_frame.clamp(1, 64) as u64) as u32;
        let figures = TraceFigures {
            traced_per_frame: traced,
            cost: state.clock.cost(),
            previewing: work.is_some_and(|(w, _)| matches!(w, TraceWork::Preview { .. })),
            geometry: traced > 0 && scene.has_geometry(),
            panorama: environment_word.w as u32 & 1 != 0,
        };
        stats.update(|f| {
            f.samples.insert(main_entity.id(), samples);
            f.traces.insert(main_entity.id(), figures);
        });
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
