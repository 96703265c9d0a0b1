//! IncrUPB: block-parallel construction (paper section 5.2). The buffered stream is split into
//! spatially coherent batches by the R*_coh spatial-median subdivision, a bBVH is built for each batch
//! in parallel, and one owner inserts the bBVH roots into the global tree with the search.

use crate::build::{BuiltTree, Prims, build_binned_over};
use crate::triangle::validate_triangles;
use crate::{Aabb, Bvh, BvhError, Triangle};
use rayon::prelude::*;
use std::collections::VecDeque;
use std::ops::Range;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

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

/// [`coherent_batches`] over boxes already converted for the builder.
fn coherent_batches_with(
    prims: &Prims,
    order: &mut [u32],
    r_max: f32,
    min_batch: usize,
    max_batch: usize,
) -> Vec<Range<usize>> {
    let mut batcher = Batcher::new(prims, order, r_max, min_batch, max_batch);
    std::iter::from_fn(|| batcher.next_batch(prims, order)).collect()
}

/// The R*_coh subdivision of one order, run lazily: each call splits only as far as the next batch
/// needs, so the pipeline spreads a buffer's subdivision over its steps instead of stalling the
/// owner while a whole buffer is cut up front. Batches come left to right and tile the order.
struct Batcher {
    /// Ranges of the order still to split, the leftmost on top.
    stack: Vec<Pending>,
    r_max: f32,
    min_batch: usize,
    max_batch: usize,
}

/// A range of the order still to split, with the axis to split it on and its primitives' bounds
/// and area sum (measured when its parent was partitioned).
struct Pending {
    range: Range<usize>,
    axis: usize,
    bounds: Aabb,
    sum: f32,
}

impl Batcher {
    fn new(prims: &Prims, order: &[u32], r_max: f32, min_batch: usize, max_batch: usize) -> Self {
        let (bounds, sum) = prims.bounds_and_area(order);
        Self {
            stack: vec![Pending {
                range: 0..order.len(),
                axis: 0,
                bounds,
                sum,
            }],
            r_max,
            min_batch,
            max_batch,
        }
    }

    /// The next batch of `order` (indices into `prims`), reordering the part of it still to split.
    fn next_batch(&mut self, prims: &Prims, order: &mut [u32]) -> Option<Range<usize>> {
        while let Some(Pending {
            range,
            axis,
            bounds,
            sum,
        }) = self.stack.pop()
        {
            let n = range.len();
            if n == 0 {
                continue;
            }
            // A small batch is kept whole while its box is no larger than r_max times its
            // primitives' (Eq. 3 without the ∛ factor, which would split every surface patch down
            // to single triangles); a scattered one, as a random order or random edits give, is
            // still split.
            let small = n <= 1 || (n <= self.min_batch && bounds.area() < self.r_max * sum);
            if small || (n <= self.max_batch && batch_coherence(&bounds, sum, n) < self.r_max) {
                return Some(range);
            }
            let next = (axis + 1) % 3;
            let (mut i, mut sides) =
                prims.partition(&mut order[range.clone()], axis, bounds.center()[axis]);
            if i == 0 || i == n {
                // Every centre on one side of the middle: halve the range as it stands.
                i = n / 2;
                let (l, r) = order[range.clone()].split_at(i);
                sides = [prims.bounds_and_area(l), prims.bounds_and_area(r)];
            }
            let mid = range.start + i;
            let [(lb, ls), (rb, rs)] = sides;
            self.stack.push(Pending {
                range: mid..range.end,
                axis: next,
                bounds: rb,
                sum: rs,
            });
            self.stack.push(Pending {
                range: range.start..mid,
                axis: next,
                bounds: lb,
                sum: ls,
            });
        }
        None
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

/// One buffer being cut into coherent batches, whose bBVHs are built a step at a time.
struct BufferBatches {
    index: usize,
    prims: Prims,
    order: Vec<u32>,
    batcher: Batcher,
    /// The buffer's triangle boxes, until its first step hands them to the owner.
    boxes: Option<Vec<Aabb>>,
}

/// What the building side hands the owner per step.
struct Step {
    /// Index of the buffer whose triangles the bBVHs' leaves index.
    buffer: usize,
    /// The buffer's triangle boxes, with its first step only: the owner stores them with the
    /// triangles instead of computing them again.
    boxes: Option<Vec<Aabb>>,
    trees: Vec<BuiltTree>,
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
    /// This step's batches, reused from step to step.
    batches: Vec<Range<usize>>,
}

impl BatchBuilder<'_> {
    /// The bBVHs of the next step's batches (built in parallel), with the buffer they index; `None`
    /// once the stream is done.
    fn next_step(&mut self) -> Option<Step> {
        self.batches.clear();
        let mut count = 0;
        while count < STEP {
            if self.current.is_none() {
                let index = self.next_buffer;
                let Some(buf) = self.buffers.get(index).cloned() else {
                    break;
                };
                self.next_buffer += 1;
                let boxes: Vec<Aabb> = self.tris[buf].iter().map(|t| t.aabb()).collect();
                let prims = Prims::new(&boxes);
                let order: Vec<u32> = (0..boxes.len() as u32).collect();
                let batcher =
                    Batcher::new(&prims, &order, self.r_max, self.min_batch, self.max_batch);
                self.current = Some(BufferBatches {
                    index,
                    prims,
                    order,
                    batcher,
                    boxes: Some(boxes),
                });
            }
            let c = self.current.as_mut()?;
            match c.batcher.next_batch(&c.prims, &mut c.order) {
                Some(batch) => {
                    count += batch.len();
                    self.batches.push(batch);
                }
                // A step never spans two buffers: its bBVHs index one buffer's triangles.
                None if self.batches.is_empty() => self.current = None,
                None => break,
            }
        }
        let c = self.current.as_mut()?;
        let index = c.index;
        if self.batches.is_empty() {
            return None;
        }
        // The batches tile `order` in sequence: cut this step's run of it into one slice per
        // batch, each built in place, so no batch copies its boxes.
        let run = &self.batches;
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
        Some(Step {
            buffer: index,
            boxes: c.boxes.take(),
            trees,
        })
    }
}

/// Steps the building side may run ahead of the owner, so that the built bBVHs waiting for
/// insertion stay a few steps' worth.
const LOOKAHEAD: usize = 2;

/// The hand-over between the two sides of IncrUPB. Each side runs as one long job for the whole
/// stream rather than one job per step: a step takes well under a millisecond, and a worker that
/// went to sleep between steps woke too late to take the next one (on a virtual machine, waking an
/// idle vCPU costs about as much as a step), which left the owner running after the builder on
/// its thread. Only the owner ever waits for the other side while it is not known to be running:
/// the builder runs first on the calling thread, so a pool whose other threads are busy (or a pool
/// of one) runs the two sides one after the other.
#[derive(Default)]
struct Pipeline {
    steps: Mutex<VecDeque<Step>>,
    /// The building side has sent its last step (or given up).
    done: AtomicBool,
    /// The owner is running, so a full queue will drain.
    owner_running: AtomicBool,
}

/// Stores a value into a flag when dropped, also while unwinding: a side that panics still lets
/// the other one finish, so the panic reaches the caller instead of leaving a thread spinning.
struct StoreOnDrop<'a>(&'a AtomicBool, bool);

