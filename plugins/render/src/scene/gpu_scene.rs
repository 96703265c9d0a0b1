//! Prepare, the scene: its GPU buffers (grown to what is coming and an eighth more, old contents
//! copied on the GPU, then patched with the frame's writes) and the scene bind group (made again
//! only when a buffer or the texture array grew).

use crate::kernels::pipelines::PathTracerPipelines;
use crate::scene::pending::PendingUpload;
use crate::scene::staging::UploadBelt;
use crate::scene::texture_layers::TextureLayers;
use crate::sky::environment::GpuEnvironment;
use crate::types::figures::PathTracerStats;
use crate::types::parts::too_few_bindings;
use crate::types::parts::{PartLayout, part_bindings, part_count};
use crate::types::upload::{BufferKind, Writes};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntry, BindingResource, Buffer, BufferBinding, BufferDescriptor,
    BufferInitDescriptor, BufferUsages, CommandEncoderDescriptor, PipelineCache,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::{Render, RenderStartup, RenderSystems};

pub(crate) fn build(render_app: &mut SubApp) {
    render_app
        .add_systems(RenderStartup, init_gpu_scene)
        .add_systems(
            Render,
            (
                apply_scene_uploads.in_set(RenderSystems::PrepareResources),
                prepare_scene_bind_group.in_set(RenderSystems::PrepareBindGroups),
            ),
        );
}

/// The scene as the kernels read it.
#[derive(Resource)]
pub(crate) struct GpuScene {
    /// In [`BufferKind::ALL`] order, each kind's parts (one until a part is full).
    pub(crate) buffers: Vec<Vec<Buffer>>,
    /// Records each kind holds, all its parts together.
    pub(crate) capacities: [u64; BufferKind::COUNT],
    /// How the large kinds are split across bindings on this adapter.
    pub layout: PartLayout,
    /// Bound where a kind has fewer parts than the kernel declares.
    pub(crate) stand_in: Buffer,
    /// The GGX lobe's albedo table (`energy.rs`), written once.
    pub(crate) energy: Buffer,
    pub root: u32,
    pub light_count: u32,
    /// Groups in the emitters' table after the lights (`EmitterList`), and the sum of their
    /// triangles' weights.
    pub emitters: (u32, f32),
    /// Raised by every upload that changes what a ray sees (geometry, materials, lights, textures):
    /// views restart their accumulation when it changes.
    pub generation: u64,
    /// Raised by every upload that changes the tree, including pure restructurings, which leave
    /// the traced image as it was but not the traversal heatmap.
    pub tree_generation: u64,
    /// Group 0 of the trace kernel over the current buffers and texture array; `None` after a
    /// buffer grew, until it is made again.
    pub bind_group: Option<BindGroup>,
    /// Records of each kind the kernels may read (the most any frame needed): the bind group
    /// covers these, not the buffers' room to grow ([`PartLayout::bound_sizes`]).
    pub(crate) in_use: [u64; BufferKind::COUNT],
    /// What `in_use` was when the bind group was made.
    pub(crate) bound: [u64; BufferKind::COUNT],
    /// The texture array's and the panorama's versions the bind group was made with.
    pub(crate) bound_array: u64,
    pub(crate) bound_environment: u64,
    /// Two bits of outline per object slot, read by the views' resolve passes.
    pub(crate) outlines: Buffer,
    /// Words `outlines` holds.
    pub(crate) outline_capacity: u64,
    /// Slots the outline words cover; 0 when nothing is outlined.
    pub outline_slots: u32,
    /// Raised when `outlines` is replaced by a bigger buffer: views make their resolve groups again.
    pub(crate) outline_version: u64,
    /// World-space bounds of the outlined meshes; `None` when unknown.
    pub(crate) outline_bounds: Option<[Vec3; 2]>,
    /// The sets of per-map UV transforms the object records name (`map_transforms.rs`), written
    /// whole when the table grows.
    pub(crate) map_transforms: Buffer,
    /// Why the scene cannot be traced on this adapter (a buffer larger than it can bind), once
    /// that happened: nothing is bound or written from then on, and no view is traced.
    pub too_large: Option<String>,
    /// Whether new geometry was on its way into the scene's tree as of this frame's extract.
    pub filling: bool,
    /// Where the frame's record writes are staged.
    pub(crate) staging: UploadBelt,
    /// The copies recorded this frame and not yet submitted (buffer growth, the rounds the
    /// extraction streamed), submitted first when the frame's uploads are.
    pub(crate) streamed: Option<wgpu::CommandEncoder>,
    /// Bytes the extraction streamed this frame, and whether some of them were node records.
    pub(crate) streamed_bytes: u64,
    pub(crate) streamed_nodes: bool,
}

