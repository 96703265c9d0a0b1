//! A scene buffer too large for one binding, split into parts: an adapter binds at most
//! `max_storage_buffer_binding_size` bytes of a buffer, so the nodes, triangles and shading records
//! of a large scene lie in several buffers of `1 << shift` records each, and the kernels read record
//! `i` as record `i & mask` of part `i >> shift` (`scene_parts.wgsl`). A scene that fits one part
//! has one buffer per kind, grown to what is coming and an eighth more (`grown_capacity`).

use crate::types::upload::BufferKind;

/// Parts the kernels declare for a kind (1 for the kinds that are never split).
pub fn part_count(kind: BufferKind) -> usize {
    match kind {
        // Node records at under half the inner nodes.
        BufferKind::Nodes => 8,
        // Parts of four times the records (at most three quarters of a node's bytes each): the
        // triangles' records and their shading records in two, the positions and the shading
        // vertices (up to three a triangle) in six.
        BufferKind::Triangles | BufferKind::Attributes => 2,
        BufferKind::Positions | BufferKind::ShadingVertices => 6,
        BufferKind::Instances | BufferKind::Objects | BufferKind::Lights => 1,
    }
}

/// The group-0 bindings of a kind's parts, part 0 first (`scene_parts.wgsl` and `pathtrace.wgsl`).
pub fn part_bindings(kind: BufferKind) -> &'static [u32] {
    match kind {
        BufferKind::Nodes => &[0, 8, 9, 10, 11, 12, 13, 14],
        BufferKind::Triangles => &[1, 15],
        BufferKind::Positions => &[16, 17, 18, 19, 20, 21],
        BufferKind::Instances => &[2],
        BufferKind::Attributes => &[3, 22],
        BufferKind::ShadingVertices => &[23, 24, 25, 26, 27, 28],
        BufferKind::Objects => &[4],
        BufferKind::Lights => &[5],
    }
}

/// Storage buffers the trace kernel binds: the scene's parts and its per-map UV transforms, then
/// the view's accumulation, aux and guides.
pub fn trace_storage_buffers() -> u32 {
    BufferKind::ALL
        .iter()
        .map(|&k| part_count(k) as u32)
        .sum::<u32>()
        + 1
        + 3
}

/// The largest part shift any adapter gets: record references carry 30 bits of index.
pub const MAX_PART_SHIFT: u32 = 30;

/// How the split kinds are cut: parts of `1 << shift` records (four times as many for the smaller
/// shading kinds: [`PartLayout::shift_of`]); the other kinds are one binding of at most
/// `max_binding_bytes`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PartLayout {
    /// Records per part, as a power of two.
    pub shift: u32,
    /// The most bytes one binding may hold.
    pub max_binding_bytes: u64,
}

impl PartLayout {
    /// The layout for an adapter binding at most `max_binding_bytes`: the largest power of two of
    /// records of every split kind that one binding holds.
    pub fn for_binding_limit(max_binding_bytes: u64) -> Self {
        let widest = BufferKind::Nodes.record_bytes();
        let records = (max_binding_bytes / widest).max(1);
        Self {
            shift: records.ilog2().min(MAX_PART_SHIFT),
            max_binding_bytes,
        }
    }

    /// One part holding everything (the GPU tests' buffers).
    pub fn whole() -> Self {
        Self {
            shift: MAX_PART_SHIFT,
            max_binding_bytes: u64::MAX,
        }
    }

    /// Records one part of the nodes holds.
    pub fn part_records(self) -> u64 {
        1 << self.shift
    }

    /// Records one part of a split kind holds, as a power of two: `shift` for nodes, two more for
    /// the 12-byte triangles and shading records and the 16-byte positions and shading vertices
    /// (a part of theirs is no more bytes than a part of nodes). The kernels' `small_part_shift` and
    /// `attr_part_shift` say the same.
    pub fn shift_of(self, kind: BufferKind) -> u32 {
        match kind {
            BufferKind::Triangles
            | BufferKind::Positions
            | BufferKind::Attributes
            | BufferKind::ShadingVertices => (self.shift + 2).min(MAX_PART_SHIFT),
            _ => self.shift,
        }
    }

    /// Records one buffer of a kind holds at most: a part, or a whole binding for a kind never
    /// split.
    fn buffer_records(self, kind: BufferKind) -> u64 {
        if part_count(kind) == 1 {
            self.max_binding_bytes / kind.record_bytes()
        } else {
            1 << self.shift_of(kind)
        }
    }

    /// The most records a kind can hold.
    pub fn max_records(self, kind: BufferKind) -> u64 {
        part_count(kind) as u64 * self.buffer_records(kind)
    }

    /// Records in each part for a kind holding `capacity` records: one part until it is full,
    /// then whole parts.
    pub fn part_sizes(self, kind: BufferKind, capacity: u64) -> Vec<u64> {
        let p = self.buffer_records(kind);
        if capacity <= p {
            return vec![capacity];
        }
        vec![p; capacity.div_ceil(p) as usize]
    }

