//! IncrUPB: block-parallel construction (paper section 5.2). The buffered stream is split into
//! spatially coherent batches by the R*_coh spatial-median subdivision, a bBVH is built for each batch
//! in parallel, and one owner inserts the bBVH roots into the global tree with the search.

use crate::build::{BuiltTree, Prims, build_binned_over};
use crate::node::NONE;
use crate::triangle::validate_triangles;
use crate::{Aabb, Bvh, BvhError, Triangle};
use rayon::prelude::*;
use std::ops::Range;

/// R*_coh(B) = S(B) / Σ S(i) · ∛(|B| − 1) (paper Eq. 3).
pub fn batch_coherence(bounds: &Aabb, sum_area: f32, count: usize) -> f32 {
    if count <= 1 {
        return 0.0;
    }
    let s = bounds.area();
    if sum_area <= 0.0 {
        return if s <= 0.0 { 0.0 } else { f32::INFINITY };
    }
    s / sum_area * ((count - 1) as f32).cbrt()
}

/// Splits `order` (indices into `boxes`) into coherent batches: a batch is split at the spatial median
/// of its bounds on a cycling axis until R*_coh < `r_max` and it has at most `max_batch` primitives,
/// or until it has at most `min_batch` and its box's area is below `r_max` times the sum of its
/// primitives' (below that size a compact bBVH is worth more than the coherence rule's single
/// triangles).
/// Returns ranges of the reordered `order`, in order and covering it.
pub fn coherent_batches(
    boxes: &[Aabb],
    order: &mut [u32],
    r_max: f32,
    min_batch: usize,
    max_batch: usize,
) -> Vec<Range<usize>> {
    let prims = Prims::new(boxes);
    coherent_batches_with(&prims, order, r_max, min_batch, max_batch)
}

/// Ranges above this size are subdivided with their two halves in parallel.
const PARALLEL_BATCHING: usize = 1 << 12;

/// [`coherent_batches`] over boxes already converted for the builder.
fn coherent_batches_with(
    prims: &Prims,
    order: &mut [u32],
    r_max: f32,
    min_batch: usize,
    max_batch: usize,
) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    subdivide(prims, order, 0, 0, (r_max, min_batch, max_batch), &mut out);
    out
}

/// Appends the batches of `order` (which starts at `offset` in the whole order) to `out`, splitting
/// on `axis` first.
fn subdivide(
    prims: &Prims,
    order: &mut [u32],
    offset: usize,
    axis: usize,
    rule: (f32, usize, usize),
    out: &mut Vec<Range<usize>>,
) {
    let (r_max, min_batch, max_batch) = rule;
    let mut stack = vec![(0usize, order.len(), axis)];
    while let Some((s, e, axis)) = stack.pop() {
        if e == s {
            continue;
        }
        let range = &mut order[s..e];
        let (bounds, sum) = prims.bounds_and_area(range);
        let n = range.len();
        // A small batch is kept whole while its box is no larger than r_max times its primitives'
        // (Eq. 3 without the ∛ factor, which would split every surface patch down to single
        // triangles); a scattered one, as a random order or random edits give, is still split.
        let small = n <= 1 || (n <= min_batch && bounds.area() < r_max * sum);
        if small || (n <= max_batch && batch_coherence(&bounds, sum, n) < r_max) {
            out.push(offset + s..offset + e);
            continue;
        }
        let pivot = bounds.center()[axis];
        let mut i = 0;
        for j in 0..n {
            if prims.center(range[j])[axis] < pivot {
                range.swap(i, j);
                i += 1;
            }
        }
        if i == 0 || i == n {
            i = n / 2;
        }
        let next = (axis + 1) % 3;
        if n > PARALLEL_BATCHING {
            // Both halves at once; the left one's batches still come first.
            let (l, r) = range.split_at_mut(i);
            let mut right = Vec::new();
            rayon::join(
                || subdivide(prims, l, offset + s, next, rule, out),
                || subdivide(prims, r, offset + s + i, next, rule, &mut right),
            );
            out.append(&mut right);
            // Ranges still on the stack lie to the right of this one: their batches come after.
            continue;
        }
        stack.push((s + i, e, next));
        stack.push((s, s + i, next));
    }
}

/// Triangles in the first buffer of the stream: small, so that the owner starts inserting soon.
/// Later buffers double up to [`BUFFER_MAX`]: the batches are cut from one buffer at a time, and a
/// larger buffer gives a stream whose order is not spatial (a scan's strips, a random order) more
/// chances to form compact batches.
const BUFFER_FIRST: usize = 1 << 12;
const BUFFER_MAX: usize = 1 << 15;
/// Triangles whose bBVHs are built in one step of the pipeline, while the owner inserts the
/// previous step's: small enough that the two sides stay busy together.
const STEP: usize = 1 << 11;

/// The stream cut into buffers of growing size.
fn buffers(n: usize) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let (mut start, mut size) = (0, BUFFER_FIRST);
    while start < n {
        let end = (start + size).min(n);
        out.push(start..end);
        start = end;
        size = (size * 2).min(BUFFER_MAX);
    }
    out
}

/// One buffer cut into coherent batches, whose bBVHs are still being built.
struct BufferBatches {
    index: usize,
    prims: Prims,
    order: Vec<u32>,
    batches: Vec<Range<usize>>,
    next: usize,
}