impl GpuScene {
    /// The encoder this frame's uploads are recorded into: the one the frame opened (growth
    /// copies, the extraction's rounds), or a new one.
    fn upload_encoder(&mut self, device: &RenderDevice) -> wgpu::CommandEncoder {
        self.streamed.take().unwrap_or_else(|| {
            device.create_command_encoder(&CommandEncoderDescriptor {
                label: Some("treelight scene upload"),
            })
        })
    }

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
pub(crate) fn max_binding_bytes(device: &RenderDevice) -> u64 {
    let limits = device.limits();
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
}

/// A size for messages: whole MiB, or KiB below one MiB.
pub(crate) fn size_text(bytes: u64) -> String {
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
            BufferKind::Positions => "treelight positions",
            BufferKind::Instances => "treelight instances",
            BufferKind::Attributes => "treelight triangle shading",
            BufferKind::ShadingVertices => "treelight shading vertices",
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
    // Lights start small; the rest at the growth floor, 1024 (or a part, if that is smaller).
    let capacities = BufferKind::ALL.map(|k| match k {
        BufferKind::Lights => 16,
        _ => layout.grown(k, 0, 1, 0).unwrap_or(1),
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
            contents: crate::types::energy::energy_bytes(),
            usage: BufferUsages::UNIFORM,
        }),
        root: u32::MAX,
        light_count: 0,
        emitters: (0, 0.0),
        generation: 0,
        tree_generation: 0,
        bind_group: None,
        in_use: [0; BufferKind::COUNT],
        bound: [0; BufferKind::COUNT],
        bound_array: 0,
        bound_environment: 0,
        outlines: outline_buffer(&device, 64),
        outline_capacity: 64,
        outline_slots: 0,
        outline_version: 0,
        outline_bounds: None,
        map_transforms: map_transform_buffer(
            &device,
            &crate::types::map_transforms::MapTransformTable::default().bytes(),
        ),
        too_large,
        filling: false,
        staging: UploadBelt::new(device.wgpu_device()),
        streamed: None,
        streamed_bytes: 0,
        streamed_nodes: false,
    });
}

/// Grows the buffers that must hold more records, then writes the frame's records: after the
/// rounds the extraction streamed, what it left.
fn apply_scene_uploads(
    mut next: ResMut<PendingUpload>,
    mut scene: ResMut<GpuScene>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    stats: Res<PathTracerStats>,
) {
    let mut pending = std::mem::take(&mut *next);
    scene.filling = pending.filling;
    let scene = &mut *scene;
    if grow_recorded(scene, &pending.needed, &pending.expected, &device, &stats).is_none() {
        return;
    }
    for (in_use, needed) in scene.in_use.iter_mut().zip(pending.needed) {
        *in_use = (*in_use).max(needed);
    }
    if scene.in_use != scene.bound {
        // The kernels may read records past what the bind group covers.
        scene.bind_group = None;
    }
    if scene.bind_group.is_none() {
        // A buffer grew or a part was added.
        let total: u64 = scene.buffers.iter().flatten().map(|b| b.size()).sum();
        stats.update(|f| f.scene_buffer_bytes = total);
    }
    // The extraction's copies and growth copies first, then the writes, in rounds of bounded
    // staging.
    let submit = scene.streamed.is_some();
    let encoder = scene.upload_encoder(&device);
    let bytes = stage_writes(scene, &pending.writes, encoder, &queue, submit)
        + std::mem::take(&mut scene.streamed_bytes);
    scene.staging.recall(pending.filling);
    let mut tree_changed = std::mem::take(&mut scene.streamed_nodes)
        || pending.writes.iter().any(|w| w.buffer == BufferKind::Nodes);
    if let Some(root) = pending.root
        && root != scene.root
    {
        scene.root = root;
        tree_changed = true;
    }
    if let Some(n) = pending.light_count {
        scene.light_count = n;
    }
    if let Some(e) = pending.emitters {
        scene.emitters = e;
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
            f.largest_upload_bytes = f.largest_upload_bytes.max(bytes);
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
        next.writes = writes;
    }
}

