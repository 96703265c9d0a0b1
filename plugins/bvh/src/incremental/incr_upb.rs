//! IncrUPB: block-parallel construction (paper section 5.2). The buffered stream is split into
//! spatially coherent batches by the R*_coh spatial-median subdivision, a bBVH is built for each batch
//! in parallel, and one owner inserts the bBVH roots into the global tree with the search.

use crate::top_down::{Box3A, Prims, build_batch_into};
use crate::tree::node::{InnerNode, NodeRef};
use crate::tree::triangle::{validate_triangles, within_limits};
use crate::{Aabb, Bvh, BvhError, Triangle};
use rayon::prelude::*;
use std::collections::VecDeque;
use std::ops::Range;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// R*_coh(B) = S(B) / Σ S(i) · ∛(|B| − 1) (paper Eq. 3).
pub fn batch_coherence(bounds: &Aabb, sum_area: f32, count: usize) -> f32 {
    coherence(bounds.area(), sum_area, count)
}

/// [`batch_coherence`] of a batch whose box has area `s`.
fn coherence(s: f32, sum_area: f32, count: usize) -> f32 {
    if count <= 1 {
        return 0.0;
    }
    if sum_area <= 0.0 {
        return if s <= 0.0 { 0.0 } else { f32::INFINITY };
    }
    s / sum_area * ((count - 1) as f32).cbrt()
}

/// Splits `order` (indices into `boxes`) into coherent batches: a batch is split at the spatial median
/// of its bounds on a cycling axis until R*_coh < `r_max` and it has at most `max_batch` primitives,
/// or until it has at most `min_batch`, its box's area is below `r_max` times the sum of its
/// primitives' (below that size a compact bBVH is worth more than the coherence rule's single
/// triangles) and it is not crowded: its box's volume times `crowding` is at most its count (see
/// [`crowding`]; 0 turns the test off).
/// Returns ranges of the reordered `order`, in order and covering it.
pub fn coherent_batches(
    boxes: &[Aabb],
    order: &mut [u32],
    r_max: f32,
    min_batch: usize,
    max_batch: usize,
    crowding: f32,
) -> Vec<Range<usize>> {
    let prims = Prims::new(boxes);
    let mut out = Vec::new();
    Cut {
        r_max,
        min_batch,
        max_batch,
        crowding,
    }
    .batches(&prims, order, &mut out);
    out
}

/// The crowding factor of IncrUPB's cut for a scene of `count` triangles within `bounds`: the
/// mean density (triangles per unit volume) over `crowd_max`. A small batch whose box's volume
/// times it exceeds the batch's own count is crowded: at the scene's mean density its box would
/// hold more than `crowd_max` foreign triangles per own one. 0 (no batch is crowded) when the box
/// is flat, empty or too large to measure, or `crowd_max` is infinite or 0.
pub fn crowding(bounds: &Aabb, count: usize, crowd_max: f32) -> f32 {
    // An empty box's extent clamps to zero, so it is flat here too.
    let e = bounds.extent();
    let volume = e.x as f64 * e.y as f64 * e.z as f64;
    let c = count as f64 / volume / crowd_max as f64;
    if volume > 0.0 && c.is_finite() {
        c as f32
    } else {
        0.0
    }
}

/// The rule of the R*_coh subdivision: when a range is a batch, and where it splits.
#[derive(Clone, Copy)]
struct Cut {
    r_max: f32,
    min_batch: usize,
    max_batch: usize,
    /// See [`crowding`].
    crowding: f32,
}

/// A range of the order still to split, with the axis to split it on and its primitives' bounds
/// and area sum (measured when its parent was partitioned).
struct Pending {
    range: Range<usize>,
    axis: usize,
    bounds: Box3A,
    sum: f32,
}

impl Pending {
    /// All of `order`, measured, to be split first on x.
    fn whole(prims: &Prims, order: &[u32]) -> Self {
        let (bounds, sum) = prims.bounds_and_area(order);
        Pending {
            range: 0..order.len(),
            axis: 0,
            bounds,
            sum,
        }
    }
}

/// What one look at a pending range gives.
enum Cutting {
    Empty,
    Batch(Range<usize>),
    /// The two halves, left first.
    Split(Pending, Pending),
}

/// Ranges of at least this many primitives cut their two halves in parallel: below it a join
/// costs more than it can win.
const PARALLEL_MIN: usize = 1 << 10;
/// Levels of the subdivision that may fork. A stream whose centres crowd to one side splits off a
/// few primitives per level; past this depth the explicit stack takes over, so no input can
/// overflow the thread's stack.
const PARALLEL_DEPTH: u32 = 24;

