//! From a [`ChangeSet`] to the buffer writes a renderer issues: only changed records, buffers grown by
//! doubling (the old contents copied on the GPU), and a byte count for the figure the UI shows.

use std::ops::Range;
use treelight_bvh::{Bvh, ChangeSet, GpuCompressedNode, GpuInstance, GpuTriangle};

/// Bytes of one node record (the compressed 4-wide record of `Bvh::gpu_wide_node`, one per inner
/// node).
pub const NODE_BYTES: u64 = size_of::<GpuCompressedNode>() as u64;
/// Bytes of one triangle record.
pub const TRIANGLE_BYTES: u64 = size_of::<GpuTriangle>() as u64;
/// Bytes of one instance record.
pub const INSTANCE_BYTES: u64 = size_of::<GpuInstance>() as u64;

/// The GPU buffers of the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BufferKind {
    /// Inner node records.
    Nodes,
    /// Triangle records.
    Triangles,
    /// Instance records.
    Instances,
    /// Per-triangle shading records (normals, UVs, group).
    Attributes,
    /// Per-group records (normal matrix, material).
    Objects,
    /// Light records.
    Lights,
}

impl BufferKind {
    /// Every buffer, in binding order.
    pub const ALL: [BufferKind; 6] = [
        BufferKind::Nodes,
        BufferKind::Triangles,
        BufferKind::Instances,
        BufferKind::Attributes,
        BufferKind::Objects,
        BufferKind::Lights,
    ];

    /// The buffer's position in [`BufferKind::ALL`] (its declaration order).
    pub fn index(self) -> usize {
        self as usize
    }

    /// What the buffer holds, for messages.
    pub fn label(self) -> &'static str {
        match self {
            BufferKind::Nodes => "tree nodes",
            BufferKind::Triangles => "triangles",
            BufferKind::Instances => "instances",
            BufferKind::Attributes => "shading records",
            BufferKind::Objects => "object records",
            BufferKind::Lights => "lights",
        }
    }

    /// Bytes of one record.
    pub fn record_bytes(self) -> u64 {
        match self {
            BufferKind::Nodes => NODE_BYTES,
            BufferKind::Triangles => TRIANGLE_BYTES,
            BufferKind::Instances => INSTANCE_BYTES,
            BufferKind::Attributes => crate::ATTRIBUTE_BYTES,
            BufferKind::Objects => crate::OBJECT_BYTES,
            BufferKind::Lights => crate::LIGHT_BYTES,
        }
    }
}

/// One `write_buffer` call.
#[derive(Clone, Debug, PartialEq)]
pub struct BufferWrite {
    /// Target buffer.
    pub buffer: BufferKind,
    /// Byte offset.
    pub offset: u64,
    /// Little-endian record bytes.
    pub bytes: Vec<u8>,
}

/// What to do to bring the GPU copy up to date with one change set.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UploadPlan {
    /// Buffers that must grow first, with their new capacity in records (old contents are kept).
    pub grow: Vec<(BufferKind, u64)>,
    /// Writes, after growth.
    pub writes: Vec<BufferWrite>,
    /// The root reference.
    pub root: u32,
}

/// The longest stretch of unchanged records, in bytes, that a plan rewrites (with their current
/// contents) to join the changed records on either side into one write. Each write is a staging
/// buffer and a copy command: an update pass that touched every other node record would otherwise
/// be millions of writes, seconds of frame time and millions of small allocations in the driver.
pub const JOIN_GAP_BYTES: u64 = 4096;

/// The unchanged records of `kind` a plan rewrites to join two writes (see [`JOIN_GAP_BYTES`]).
pub fn join_gap(kind: BufferKind) -> u32 {
    (JOIN_GAP_BYTES / kind.record_bytes()) as u32
}

/// Records a buffer must hold to fit `needed`, doubling from `current` (at least 1024).
pub fn grown_capacity(current: u64, needed: u64) -> u64 {
    let mut cap = current.max(1024);
    while cap < needed {
        cap *= 2;
    }
    cap
}

/// The 64 bytes of a node record.
pub fn node_bytes(n: &GpuCompressedNode) -> Vec<u8> {
    bytemuck::bytes_of(n).to_vec()
}

/// The 36 bytes of a triangle record.
pub fn triangle_bytes(t: &GpuTriangle) -> Vec<u8> {
    bytemuck::bytes_of(t).to_vec()
}