/// Records the copies of `writes` after what `encoder` holds and submits them, in rounds of
/// bounded staging ([`UploadBelt::write`]): a frame that rewrites a large scene holds one round of
/// staging beside its writes, not a second copy of them. Returns the bytes written; submits
/// nothing when there was nothing to do (`holds_copies`: the encoder already holds copies).
fn stage_writes(
    scene: &mut GpuScene,
    writes: &Writes,
    mut encoder: wgpu::CommandEncoder,
    queue: &wgpu::Queue,
    holds_copies: bool,
) -> u64 {
    let bytes = record_writes(scene, writes, &mut encoder, queue);
    scene.staging.finish();
    if holds_copies || bytes > 0 {
        queue.submit([encoder.finish()]);
    }
    bytes
}

/// Records into `encoder` the staged copies of `writes` (a round's worth submitted and waited for
/// whenever one is staged: [`UploadBelt::write`]). Returns the bytes written.
fn record_writes(
    scene: &mut GpuScene,
    writes: &Writes,
    encoder: &mut wgpu::CommandEncoder,
    queue: &wgpu::Queue,
) -> u64 {
    let layout = scene.layout;
    let mut bytes = 0u64;
    for w in writes.iter() {
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
            let target = &scene.buffers[i][part];
            if !scene.staging.write(encoder, queue, target, at, piece) {
                error!(
                    "treelight: dropped a {:?} write of {} bytes at {at}: not whole words",
                    w.buffer,
                    piece.len()
                );
            }
        }
        bytes += w.bytes.len() as u64;
    }
    bytes
}

/// The scene's buffers as the extraction sees them: a frame whose writes reach a staging round
/// ([`crate::scene::staging::ROUND_BYTES`]) hands them over round by round while it makes them,
/// so it holds one round of records at a time instead of all of them (a fill's frame can write
/// hundreds of megabytes).
#[derive(SystemParam)]
pub(crate) struct StreamTarget<'w> {
    scene: Option<ResMut<'w, GpuScene>>,
    device: Res<'w, RenderDevice>,
    queue: Res<'w, RenderQueue>,
    stats: Res<'w, PathTracerStats>,
}

impl StreamTarget<'_> {
    /// Publishes the heap bytes of the node records' layout
    /// ([`PathTracerFigures::record_layout_bytes`](crate::types::figures::PathTracerFigures::record_layout_bytes)).
    pub(crate) fn set_record_layout_bytes(&self, bytes: u64) {
        self.stats.update(|f| f.record_layout_bytes = bytes);
    }

    /// Grows the buffers to hold `needed` records of each kind (and `expected`, as
    /// [`PendingUpload::expected`] says), then stages `writes` and empties them; the copies go to
    /// the GPU with the frame's uploads, or sooner, a round at a time. Before the scene's buffers
    /// exist the writes are left as they are.
    pub(crate) fn flush(
        &mut self,
        writes: &mut Writes,
        needed: &[u64; BufferKind::COUNT],
        expected: &[u64; BufferKind::COUNT],
    ) {
        let Some(scene) = self.scene.as_deref_mut() else {
            return;
        };
        if grow_recorded(scene, needed, expected, &self.device, &self.stats).is_none() {
            // Nothing is written once the scene is too large to trace here.
            writes.clear();
            return;
        }
        let mut encoder = scene.upload_encoder(&self.device);
        scene.streamed_bytes += record_writes(scene, writes, &mut encoder, &self.queue);
        self.stats.update(|f| f.upload_rounds += 1);
        scene.streamed_nodes |= writes.iter().any(|w| w.buffer == BufferKind::Nodes);
        scene.streamed = Some(encoder);
        writes.clear();
    }
}