impl Cut {
    /// Appends the batches of `order` to `out`, left to right, tiling it. The halves of a large
    /// range are cut in parallel, so that an owner waiting for its next step takes a share of a
    /// new buffer's subdivision; the batches do not depend on who cuts them.
    fn batches(&self, prims: &Prims, order: &mut [u32], out: &mut Vec<Range<usize>>) {
        let whole = Pending::whole(prims, order);
        self.batches_from(prims, order, 0, whole, PARALLEL_DEPTH, out);
    }

    /// [`Cut::batches`] of `order` (which starts at `start` of the whole order), whose bounds,
    /// area sum and split axis `whole` gives. A large range forks its halves while `depth` lasts;
    /// the ranges still on the stack then lie to its right, so their batches come after.
    fn batches_from(
        &self,
        prims: &Prims,
        order: &mut [u32],
        start: usize,
        whole: Pending,
        depth: u32,
        out: &mut Vec<Range<usize>>,
    ) {
        let mut stack = vec![whole];
        while let Some(p) = stack.pop() {
            let n = p.range.len();
            match self.look(prims, order, p) {
                Cutting::Empty => {}
                Cutting::Batch(r) => out.push(start + r.start..start + r.end),
                Cutting::Split(l, r) if n >= PARALLEL_MIN && depth > 0 => {
                    let (ls, rs) = (l.range.start, r.range.start);
                    let (lo, hi) = order[ls..r.range.end].split_at_mut(rs - ls);
                    // Each half's range, relative to its own slice.
                    let own = |p: Pending, at: usize| Pending {
                        range: p.range.start - at..p.range.end - at,
                        ..p
                    };
                    let (l, r) = (own(l, ls), own(r, rs));
                    let mut right = Vec::new();
                    rayon::join(
                        || self.batches_from(prims, lo, start + ls, l, depth - 1, out),
                        || self.batches_from(prims, hi, start + rs, r, depth - 1, &mut right),
                    );
                    out.append(&mut right);
                }
                Cutting::Split(l, r) => {
                    stack.push(r);
                    stack.push(l);
                }
            }
        }
    }

    /// Whether a batch of `n` primitives within `bounds` is crowded (see [`crowding`]).
    fn crowded(&self, bounds: &Box3A, n: usize) -> bool {
        let d = bounds.max - bounds.min;
        d.x * d.y * d.z * self.crowding > n as f32
    }