impl Drop for StoreOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(self.1, Ordering::Release);
    }
}

impl Pipeline {
    /// Queues a step, first waiting while the owner is running and has enough to do.
    fn send(&self, step: Step) {
        while self.owner_running.load(Ordering::Acquire) && self.queued() >= LOOKAHEAD {
            idle();
        }
        self.lock().push_back(step);
    }

    /// The next step in order, waiting for the building side; `None` once the stream is done.
    fn receive(&self) -> Option<Step> {
        loop {
            // Read `done` before looking at the queue: once it is set, every step is queued.
            let done = self.done.load(Ordering::Acquire);
            if let Some(step) = self.lock().pop_front() {
                return Some(step);
            }
            if done {
                return None;
            }
            idle();
        }
    }

    fn queued(&self) -> usize {
        self.lock().len()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, VecDeque<Step>> {
        // A panic on the other side poisons the queue; its contents are still whole.
        self.steps.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Waits a moment for the other side of the pipeline, helping with any parallel work in the pool
/// meanwhile (the builder's bBVH builds, or other work queued there).
fn idle() {
    if !matches!(rayon::yield_now(), Some(rayon::Yield::Executed)) {
        std::hint::spin_loop();
        std::thread::yield_now();
    }
}

impl Bvh {
    /// Inserts world-space triangles block-parallel (IncrUPB). The input is cut into buffers and
    /// each buffer into coherent batches; one job builds their bBVHs a step at a time (in parallel
    /// where the pool has threads to spare), up to two steps ahead of the owner, which inserts the
    /// roots of the steps before. Insertion follows the batches' order whatever the timing, so the
    /// tree does not depend on the number of threads.
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
            batches: Vec::new(),
        };
        self.reserve(tris.len());
        let mut ids = Vec::with_capacity(tris.len());
        let pipe = Pipeline::default();
        rayon::join(
            || {
                let _done = StoreOnDrop(&pipe.done, true);
                while let Some(step) = builder.next_step() {
                    pipe.send(step);
                }
            },
            || {
                pipe.owner_running.store(true, Ordering::Release);
                let _gone = StoreOnDrop(&pipe.owner_running, false);
                while let Some(Step {
                    buffer,
                    boxes,
                    trees,
                }) = pipe.receive()
                {
                    // A buffer's triangles get their ids when its first bBVHs arrive.
                    let buf = &buffers[buffer];
                    if let Some(boxes) = boxes {
                        self.alloc_triangles_boxed(&tris[buf.clone()], &boxes, &mut ids);
                    }
                    // The bBVH's own nodes are candidates for updates too: where batches meet,
                    // their boxes overlap, and only moving nodes inside them can fix that.
                    for tree in &trees {
                        let root = self.graft_with(tree, &ids[buf.start..buf.end], true);
                        self.insert_item(root);
                    }
                }
            },
        );
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