/// Grows the buffers to hold `needed` records of each kind (and `expected`: [`grow_buffers`]) and
/// records into the scene's open upload encoder the copies that keep their records: records
/// outside this frame's writes stay valid. `None` once the scene is too large to trace here: then
/// nothing is written, and the copies recorded this frame are dropped.
fn grow_recorded(
    scene: &mut GpuScene,
    needed: &[u64; BufferKind::COUNT],
    expected: &[u64; BufferKind::COUNT],
    device: &RenderDevice,
    stats: &PathTracerStats,
) -> Option<()> {
    let grown = match scene.too_large {
        None => grow_buffers(scene, needed, expected, device, stats),
        Some(_) => None,
    };
    let Some(grown) = grown else {
        scene.streamed = None;
        return None;
    };
    if !grown.is_empty() {
        let mut encoder = scene.upload_encoder(device);
        for (old, bytes, i, k) in &grown {
            encoder.copy_buffer_to_buffer(old, 0, &scene.buffers[*i][*k], 0, *bytes);
        }
        scene.streamed = Some(encoder);
    }
    Some(())
}

/// Grows the buffers that must hold more records: up to what the adapter binds, then the large
/// kinds add parts, each a binding of its own. Returns the old buffers whose contents are to be
/// copied over (buffer, bytes, kind, part), or `None` once the scene outgrows the parts the kernel
/// declares: tracing stops, with the reason in the figures.
fn grow_buffers(
    scene: &mut GpuScene,
    needed: &[u64; BufferKind::COUNT],
    expected: &[u64; BufferKind::COUNT],
    device: &RenderDevice,
    stats: &PathTracerStats,
) -> Option<Vec<(Buffer, u64, usize, usize)>> {
    let layout = scene.layout;
    let mut grown = Vec::new();
    for (i, &kind) in BufferKind::ALL.iter().enumerate() {
        let need = needed[i];
        if need <= scene.capacities[i] {
            continue;
        }
        let Some(cap) = layout.grown(kind, scene.capacities[i], need, expected[i]) else {
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
            return None;
        };
        let old_sizes = layout.part_sizes(kind, scene.capacities[i]);
        for (k, &records) in layout.part_sizes(kind, cap).iter().enumerate() {
            if old_sizes.get(k) == Some(&records) {
                continue;
            }
            let bigger = create(device, kind, records);
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
    Some(grown)
}

/// The most bytes of write buffer kept from frame to frame while nothing streams in.
const KEPT_WRITE_BYTES: u64 = 4 << 20;

/// Makes the scene bind group again when a buffer grew or the texture array was replaced.
pub(crate) fn prepare_scene_bind_group(
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
        let bound = scene
            .layout
            .bound_sizes(kind, scene.capacities[i], scene.in_use[i]);
        for (k, &binding) in part_bindings(kind).iter().enumerate() {
            let resource = match (scene.buffers[i].get(k), bound.get(k)) {
                (Some(buffer), Some(&records)) => BindingResource::Buffer(BufferBinding {
                    buffer,
                    offset: 0,
                    size: std::num::NonZeroU64::new(records * kind.record_bytes()),
                }),
                _ => scene.stand_in.as_entire_binding(),
            };
            entries.push(BindGroupEntry { binding, resource });
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
        binding: crate::types::map_transforms::MAP_TRANSFORMS_BINDING,
        resource: scene.map_transforms.as_entire_binding(),
    });
    entries.push(BindGroupEntry {
        binding: crate::types::energy::ENERGY_BINDING,
        resource: scene.energy.as_entire_binding(),
    });
    let [env_image, env_sampler, env_cdf] = crate::types::bindings::ENVIRONMENT_BINDINGS;
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
    scene.bound = scene.in_use;
    scene.bound_environment = environment.version;
}
