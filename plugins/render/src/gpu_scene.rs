//! The scene's GPU buffers in the render world: grown by doubling (old contents copied on the GPU),
//! then patched with the frame's writes.

use crate::PathTracerStats;
use crate::extract::SceneSync;
use crate::upload::{BufferKind, grown_capacity};
use bevy::prelude::*;
use bevy::render::render_resource::{
    Buffer, BufferDescriptor, BufferUsages, CommandEncoderDescriptor,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::{Render, RenderStartup, RenderSystems};

pub(crate) fn build(render_app: &mut SubApp) {
    render_app
        .add_systems(RenderStartup, init_gpu_scene)
        .add_systems(
            Render,
            apply_scene_uploads.in_set(RenderSystems::PrepareResources),
        );
}

/// The scene as the kernels read it.
#[derive(Resource)]
pub(crate) struct GpuScene {
    /// In [`BufferKind::ALL`] order.
    pub buffers: Vec<Buffer>,
    /// Records each buffer holds.
    capacities: [u64; 6],
    pub root: u32,
    pub light_count: u32,
    /// Raised by every upload that changes what a ray sees (geometry, materials, lights, textures):
    /// views restart their accumulation when it changes.
    pub generation: u64,
    /// Raised by every upload that changes the tree, including pure restructurings, which leave
    /// the traced image as it was but not the traversal heatmap.
    pub tree_generation: u64,
}

fn create(device: &RenderDevice, kind: BufferKind, records: u64) -> Buffer {
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

fn init_gpu_scene(mut commands: Commands, device: Res<RenderDevice>) {
    // Lights start small; the rest at the doubling floor.
    let capacities = BufferKind::ALL.map(|k| match k {
        BufferKind::Lights => 16,
        _ => grown_capacity(0, 1),
    });
    let buffers = BufferKind::ALL
        .iter()
        .zip(capacities)
        .map(|(&k, c)| create(&device, k, c))
        .collect();
    commands.insert_resource(GpuScene {
        buffers,
        capacities,
        root: u32::MAX,
        light_count: 0,
        generation: 0,
        tree_generation: 0,
    });
}

pub(crate) fn apply_scene_uploads(
    mut sync: ResMut<SceneSync>,
    mut scene: ResMut<GpuScene>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    stats: Res<PathTracerStats>,
) {
    let pending = std::mem::take(&mut sync.pending);
    let scene = &mut *scene;
    let mut grown = Vec::new();
    for (i, &kind) in BufferKind::ALL.iter().enumerate() {
        let need = pending.needed[i];
        if need <= scene.capacities[i] {
            continue;
        }
        let cap = grown_capacity(scene.capacities[i], need);
        let bigger = create(&device, kind, cap);
        grown.push((
            std::mem::replace(&mut scene.buffers[i], bigger),
            scene.capacities[i] * kind.record_bytes(),
            i,
        ));
        scene.capacities[i] = cap;
    }
    if !grown.is_empty() {
        // Keep what is already on the GPU: records outside this frame's writes stay valid.
        let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor {
            label: Some("treelight buffer growth"),
        });
        for (old, bytes, i) in &grown {
            encoder.copy_buffer_to_buffer(old, 0, &scene.buffers[*i], 0, *bytes);
        }
        queue.submit([encoder.finish()]);
    }
    let mut bytes = 0u64;
    for w in &pending.writes {
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
        queue.write_buffer(&scene.buffers[i], w.offset, &w.bytes);
        bytes += w.bytes.len() as u64;
    }
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
    if pending.geometry_changed {
        scene.generation += 1;
    }
    if tree_changed || pending.geometry_changed {
        scene.tree_generation += 1;
    }
    let ready = pending.root.is_some();
    stats.update(|f| {
        if bytes > 0 {
            f.last_upload_bytes = bytes;
            f.total_upload_bytes += bytes;
            f.uploads += 1;
        }
        f.scene_ready |= ready;
    });
}