/// The 112 bytes of an instance record.
pub fn instance_bytes(i: &GpuInstance) -> Vec<u8> {
    bytemuck::bytes_of(i).to_vec()
}

impl UploadPlan {
    /// The plan for `changes`, given the capacities (in records) the GPU buffers have now.
    /// Consecutive changed records become one write each, and so do changed records no more than
    /// [`join_gap`] records apart (the records between rewritten as they are). A node record holds
    /// its children's binary records, so the changed nodes' parents are rewritten with them
    /// (`Bvh::gpu_wide_ranges`).
    pub fn new(bvh: &Bvh, changes: &ChangeSet, capacities: [u64; 3]) -> Self {
        let mut plan = UploadPlan {
            root: bvh.gpu_root(),
            ..Default::default()
        };
        let needed = [
            (BufferKind::Nodes, changes.inner_capacity as u64),
            (BufferKind::Triangles, changes.triangle_capacity as u64),
            (BufferKind::Instances, changes.instance_capacity as u64),
        ];
        for ((kind, need), cap) in needed.into_iter().zip(capacities) {
            if need > cap {
                plan.grow.push((kind, grown_capacity(cap, need)));
            }
        }
        push_ranges(
            &mut plan.writes,
            BufferKind::Nodes,
            joined(bvh.gpu_wide_ranges(changes), join_gap(BufferKind::Nodes)),
            |i, out| out.extend_from_slice(bytemuck::bytes_of(&bvh.gpu_wide_node(i))),
        );
        let mut tris: Vec<u32> = changes
            .written_triangles
            .iter()
            .chain(&changes.removed_triangles)
            .copied()
            .collect();
        tris.sort_unstable();
        tris.dedup();
        let gap = join_gap(BufferKind::Triangles);
        push_runs(
            &mut plan.writes,
            BufferKind::Triangles,
            &tris,
            gap,
            |t, out| {
                out.extend_from_slice(bytemuck::bytes_of(&bvh.gpu_triangle(t)));
            },
        );
        let mut instances = changes.instances.clone();
        instances.sort_unstable();
        instances.dedup();
        push_runs(
            &mut plan.writes,
            BufferKind::Instances,
            &instances,
            join_gap(BufferKind::Instances),
            |i, out| {
                out.extend_from_slice(bytemuck::bytes_of(&bvh.gpu_instance(i)));
            },
        );
        plan
    }

    /// Bytes this plan uploads (growth copies stay on the GPU and are not counted).
    pub fn upload_bytes(&self) -> u64 {
        self.writes
            .iter()
            .map(|w| w.bytes.len() as u64)
            .sum::<u64>()
            + 4
    }
}

/// Sorted disjoint `ranges`, those at most `gap` apart joined into one, as they are read.
fn joined(
    ranges: impl IntoIterator<Item = Range<u32>>,
    gap: u32,
) -> impl Iterator<Item = Range<u32>> {
    let mut ranges = ranges.into_iter().peekable();
    std::iter::from_fn(move || {
        let mut r = ranges.next()?;
        while let Some(next) = ranges.next_if(|n| n.start - r.end <= gap) {
            r.end = next.end;
        }
        Some(r)
    })
}

/// One write per range of records, each record's bytes appended by `put`, called for every id of
/// the range in order: no buffer per record, so a large change set costs one allocation per range.
fn push_ranges(
    out: &mut Vec<BufferWrite>,
    buffer: BufferKind,
    ranges: impl IntoIterator<Item = Range<u32>>,
    mut put: impl FnMut(u32, &mut Vec<u8>),
) {
    let record = buffer.record_bytes();
    for r in ranges {
        let mut bytes = Vec::with_capacity(r.len() * record as usize);
        for id in r.clone() {
            put(id, &mut bytes);
        }
        out.push(BufferWrite {
            buffer,
            offset: r.start as u64 * record,
            bytes,
        });
    }
}

/// One write per run of `ids` (sorted, each once) no more than `gap` records apart
/// ([`push_ranges`]), so `put` sees the ids between them too; with `gap` 0, exactly `ids`.
pub(crate) fn push_runs(
    out: &mut Vec<BufferWrite>,
    buffer: BufferKind,
    ids: &[u32],
    gap: u32,
    put: impl FnMut(u32, &mut Vec<u8>),
) {
    let runs = joined(ids.iter().map(|&i| i..i + 1), gap);
    push_ranges(out, buffer, runs, put);
}