    /// Whether the pending range of `order` is a batch, or else its two halves (reordering it).
    fn look(&self, prims: &Prims, order: &mut [u32], p: Pending) -> Cutting {
        let Pending {
            range,
            axis,
            bounds,
            sum,
        } = p;
        let n = range.len();
        if n == 0 {
            return Cutting::Empty;
        }
        // A small batch is kept whole while its box is no larger than r_max times its
        // primitives' (Eq. 3 without the ∛ factor, which would split every surface patch down
        // to single triangles); a scattered one, as a random order or random edits give, is
        // still split. So is a crowded one: a piece of thin geometry (a strand of hair, a
        // cable) whose box the rest of the scene crosses. Inserted whole, its bBVH root
        // overlaps all that geometry, and no update splits it as well as the cut does. The
        // batch's own ratio cannot see this; the scene's mean density can. A flat
        // patch has no volume, so walls and floors are never crowded.
        let area = bounds.area();
        let small =
            n <= 1 || (n <= self.min_batch && area < self.r_max * sum && !self.crowded(&bounds, n));
        if small || (n <= self.max_batch && coherence(area, sum, n) < self.r_max) {
            return Cutting::Batch(range);
        }
        let next = (axis + 1) % 3;
        let mut i = prims.split_at(&mut order[range.clone()], axis, bounds.center()[axis]);
        if i == 0 || i == n {
            // Every centre on one side of the middle: halve the range as it stands.
            i = n / 2;
        }
        // The halves are measured after the partition, each in a pass of its own: gathering both
        // sides' bounds while partitioning made every primitive wait on a union held in memory
        // (the side it fell on), which cost more than the second pass.
        let (l, r) = order[range.clone()].split_at(i);
        let [(lb, ls), (rb, rs)] = [prims.bounds_and_area(l), prims.bounds_and_area(r)];
        let mid = range.start + i;
        Cutting::Split(
            Pending {
                range: range.start..mid,
                axis: next,
                bounds: lb,
                sum: ls,
            },
            Pending {
                range: mid..range.end,
                axis: next,
                bounds: rb,
                sum: rs,
            },
        )
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

/// One buffer cut into coherent batches, whose bBVHs are built a step at a time.
struct BufferBatches {
    index: usize,
    prims: Prims,
    order: Vec<u32>,
    /// Ranges of `order` the cut has still to look at, the leftmost last.
    pending: Vec<Pending>,
    /// The buffer's batches found so far, in order, and how many of them earlier steps took.
    /// Once nothing is pending they tile `order`.
    batches: Vec<Range<usize>>,
    taken: usize,
    /// Whether no step of the buffer has gone to the owner yet.
    untaken: bool,
}

/// Primitives the cut looks at per piece of a buffer cut ahead: a piece takes a fraction of
/// the owner's time for one step, so this side comes back to its queue in time.
const CUT_PIECE: usize = 1 << 12;

impl BufferBatches {
    /// Buffer `index` of the stream, holding `tris` (checked already), with its cut still to do.
    fn new(index: usize, tris: &[Triangle]) -> Self {
        let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
        let prims = Prims::new(&boxes);
        let order: Vec<u32> = (0..boxes.len() as u32).collect();
        let pending = vec![Pending::whole(&prims, &order)];
        Self {
            index,
            prims,
            order,
            pending,
            batches: Vec::new(),
            taken: 0,
            untaken: true,
        }
    }

    /// Cuts about `budget` primitives' worth of the pending ranges, left to right, on this thread.
    fn cut_piece(&mut self, cut: &Cut, budget: usize) {
        let mut looked = 0;
        while looked < budget {
            let Some(p) = self.pending.pop() else { break };
            looked += p.range.len();
            match cut.look(&self.prims, &mut self.order, p) {
                Cutting::Empty => {}
                Cutting::Batch(r) => self.batches.push(r),
                Cutting::Split(l, r) => {
                    self.pending.push(r);
                    self.pending.push(l);
                }
            }
        }
    }

    /// Cuts whatever is pending, in parallel: an owner that has inserted what it was sent helps
    /// with the cutting instead of waiting for it.
    fn cut_rest(&mut self, cut: &Cut) {
        while let Some(p) = self.pending.pop() {
            cut.batches_from(
                &self.prims,
                &mut self.order,
                0,
                p,
                PARALLEL_DEPTH,
                &mut self.batches,
            );
        }
    }
}

/// What the building side hands the owner per step.
struct Step {
    /// Index of the buffer whose triangles the bBVHs' leaves index.
    buffer: usize,
    /// Whether this is the buffer's first step: the owner then stores its triangles.
    first_of_buffer: bool,
    /// The inner nodes of all the step's bBVHs: each batch's `len - 1` in turn, indexed locally.
    nodes: Vec<InnerNode>,
    /// Each batch's root and number of inner nodes, in order.
    roots: Vec<(NodeRef, u32)>,
}

/// The building side of IncrUPB: cuts buffers into batches and builds their bBVHs, a step at a time.
/// It never touches the tree, so it runs beside the owner.
struct BatchBuilder<'a> {
    tris: &'a [Triangle],
    buffers: &'a [Range<usize>],
    next_buffer: usize,
    current: Option<BufferBatches>,
    /// The next buffer, cut while this side waited for the owner.
    ahead: Option<BufferBatches>,
    cut: Cut,
}

impl BatchBuilder<'_> {
    /// The next buffer of the stream, its cut not begun; `None` once every buffer was taken.
    fn next_buffer(&mut self) -> Option<BufferBatches> {
        let index = self.next_buffer;
        let buf = self.buffers.get(index).cloned()?;
        self.next_buffer += 1;
        Some(BufferBatches::new(index, &self.tris[buf]))
    }

    /// Cuts a piece of the buffer after the current one; returns whether there was any to cut.
    /// Called while the owner has enough queued. A full buffer's cut takes as long as the
    /// owner's work on several steps: done whole when the current buffer ran out, it left the
    /// owner waiting, and done whole ahead, it let the queue run dry.
    fn cut_ahead(&mut self) -> bool {
        if self.current.is_none() {
            return false;
        }
        match &mut self.ahead {
            Some(b) if b.pending.is_empty() => false,
            Some(b) => {
                b.cut_piece(&self.cut, CUT_PIECE);
                true
            }
            None => {
                self.ahead = self.next_buffer();
                self.ahead.is_some()
            }
        }
    }