    /// Records each part's binding covers for a kind holding `capacity` records of which the
    /// kernels read the first `in_use`: the part up to `in_use`, at least one record (a binding
    /// is never empty). The rest of a buffer stays out of its binding, so the device never clears
    /// it: wgpu zeroes the unwritten bytes of every range bound, and on a software adapter those
    /// are the process's own pages (an eighth of a large scene's buffers is room to grow).
    pub fn bound_sizes(self, kind: BufferKind, capacity: u64, in_use: u64) -> Vec<u64> {
        let mut start = 0;
        self.part_sizes(kind, capacity)
            .into_iter()
            .map(|size| {
                let bound = in_use.saturating_sub(start).clamp(1, size.max(1));
                start += size;
                bound
            })
            .collect()
    }

    /// The capacity a kind grows to from `current` records to hold `needed` now and `expected`
    /// soon (what is on its way; 0 when nothing is): while `needed` fits one part, the larger of
    /// the two and an eighth more ([`grown_capacity`](crate::types::upload::grown_capacity)), at
    /// most the part; past one part, whole parts. `None` when `needed` is past what its parts can
    /// hold (`expected` is only a hint, bounded by that).
    pub fn grown(self, kind: BufferKind, current: u64, needed: u64, expected: u64) -> Option<u64> {
        let most = self.max_records(kind);
        if needed > most {
            return None;
        }
        let target = needed.max(expected.min(most));
        let p = self.buffer_records(kind);
        if needed <= p {
            // What is coming fills one part at most: a second one switches the views to the split
            // kernels (half the trace rate on llvmpipe, and a compile of minutes there) before
            // any record needs it.
            return Some(crate::types::upload::grown_capacity(current, target).min(p));
        }
        Some(target.div_ceil(p) * p)
    }

    /// A write of `len` bytes at byte `offset` of a kind's records, as pieces within parts:
    /// (part, byte offset in the part, byte range of the write).
    pub fn pieces(
        self,
        kind: BufferKind,
        offset: u64,
        len: u64,
    ) -> impl Iterator<Item = (usize, u64, std::ops::Range<usize>)> {
        let part_bytes = if part_count(kind) == 1 {
            u64::MAX
        } else {
            self.buffer_records(kind) * kind.record_bytes()
        };
        let mut at = 0u64;
        std::iter::from_fn(move || {
            if at >= len {
                return None;
            }
            let abs = offset + at;
            let (part, within) = (abs / part_bytes, abs % part_bytes);
            let take = (part_bytes - within).min(len - at);
            let piece = (part as usize, within, at as usize..(at + take) as usize);
            at += take;
            Some(piece)
        })
    }
}

