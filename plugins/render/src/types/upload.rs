//! From a [`ChangeSet`] to the buffer writes a renderer issues: only changed records, buffers grown by
//! an eighth more than they must hold (the old contents copied on the GPU), and a byte count for the
//! figure the UI shows.

use std::ops::Range;
use treelight_bvh::{
    Bvh, ChangeSet, GpuCompressedNode, GpuIndexedTriangle, GpuInstance, GpuPosition,
    PositionChanges, PositionPool, PositionSource, RecordChanges, WideRecords,
};

/// Bytes of one node record (the compressed 4-wide record of `WideRecords::record`, one per inner
/// node the traversal reads).
pub const NODE_BYTES: u64 = size_of::<GpuCompressedNode>() as u64;
/// Bytes of one triangle record (its corners in the position pool).
pub const TRIANGLE_BYTES: u64 = size_of::<GpuIndexedTriangle>() as u64;
/// Bytes of one record of the position pool: a float position and a 1, a `vec4` the kernels read
/// in one load (three floats, three loads, traced rays 9–13% slower on llvmpipe).
pub const POSITION_BYTES: u64 = size_of::<[f32; 4]>() as u64;
/// Bytes of one instance record.
pub const INSTANCE_BYTES: u64 = size_of::<GpuInstance>() as u64;

/// The GPU buffers of the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BufferKind {
    /// Inner node records.
    Nodes,
    /// Triangle records: three corners in the position pool.
    Triangles,
    /// The position pool: each group's vertices as the tree stores them, a run per group.
    Positions,
    /// Instance records.
    Instances,
    /// Per-triangle shading records (the corners in the shading vertices' pool).
    Attributes,
    /// The pool of shading vertices (normals, tangents, UVs), a run per mesh.
    ShadingVertices,
    /// Per-group records (normal matrix, material).
    Objects,
    /// Light records.
    Lights,
}

impl BufferKind {
    /// How many buffers there are.
    pub const COUNT: usize = 8;

    /// Every buffer, in binding order.
    pub const ALL: [BufferKind; BufferKind::COUNT] = [
        BufferKind::Nodes,
        BufferKind::Triangles,
        BufferKind::Positions,
        BufferKind::Instances,
        BufferKind::Attributes,
        BufferKind::ShadingVertices,
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
            BufferKind::Positions => "positions",
            BufferKind::Instances => "instances",
            BufferKind::Attributes => "shading records",
            BufferKind::ShadingVertices => "shading vertices",
            BufferKind::Objects => "object records",
            BufferKind::Lights => "lights",
        }
    }

    /// Bytes of one record.
    pub fn record_bytes(self) -> u64 {
        match self {
            BufferKind::Nodes => NODE_BYTES,
            BufferKind::Triangles => TRIANGLE_BYTES,
            BufferKind::Positions => POSITION_BYTES,
            BufferKind::Instances => INSTANCE_BYTES,
            BufferKind::Attributes => crate::types::shading::ATTRIBUTE_BYTES,
            BufferKind::ShadingVertices => crate::types::shading::SHADING_VERTEX_BYTES,
            BufferKind::Objects => crate::types::records::OBJECT_BYTES,
            BufferKind::Lights => crate::types::records::LIGHT_BYTES,
        }
    }
}

/// One write: record bytes for `buffer` at byte `offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BufferWrite<'a> {
    /// Target buffer.
    pub buffer: BufferKind,
    /// Byte offset.
    pub offset: u64,
    /// Little-endian record bytes.
    pub bytes: &'a [u8],
}

/// Record writes whose bytes share one growing buffer. A renderer keeps it from frame to frame
/// ([`Writes::clear`]): a fill's uploads are tens of megabytes a frame, and a fresh buffer each
/// frame would have the kernel zero that many new pages again every time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Writes {
    bytes: Vec<u8>,
    /// Target, offset and where the bytes are in `bytes`, in the order they were pushed.
    list: Vec<(BufferKind, u64, Range<usize>)>,
    /// [`Writes::push_records`]' record ids, kept for the same reason as `bytes` (a fill's frame
    /// has millions); empty between calls.
    ids: Vec<u32>,
}

