//! IncrUPB: block-parallel construction (paper section 5.2). The buffered stream is split into
//! spatially coherent batches by the R*_coh spatial-median subdivision, a bBVH is built for each batch
//! in parallel, and one owner inserts the bBVH roots into the global tree with the search.

use crate::build::{BuiltTree, build_binned};
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
/// or until it has at most `min_batch` (below which a bBVH is not worth its insertion).
/// Returns ranges of the reordered `order`.
pub fn coherent_batches(
    boxes: &[Aabb],
    order: &mut [u32],
    r_max: f32,
    min_batch: usize,
    max_batch: usize,
) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut stack = vec![(0usize, order.len(), 0usize)];
    while let Some((s, e, axis)) = stack.pop() {
        if e == s {
            continue;
        }
        let range = &mut order[s..e];
        let mut bounds = Aabb::EMPTY;
        let mut sum = 0.0f32;
        for &p in range.iter() {
            bounds = bounds.union(&boxes[p as usize]);
            sum += boxes[p as usize].area();
        }
        let n = range.len();
        if n <= min_batch.max(1) || (n <= max_batch && batch_coherence(&bounds, sum, n) < r_max) {
            out.push(s..e);
            continue;
        }
        let pivot = bounds.center()[axis];
        let mut i = 0;
        for j in 0..n {
            if boxes[range[j] as usize].center()[axis] < pivot {
                range.swap(i, j);
                i += 1;
            }
        }
        if i == 0 || i == n {
            i = n / 2;
        }
        let next = (axis + 1) % 3;
        stack.push((s + i, e, next));
        stack.push((s, s + i, next));
    }
    out
}

/// Triangles per buffer of the stream: the unit of the build/insert pipeline.
const BUFFER: usize = 1 << 15;

impl Bvh {
    /// Inserts world-space triangles block-parallel (IncrUPB). The input is cut into buffers; while the
    /// owner inserts the bBVHs of one buffer, the other threads build the bBVHs of the next.
    /// Rejects the whole input, inserting nothing, if any vertex is invalid. Returns the new ids.
    pub fn insert_triangles_block_parallel(
        &mut self,
        tris: &[Triangle],
    ) -> Result<Vec<u32>, BvhError> {
        validate_triangles(tris)?;
        self.check_room(tris.len())?;
        let ids: Vec<u32> = tris.iter().map(|t| self.alloc_triangle(*t, NONE)).collect();
        let (r_max, min_batch, max_batch) = (
            self.config.coherence_max,
            self.config.block_min_batch as usize,
            self.config.block_max_batch.max(1) as usize,
        );
        let build = |buf: Range<usize>| -> Vec<(Vec<u32>, BuiltTree)> {
            let boxes: Vec<Aabb> = tris[buf.clone()].iter().map(|t| t.aabb()).collect();
            let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
            let batches = coherent_batches(&boxes, &mut order, r_max, min_batch, max_batch);
            batches
                .into_par_iter()
                .map(|r| {
                    let local: Vec<Aabb> = order[r.clone()]
                        .iter()
                        .map(|&k| boxes[k as usize])
                        .collect();
                    let batch_ids = order[r]
                        .iter()
                        .map(|&k| ids[buf.start + k as usize])
                        .collect();
                    (batch_ids, build_binned(&local))
                })
                .collect()
        };
        let buffers: Vec<Range<usize>> = (0..tris.len())
            .step_by(BUFFER)
            .map(|s| s..(s + BUFFER).min(tris.len()))
            .collect();
        let mut ready = buffers
            .first()
            .map(|b| build(b.clone()))
            .unwrap_or_default();
        for k in 0..buffers.len() {
            let next = buffers.get(k + 1).cloned();
            let current = std::mem::take(&mut ready);
            let (built_next, ()) = rayon::join(
                || next.map(&build).unwrap_or_default(),
                || {
                    for (batch_ids, tree) in &current {
                        let root = self.graft(tree, batch_ids);
                        self.insert_item(root);
                    }
                },
            );
            ready = built_next;
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