/// The building side of IncrUPB: cuts buffers into batches and builds their bBVHs, a step at a time.
/// It never touches the tree, so it runs beside the owner.
struct BatchBuilder<'a> {
    tris: &'a [Triangle],
    buffers: &'a [Range<usize>],
    next_buffer: usize,
    current: Option<BufferBatches>,
    r_max: f32,
    min_batch: usize,
    max_batch: usize,
}

impl BatchBuilder<'_> {
    /// The bBVHs of the next step's batches (built in parallel), with the buffer they index; `None`
    /// once the stream is done.
    fn next_step(&mut self) -> Option<(usize, Vec<BuiltTree>)> {
        if self
            .current
            .as_ref()
            .is_none_or(|c| c.next == c.batches.len())
        {
            let index = self.next_buffer;
            let buf = self.buffers.get(index)?.clone();
            self.next_buffer += 1;
            let boxes: Vec<Aabb> = self.tris[buf].iter().map(|t| t.aabb()).collect();
            let prims = Prims::new(&boxes);
            let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
            let batches = coherent_batches_with(
                &prims,
                &mut order,
                self.r_max,
                self.min_batch,
                self.max_batch,
            );
            self.current = Some(BufferBatches {
                index,
                prims,
                order,
                batches,
                next: 0,
            });
        }
        let c = self.current.as_mut()?;
        let first = c.next;
        let mut count = 0;
        while c.next < c.batches.len() && count < STEP {
            count += c.batches[c.next].len();
            c.next += 1;
        }
        // The batches tile `order` in sequence: cut this step's run of it into one slice per
        // batch, each built in place, so no batch copies its boxes.
        let run = &c.batches[first..c.next];
        let mut slices = Vec::with_capacity(run.len());
        let mut rest = &mut c.order[run[0].start..run[run.len() - 1].end];
        for r in run {
            let (head, tail) = rest.split_at_mut(r.len());
            slices.push(head);
            rest = tail;
        }
        let prims = &c.prims;
        let trees = slices
            .into_par_iter()
            .map(|slice| build_binned_over(prims, slice))
            .collect();
        Some((c.index, trees))
    }
}

impl Bvh {
    /// Inserts world-space triangles block-parallel (IncrUPB). The input is cut into buffers and
    /// each buffer into coherent batches; the other threads build the bBVHs of one step of batches
    /// while the owner inserts those of the step before. Insertion follows the batches' order
    /// whatever the timing, so the tree does not depend on the number of threads.
    /// Rejects the whole input, inserting nothing, if any vertex is invalid. Returns the new ids.
    pub fn insert_triangles_block_parallel(
        &mut self,
        tris: &[Triangle],
    ) -> Result<Vec<u32>, BvhError> {
        validate_triangles(tris)?;
        self.check_room(tris.len())?;
        let buffers = buffers(tris.len());
        let mut builder = BatchBuilder {
            tris,
            buffers: &buffers,
            next_buffer: 0,
            current: None,
            r_max: self.config.coherence_max,
            min_batch: self.config.block_min_batch as usize,
            max_batch: self.config.block_max_batch.max(1) as usize,
        };
        self.reserve_triangles(tris.len());
        let mut ids = Vec::with_capacity(tris.len());
        let mut ready = builder.next_step();
        while let Some((index, trees)) = ready {
            let (next, ()) = rayon::join(
                || builder.next_step(),
                || {
                    // A buffer's triangles get their ids when its first bBVHs arrive.
                    let buf = &buffers[index];
                    while ids.len() < buf.end {
                        ids.push(self.alloc_triangle(tris[ids.len()], NONE));
                    }
                    for tree in &trees {
                        // The bBVH's own nodes are candidates for updates too: where batches meet,
                        // their boxes overlap, and only moving nodes inside them can fix that.
                        let root = self.graft_with(tree, &ids[buf.start..buf.end], true);
                        self.insert_item(root);
                    }
                },
            );
            ready = next;
        }
        Ok(ids)
    }
}

/// A streaming front end for IncrUPB: accepts triangles in chunks as they arrive, buffers them and
/// inserts a buffer once it is full (or on [`BlockStream::flush`]). The tree is valid and traceable
/// between calls; triangles still buffered are not in it yet.
pub struct BlockStream {
    buffer: Vec<Triangle>,
    capacity: usize,
}

impl BlockStream {
    /// A stream that inserts every `capacity` triangles.
    pub fn new(capacity: usize) -> Self {
        Self {
            buffer: Vec::with_capacity(capacity),
            capacity: capacity.max(1),
        }
    }

    /// Triangles received but not inserted yet.
    pub fn pending(&self) -> usize {
        self.buffer.len()
    }

    /// Accepts a chunk; inserts the buffer into `bvh` when full. Returns the ids inserted by this call.
    /// An invalid chunk is rejected whole and leaves the buffer as it was.
    pub fn push(&mut self, bvh: &mut Bvh, chunk: &[Triangle]) -> Result<Vec<u32>, BvhError> {
        validate_triangles(chunk)?;
        self.buffer.extend_from_slice(chunk);
        if self.buffer.len() >= self.capacity {
            self.flush(bvh)
        } else {
            Ok(Vec::new())
        }
    }

    /// Inserts whatever is buffered.
    pub fn flush(&mut self, bvh: &mut Bvh) -> Result<Vec<u32>, BvhError> {
        let ids = bvh.insert_triangles_block_parallel(&self.buffer)?;
        self.buffer.clear();
        Ok(ids)
    }
}