impl Writes {
    /// Adds a write of `bytes` to `buffer` at byte `offset`.
    pub fn push(&mut self, buffer: BufferKind, offset: u64, bytes: &[u8]) {
        let start = self.bytes.len();
        self.bytes.extend_from_slice(bytes);
        self.list.push((buffer, offset, start..self.bytes.len()));
    }

    /// Adds one write per range of record ids, records of `T`'s size; the record with id `i`, the
    /// `j`th of all the ranges' ids, is `record(j, i)`. Made on rayon's threads: a fill's frame makes millions of
    /// records, and the frame (and the worker, waiting for the tree) waits for them.
    pub fn push_records<T: bytemuck::Pod>(
        &mut self,
        buffer: BufferKind,
        ranges: impl IntoIterator<Item = Range<u32>>,
        record: impl Fn(usize, u32) -> T + Sync,
    ) {
        use rayon::prelude::*;
        let size = size_of::<T>();
        // Offsets are counted in `T`s: they must be the buffer's records.
        assert_eq!(size as u64, buffer.record_bytes(), "{buffer:?} records");
        let start = self.bytes.len();
        let ids = &mut self.ids;
        ids.clear();
        for r in ranges {
            let at = start + ids.len() * size;
            self.list.push((
                buffer,
                r.start as u64 * size as u64,
                at..at + r.len() * size,
            ));
            ids.extend(r);
        }
        self.bytes.resize(start + ids.len() * size, 0);
        self.bytes[start..]
            .par_chunks_mut(size)
            .zip(ids.par_iter())
            .enumerate()
            .with_min_len(1024)
            .for_each(|(j, (out, &i))| out.copy_from_slice(bytemuck::bytes_of(&record(j, i))));
        ids.clear();
    }

    /// [`Writes::push_records`], handing the writes to `flush` each time they reach `round` bytes:
    /// a frame that rewrites a large scene then holds one round of records at a time, not all of
    /// them. Record `(j, i)` is as in `push_records`. What `flush` leaves in the writes stays, and
    /// the next round counts from it.
    pub fn push_records_in_rounds<T: bytemuck::Pod>(
        &mut self,
        buffer: BufferKind,
        ranges: impl IntoIterator<Item = Range<u32>>,
        record: impl Fn(usize, u32) -> T + Sync,
        round: u64,
        flush: &mut dyn FnMut(&mut Writes),
    ) {
        let size = size_of::<T>() as u64;
        // Bytes a flush left behind: not this round's.
        let mut floor = 0u64;
        let mut done = 0usize;
        let mut batch: Vec<Range<u32>> = Vec::new();
        let mut batch_records = 0u64;
        let mut ranges = ranges.into_iter();
        let mut rest: Option<Range<u32>> = None;
        while let Some(r) = rest.take().or_else(|| ranges.next()) {
            let used = self.byte_len() - floor + batch_records * size;
            // At least one record a round, so a round smaller than a record still moves on.
            let room = (round.saturating_sub(used) / size).max(1);
            let take = (r.len() as u64).min(room) as u32;
            batch.push(r.start..r.start + take);
            batch_records += u64::from(take);
            if take < r.len() as u32 {
                rest = Some(r.start + take..r.end);
            }
            if self.byte_len() - floor + batch_records * size >= round {
                let first = done;
                self.push_records(buffer, batch.drain(..), |j, i| record(first + j, i));
                done += batch_records as usize;
                batch_records = 0;
                flush(self);
                floor = self.byte_len();
            }
        }
        let first = done;
        self.push_records(buffer, batch, |j, i| record(first + j, i));
    }