    /// The bBVHs of the next step's batches (built in parallel), with the buffer they index; `None`
    /// once the stream is done.
    fn next_step(&mut self) -> Option<Step> {
        loop {
            if self.current.is_none() {
                let mut b = match self.ahead.take() {
                    Some(b) => b,
                    None => self.next_buffer()?,
                };
                b.cut_rest(&self.cut);
                self.current = Some(b);
            }
            let c = self.current.as_mut()?;
            if c.taken == c.batches.len() {
                self.current = None;
                continue;
            }
            // A step never spans two buffers: its bBVHs index one buffer's triangles.
            let first = c.taken;
            let mut count = 0;
            while c.taken < c.batches.len() && count < STEP {
                count += c.batches[c.taken].len();
                c.taken += 1;
            }
            // The batches tile `order` in sequence: cut this step's run of it into one slice per
            // batch, each built in place, so no batch copies its boxes. A batch of k primitives
            // has k - 1 inner nodes: the step's bBVHs share one node array, cut the same way, so
            // that a step allocates (and the owner frees) one array, not one per batch.
            let run = &c.batches[first..c.taken];
            let mut nodes = vec![InnerNode::UNLINKED; count - run.len()];
            let mut jobs = Vec::with_capacity(run.len());
            let mut rest = &mut c.order[run[0].start..run[run.len() - 1].end];
            let mut rest_nodes = &mut nodes[..];
            for r in run {
                let (head, tail) = rest.split_at_mut(r.len());
                let (node_head, node_tail) = rest_nodes.split_at_mut(r.len() - 1);
                jobs.push((head, node_head));
                rest = tail;
                rest_nodes = node_tail;
            }
            let prims = &c.prims;
            let roots = jobs
                .into_par_iter()
                .map(|(slice, nodes)| {
                    let inner = nodes.len() as u32;
                    (build_batch_into(prims, slice, nodes), inner)
                })
                .collect();
            return Some(Step {
                buffer: c.index,
                first_of_buffer: std::mem::take(&mut c.untaken),
                nodes,
                roots,
            });
        }
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
    /// Queues a step, first waiting while the owner is running and has enough to do; `meanwhile`
    /// is called while waiting, and idles when it returns false (nothing left to do ahead).
    fn send(&self, step: Step, mut meanwhile: impl FnMut() -> bool) {
        while self.owner_running.load(Ordering::Acquire) && self.queued() >= LOOKAHEAD {
            if !meanwhile() {
                idle();
            }
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

/// Bounds of `tris`, and whether every vertex is within limits (see `within_limits`): one pass
/// over the vertices, a long stream's pieces in parallel. The cut needs the bounds (for the
/// scene's density) before either side starts, and the same loads check the input, so neither
/// side checks it again. Bounds of input that fails the check are not to be used.
fn checked_bounds(tris: &[Triangle]) -> (Aabb, bool) {
    /// Triangles measured in one piece: a pass over them takes a small fraction of a millisecond.
    const PIECE: usize = 1 << 15;
    let measure = |part: &[Triangle]| {
        part.iter().fold((Box3A::EMPTY, true), |(mut b, ok), t| {
            for v in t.v {
                b.grow(v.into());
            }
            (b, ok & within_limits(t))
        })
    };
    let (b, ok) = if tris.len() <= PIECE {
        measure(tris)
    } else {
        tris.par_chunks(PIECE)
            .map(measure)
            .reduce(|| (Box3A::EMPTY, true), |a, b| (a.0.union(&b.0), a.1 & b.1))
    };
    (b.aabb(), ok)
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
        self.check_room(tris.len())?;
        let (input, valid) = checked_bounds(tris);
        if !valid {
            // The slow pass that finds the first invalid vertex and says why.
            validate_triangles(tris)?;
        }
        let buffers = buffers(tris.len());
        let mut builder = BatchBuilder {
            tris,
            buffers: &buffers,
            next_buffer: 0,
            current: None,
            ahead: None,
            cut: Cut {
                r_max: self.config.coherence_max,
                min_batch: self.config.block_min_batch as usize,
                max_batch: self.config.block_max_batch.max(1) as usize,
                crowding: crowding(
                    &self.bounds().union(&input),
                    self.triangle_count() as usize + tris.len(),
                    self.config.block_crowd_max,
                ),
            },
        };
        let mut ids = Vec::with_capacity(tris.len());
        let pipe = Pipeline::default();
        rayon::join(
            || {
                let _done = StoreOnDrop(&pipe.done, true);
                while let Some(step) = builder.next_step() {
                    pipe.send(step, || builder.cut_ahead());
                }
            },
            || {
                pipe.owner_running.store(true, Ordering::Release);
                let _gone = StoreOnDrop(&pipe.owner_running, false);
                self.reserve(tris.len());
                let mut last = NodeRef::NONE;
                while let Some(Step {
                    buffer,
                    first_of_buffer,
                    nodes,
                    roots,
                }) = pipe.receive()
                {
                    // A buffer's triangles get their ids when its first bBVHs arrive.
                    let buf = &buffers[buffer];
                    if first_of_buffer {
                        self.alloc_triangles_into(&tris[buf.clone()], &mut ids);
                    }
                    // The bBVH's own nodes are candidates for updates too: where batches meet,
                    // their boxes overlap, and only moving nodes inside them can fix that.
                    let mut rest = &nodes[..];
                    for &(root, inner) in &roots {
                        let (tree, tail) = rest.split_at(inner as usize);
                        rest = tail;
                        let root = self.graft_with(tree, root, &ids[buf.start..buf.end], true);
                        // Consecutive batches are neighbours in the cut's order, so the last root
                        // is a close candidate: seeded with it, the search starts from a tight
                        // bound and expands fewer nodes. The best it finds is the same up to ties.
                        self.insert_item_near(root, last);
                        last = root;
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