/// Why the trace kernel cannot run on this device, if it binds fewer storage buffers per shader
/// stage than the kernel declares.
pub(crate) fn too_few_bindings(device: &bevy::render::renderer::RenderDevice) -> Option<String> {
    let have = device.limits().max_storage_buffers_per_shader_stage;
    let need = trace_storage_buffers();
    (have < need).then(|| {
        format!(
            "this adapter binds {have} storage buffers per shader stage and the path tracer needs \
             {need}"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bindings_are_distinct_and_counted() {
        let mut all: Vec<u32> = BufferKind::ALL
            .iter()
            .flat_map(|&k| part_bindings(k).iter().copied())
            .collect();
        for k in BufferKind::ALL {
            assert_eq!(part_bindings(k).len(), part_count(k), "{k:?}");
        }
        // The texture array, its sampler and the energy table fill the rest of group 0 up to 29, the
        // panorama's three after it, then the per-map UV transforms.
        all.extend([6, 7, crate::types::energy::ENERGY_BINDING]);
        all.extend(crate::types::bindings::ENVIRONMENT_BINDINGS);
        all.push(crate::types::map_transforms::MAP_TRANSFORMS_BINDING);
        all.sort_unstable();
        assert_eq!(all, (0..34).collect::<Vec<u32>>());
        // 27 parts and the transforms, then the view's accumulation, aux and guides: 31, what
        // Metal binds in a stage.
        assert_eq!(trace_storage_buffers(), 31);
    }

    #[test]
    fn a_part_is_the_largest_power_of_two_of_records_a_binding_holds() {
        // 128 MiB of 64-byte nodes: 2^21 records.
        let layout = PartLayout::for_binding_limit(128 << 20);
        assert_eq!(layout.shift, 21);
        assert!(layout.part_records() * 64 <= 128 << 20);
        assert_eq!(PartLayout::for_binding_limit((128 << 20) - 1).shift, 20);
        assert_eq!(
            PartLayout::for_binding_limit(u64::MAX).shift,
            MAX_PART_SHIFT
        );
        assert_eq!(PartLayout::for_binding_limit(1).shift, 0);
    }

    #[test]
    fn growth_takes_what_is_coming_and_an_eighth_more_within_a_part_then_whole_parts() {
        let l = PartLayout {
            shift: 12,
            max_binding_bytes: 4096 * 64,
        };
        let t = BufferKind::Nodes;
        assert_eq!(l.grown(t, 1024, 1500, 0), Some(2048));
        assert_eq!(l.grown(t, 2048, 2049, 0), Some(3072));
        assert_eq!(l.grown(t, 3072, 3100, 0), Some(4096), "at most a part");
        // What an import is about to need is taken at once.
        assert_eq!(l.grown(t, 1024, 1500, 2900), Some(4096));
        assert_eq!(l.grown(t, 1024, 1500, 2000), Some(3072));
        assert_eq!(l.grown(t, 4096, 4097, 0), Some(2 * 4096));
        // Only what is needed takes a second part (the split kernels).
        assert_eq!(l.grown(t, 1024, 1500, 5 * 4096 + 7), Some(4096));
        assert_eq!(l.grown(t, 4096, 4097, 5 * 4096 + 7), Some(6 * 4096));
        assert_eq!(l.grown(t, 8192, 3 * 4096 + 1, 0), Some(4 * 4096));
        assert_eq!(l.grown(t, 0, 8 * 4096, 0), Some(8 * 4096));
        assert_eq!(l.grown(t, 0, 8 * 4096 + 1, 0), None);
        // More coming than the parts can hold: as much as they can, until it is needed.
        assert_eq!(l.grown(t, 4096, 5000, 9 * 4096), Some(8 * 4096));
        // A kind never split holds what one binding does.
        let o = BufferKind::Objects;
        let most = 4096 * 64 / o.record_bytes();
        assert_eq!(l.grown(o, 0, most, 0), Some(most));
        assert_eq!(l.grown(o, 0, most + 1, 0), None);
        assert_eq!(l.part_sizes(o, most), vec![most]);
        assert_eq!(l.part_sizes(t, 3000), vec![3000]);
        assert_eq!(l.part_sizes(t, 4096), vec![4096]);
        assert_eq!(l.part_sizes(t, 3 * 4096), vec![4096; 3]);
    }

    #[test]
    fn a_binding_covers_the_records_in_use_and_never_nothing() {
        let l = PartLayout {
            shift: 12,
            max_binding_bytes: 4096 * 64,
        };
        let t = BufferKind::Nodes;
        assert_eq!(l.bound_sizes(t, 3072, 2000), vec![2000]);
        assert_eq!(l.bound_sizes(t, 3072, 0), vec![1]);
        assert_eq!(
            l.bound_sizes(t, 3072, 5000),
            vec![3072],
            "at most the buffer"
        );
        assert_eq!(l.bound_sizes(t, 3 * 4096, 4096 + 5), vec![4096, 5, 1]);
        assert_eq!(l.bound_sizes(t, 3 * 4096, 3 * 4096), vec![4096; 3]);
        let o = BufferKind::Objects;
        assert_eq!(l.bound_sizes(o, 900, 17), vec![17]);
    }

    #[test]
    fn a_write_across_a_part_boundary_is_cut_there() {
        let l = PartLayout {
            shift: 4,
            max_binding_bytes: 16 * 64,
        };
        let t = BufferKind::Nodes;
        let rb = t.record_bytes();
        // Records 14 to 33: 2 in part 0, 16 in part 1, 2 in part 2.
        let pieces: Vec<_> = l.pieces(t, 14 * rb, 20 * rb).collect();
        assert_eq!(
            pieces,
            vec![
                (0, 14 * rb, 0..(2 * rb) as usize),
                (1, 0, (2 * rb) as usize..(18 * rb) as usize),
                (2, 0, (18 * rb) as usize..(20 * rb) as usize),
            ]
        );
        // The shading kinds' parts hold four times the records: the same bytes.
        let a = BufferKind::Attributes;
        assert_eq!(l.shift_of(a), 6);
        assert_eq!(l.shift_of(BufferKind::ShadingVertices), 6);
        let ab = a.record_bytes();
        let pieces: Vec<_> = l.pieces(a, 60 * ab, 8 * ab).collect();
        let cut = (4 * ab) as usize;
        assert_eq!(pieces, vec![(0, 60 * ab, 0..cut), (1, 0, cut..2 * cut)]);
        // As many triangles as node records, shading records for as many as the triangles, and
        // three positions and shading vertices a triangle.
        let tr = BufferKind::Triangles;
        assert_eq!(l.max_records(tr), l.max_records(t));
        assert_eq!(l.max_records(a), l.max_records(tr));
        for k in [BufferKind::Positions, BufferKind::ShadingVertices] {
            assert_eq!(l.shift_of(k), 6);
            assert_eq!(l.max_records(k), 3 * l.max_records(tr));
        }
        // A part of every split kind is no more bytes than a part of nodes.
        for k in BufferKind::ALL.into_iter().filter(|&k| part_count(k) > 1) {
            assert!(
                (1u64 << l.shift_of(k)) * k.record_bytes() <= l.part_records() * rb,
                "{k:?}"
            );
        }
        assert_eq!(PartLayout::whole().shift_of(a), MAX_PART_SHIFT);
        // A kind never split is one piece wherever it writes.
        let o = BufferKind::Objects;
        let whole: Vec<_> = l.pieces(o, 100 * o.record_bytes(), 64).collect();
        assert_eq!(whole, vec![(0, 100 * o.record_bytes(), 0..64)]);
    }
}