    /// The writes, in the order they were added.
    pub fn iter(&self) -> impl Iterator<Item = BufferWrite<'_>> {
        self.list.iter().map(|(buffer, offset, range)| BufferWrite {
            buffer: *buffer,
            offset: *offset,
            bytes: &self.bytes[range.clone()],
        })
    }

    /// How many writes there are.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Bytes written, all writes together.
    pub fn byte_len(&self) -> u64 {
        self.bytes.len() as u64
    }

    /// Bytes held for writes to come: what [`Writes::clear`] keeps.
    pub fn capacity_bytes(&self) -> u64 {
        (self.bytes.capacity() + self.ids.capacity() * size_of::<u32>()) as u64
    }

    /// Forgets the writes and keeps the memory for the next ones.
    pub fn clear(&mut self) {
        self.bytes.clear();
        self.list.clear();
    }
}

/// What to do to bring the GPU copy up to date with one change set.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UploadPlan {
    /// Buffers that must grow first, with their new capacity in records (old contents are kept).
    pub grow: Vec<(BufferKind, u64)>,
    /// Writes, after growth.
    pub writes: Writes,
    /// The root reference.
    pub root: u32,
}

/// The layouts a plan writes from, each with what its update said to rewrite: the node records'
/// ([`WideRecords::update`]) and the position pool's ([`PositionPool::update`]).
#[derive(Clone, Copy)]
pub struct Layouts<'a> {
    /// The node records' layout and its changes.
    pub records: (&'a WideRecords, &'a RecordChanges),
    /// The position pool and its changes.
    pub positions: (&'a PositionPool, &'a PositionChanges),
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

/// Records a buffer grows to from `current` to hold `target`: an eighth more, in whole thousands
/// (1024s), never less than `current`. Doubling left up to half a large scene's buffers empty, and
/// each growth holds the old and the new buffer at once: the renderer grows once to what is coming
/// (the records an import is about to need), with room for edits after it.
pub fn grown_capacity(current: u64, target: u64) -> u64 {
    (target + target / 8)
        .next_multiple_of(1024)
        .max(current)
        .max(1024)
}

/// The 64 bytes of a node record.
pub fn node_bytes(n: &GpuCompressedNode) -> Vec<u8> {
    bytemuck::bytes_of(n).to_vec()
}

/// The 12 bytes of a triangle record.
pub fn triangle_bytes(t: &GpuIndexedTriangle) -> Vec<u8> {
    bytemuck::bytes_of(t).to_vec()
}

/// The 112 bytes of an instance record.
pub fn instance_bytes(i: &GpuInstance) -> Vec<u8> {
    bytemuck::bytes_of(i).to_vec()
}

impl UploadPlan {
    /// The plan for `changes`, given the capacities (in records) the GPU buffers have now: nodes,
    /// triangles, instances and positions. Consecutive changed records become one write each, and
    /// so do changed records no more than `join_gap` records apart (the records between rewritten
    /// as they are). `records`, the node records' layout, and `positions`, the position pool, are
    /// brought up to date with `changes` first ([`WideRecords::update`],
    /// [`PositionPool::update`]): they say which records hold what changed.
    pub fn new(
        bvh: &Bvh,
        records: &mut WideRecords,
        positions: &mut PositionPool,
        changes: &ChangeSet,
        capacities: [u64; 4],
    ) -> Self {
        Self::new_in(
            bvh,
            (records, positions),
            changes,
            capacities,
            Writes::default(),
        )
    }

    /// [`UploadPlan::new`], its writes added after those already in `writes` (a renderer's
    /// buffer, kept from frame to frame).
    pub fn new_in(
        bvh: &Bvh,
        layouts: (&mut WideRecords, &mut PositionPool),
        changes: &ChangeSet,
        capacities: [u64; 4],
        writes: Writes,
    ) -> Self {
        let (records, positions) = layouts;
        let moved = records.update(bvh, changes);
        let pooled = positions.update(bvh, changes);
        Self::streamed(
            bvh,
            Layouts {
                records: (records, &moved),
                positions: (positions, &pooled),
            },
            changes,
            capacities,
            writes,
            u64::MAX,
            &mut |_| {},
        )
    }

    /// [`UploadPlan::new_in`] with the layouts already updated (each with what its update said to
    /// rewrite), the writes handed to `flush` each time they reach `round` bytes
    /// ([`Writes::push_records_in_rounds`]); what is left when the plan is made is in its writes.
    /// The renderer must have grown its buffers to `changes`' capacities and the layouts' before
    /// the first flush.
    pub fn streamed(
        bvh: &Bvh,
        layouts: Layouts,
        changes: &ChangeSet,
        capacities: [u64; 4],
        writes: Writes,
        round: u64,
        flush: &mut dyn FnMut(&mut Writes),
    ) -> Self {
        let (layout, moved) = layouts.records;
        let (pool, pooled) = layouts.positions;
        let mut plan = UploadPlan {
            root: layout.root(bvh),
            writes,
            grow: Vec::new(),
        };
        let needed = [
            (BufferKind::Nodes, layout.capacity() as u64),
            (BufferKind::Triangles, changes.triangle_capacity as u64),
            (BufferKind::Instances, changes.instance_capacity as u64),
            (BufferKind::Positions, u64::from(pool.end())),
        ];
        for ((kind, need), cap) in needed.into_iter().zip(capacities) {
            if need > cap {
                plan.grow.push((kind, grown_capacity(cap, need)));
            }
        }
        plan.writes.push_records_in_rounds(
            BufferKind::Nodes,
            joined(moved.ranges.iter().cloned(), join_gap(BufferKind::Nodes)),
            |_, s| layout.record(bvh, s),
            round,
            flush,
        );
        position_writes(&mut plan.writes, bvh, layouts.positions, round, flush);
        let mut tris: Vec<u32> = changes
            .written_triangles
            .iter()
            .chain(&changes.removed_triangles)
            .chain(&pooled.triangles)
            .copied()
            .collect();
        tris.sort_unstable();
        tris.dedup();
        plan.writes.push_records_in_rounds(
            BufferKind::Triangles,
            runs(tris, join_gap(BufferKind::Triangles)),
            |_, t| pool.record(bvh, t),
            round,
            flush,
        );
        let mut instances = changes.instances.clone();
        instances.extend(&moved.instances);
        instances.sort_unstable();
        instances.dedup();
        plan.writes.push_records_in_rounds(
            BufferKind::Instances,
            runs(instances, join_gap(BufferKind::Instances)),
            |_, i| layout.instance(bvh, i),
            round,
            flush,
        );
        plan
    }

    /// Bytes this plan uploads (growth copies stay on the GPU and are not counted).
    pub fn upload_bytes(&self) -> u64 {
        self.writes.byte_len() + 4
    }
}

/// The position pool's writes for what its update said: runs that follow one another (a fill's
/// groups, laid end to end) as one write each, however many groups they hold.
fn position_writes(
    writes: &mut Writes,
    bvh: &Bvh,
    (pool, pooled): (&PositionPool, &PositionChanges),
    round: u64,
    flush: &mut dyn FnMut(&mut Writes),
) {
    let mut runs: Vec<(u32, &[treelight_bvh::glam::Vec3], PositionSource)> = pooled
        .runs
        .iter()
        .map(|&(first, source)| (first, pool.positions(bvh, source), source))
        .collect();
    runs.sort_unstable_by_key(|r| r.0);
    let mut k = 0;
    while k < runs.len() {
        let start = runs[k].0;
        let mut end = start;
        let mut last = k;
        while last < runs.len() && runs[last].0 == end {
            end += runs[last].1.len() as u32;
            last += 1;
        }
        let chain = &runs[k..last];
        writes.push_records_in_rounds(
            BufferKind::Positions,
            std::iter::once(start..end),
            |j, _| {
                let at = start + j as u32;
                let (first, positions, source) = chain[chain.partition_point(|r| r.0 <= at) - 1];
                GpuPosition::new(positions[(at - first) as usize], source)
            },
            round,
            flush,
        );
        k = last;
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

/// The runs of `ids` (sorted, each once) no more than `gap` records apart, as ranges of records:
/// one write each, the records between rewritten as they are; with `gap` 0, exactly `ids`.
pub(crate) fn runs(
    ids: impl IntoIterator<Item = u32>,
    gap: u32,
) -> impl Iterator<Item = Range<u32>> {
    joined(ids.into_iter().map(|i| i..i + 1), gap)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_made_in_parallel_land_in_order_after_earlier_writes() {
        let mut writes = Writes::default();
        writes.push(BufferKind::Lights, 8, &[1, 2, 3, 4]);
        // Enough records for several parallel pieces: triangle record (j, i) starts with both
        // numbers.
        let ranges = [5..8, 20..3000, 4000..9000];
        writes.push_records(BufferKind::Triangles, ranges.clone(), |j, i| {
            let mut record = [0u32; 3];
            record[..2].copy_from_slice(&[j as u32, i]);
            record
        });
        let all: Vec<BufferWrite> = writes.iter().collect();
        assert_eq!(all.len(), 4);
        assert_eq!(
            (all[0].buffer, all[0].offset, all[0].bytes),
            (BufferKind::Lights, 8, &[1u8, 2, 3, 4][..])
        );
        let mut j = 0u32;
        for (w, r) in all[1..].iter().zip(ranges) {
            assert_eq!(w.buffer, BufferKind::Triangles);
            assert_eq!(w.offset, r.start as u64 * TRIANGLE_BYTES);
            let words: &[u32] = bytemuck::cast_slice(w.bytes);
            for (record, i) in words.chunks(3).zip(r) {
                assert_eq!(record[..2], [j, i]);
                j += 1;
            }
        }
        assert_eq!(writes.byte_len(), 4 + TRIANGLE_BYTES * j as u64);
        writes.clear();
        assert!(writes.is_empty() && writes.capacity_bytes() >= TRIANGLE_BYTES * j as u64);
    }

    /// The writes' (buffer, offset, bytes) as one list of records: (offset of each record, its
    /// bytes), so writes cut at other places compare equal.
    fn records_of(writes: &Writes, size: usize) -> Vec<(u64, Vec<u8>)> {
        writes
            .iter()
            .flat_map(|w| {
                w.bytes
                    .chunks(size)
                    .enumerate()
                    .map(move |(k, b)| (w.offset + (k * size) as u64, b.to_vec()))
            })
            .collect()
    }

    proptest::proptest! {
        /// Records made in rounds are the records made at once, in the same order, with the same
        /// `(j, i)`; every round handed over holds at least `round` bytes and less than `round`
        /// plus a record more than it, and what is left holds less than a round.
        #[test]
        fn records_made_in_rounds_are_the_records_made_at_once(
            ranges in proptest::collection::vec((0u32..400, 0u32..60), 0..12),
            round_records in 1u64..40,
            before in 0usize..3,
        ) {
            // Sorted disjoint ranges from (gap, length) pairs.
            let mut at = 0u32;
            let ranges: Vec<Range<u32>> = ranges
                .into_iter()
                .map(|(gap, len)| {
                    let r = at + gap..at + gap + len;
                    at = r.end;
                    r
                })
                .collect();
            let record = |j: usize, i: u32| [j as u32, i, 7];
            let mut whole = Writes::default();
            let mut cut = Writes::default();
            for k in 0..before {
                whole.push(BufferKind::Lights, 4 * k as u64, &[k as u8; 4]);
                cut.push(BufferKind::Lights, 4 * k as u64, &[k as u8; 4]);
            }
            whole.push_records(BufferKind::Triangles, ranges.clone(), record);
            let round = round_records * TRIANGLE_BYTES;
            let mut handed: Vec<(u64, Vec<u8>)> = Vec::new();
            let mut sizes = Vec::new();
            cut.push_records_in_rounds(
                BufferKind::Triangles,
                ranges,
                record,
                round,
                &mut |w: &mut Writes| {
                    sizes.push(w.byte_len());
                    handed.extend(records_of(w, 4));
                    w.clear();
                },
            );
            for s in &sizes {
                proptest::prop_assert!(*s >= round && *s < round + TRIANGLE_BYTES, "a round of {s}");
            }
            proptest::prop_assert!(cut.byte_len() < round);
            handed.extend(records_of(&cut, 4));
            proptest::prop_assert_eq!(handed, records_of(&whole, 4));
        }
    }
}
