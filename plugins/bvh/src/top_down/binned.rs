//! Binned SAH (up to 16 bins on each axis over the centroid bounds): fast, used for bBVHs, groups
//! and the post-pass restarts.
//!
//! The builder works on the boxes in 16-byte lanes ([`Prims`]): binning a primitive on all three
//! axes is one vector subtraction, one multiplication and one conversion, and each union two vector
//! instructions, where `Aabb`'s packed `Vec3`s need a scalar operation per axis.

use super::BuiltTree;
use super::prims::{Box3A, Prims};
use crate::Aabb;
use crate::tree::node::{InnerNode, NONE, NodeRef};
use glam::Vec3A;

const BINS: usize = 16;
/// Ranges this small are split exactly: every partition is costed.
const SMALL: usize = 4;
/// Ranges this small are split exactly along each axis: sorted by centre and swept, which costs
/// less than filling and sweeping bins for so few primitives.
const SWEEP: usize = 16;

/// Binned SAH builder, one primitive per leaf.
pub fn build_binned(boxes: &[Aabb]) -> BuiltTree {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    build_binned_over(&Prims::new(boxes), &mut order)
}

/// Binned SAH over the primitives `order` lists, reordering `order` in place; leaves are
/// `NodeRef::leaf(index)`. Builds over part of a larger array without copying it, which is how
/// IncrUPB builds its many small bBVHs.
pub(crate) fn build_binned_over(prims: &Prims, order: &mut [u32]) -> BuiltTree {
    let mut bins = Bins::default();
    assemble_sides(prims, order, |range, whole| {
        split(prims, &mut bins, range, whole)
    })
}

/// Builds the tree over the primitives `order` lists by splitting ranges top-down: `split(range,
/// side)` gets a range of at least two primitives with its [`Side`], reorders it, and returns its
/// two halves' sides, left first, both non-empty (`count` says where the range splits; a side of
/// one primitive, a leaf, need not be measured). Leaves are `NodeRef::leaf(primitive)`.
///
/// Each range arrives with its bounds and centroid bounds, worked out while its parent was split,
/// so a split needs no pass of its own to measure its range.
pub(super) fn assemble_sides(
    prims: &Prims,
    order: &mut [u32],
    mut split: impl FnMut(&mut [u32], &Side) -> [Side; 2],
) -> BuiltTree {
    let n = order.len();
    if n <= 1 {
        return BuiltTree {
            nodes: Vec::new(),
            root: order.first().map_or(NodeRef::NONE, |&p| NodeRef::leaf(p)),
        };
    }
    let mut nodes: Vec<InnerNode> = Vec::with_capacity(n - 1);
    let mut stack = vec![Pending {
        start: 0,
        end: n,
        parent: NONE,
        slot: 0,
        side: Side::of(prims, order),
    }];
    while let Some(r) = stack.pop() {
        let me = if r.end - r.start == 1 {
            NodeRef::leaf(order[r.start])
        } else {
            let [left, right] = split(&mut order[r.start..r.end], &r.side);
            let i = nodes.len() as u32;
            nodes.push(InnerNode {
                aabb: r.side.bounds.aabb(),
                children: [NodeRef::NONE; 2],
                parent: r.parent,
            });
            let mid = r.start + left.count;
            debug_assert!(mid > r.start && mid < r.end);
            stack.push(Pending {
                start: mid,
                end: r.end,
                parent: i,
                slot: 1,
                side: right,
            });
            stack.push(Pending {
                start: r.start,
                end: mid,
                parent: i,
                slot: 0,
                side: left,
            });
            NodeRef::inner(i)
        };
        if r.parent != NONE {
            nodes[r.parent as usize].children[r.slot] = me;
        }
    }
    BuiltTree {
        nodes,
        root: NodeRef::inner(0),
    }
}

/// A range still to be split.
struct Pending {
    start: usize,
    end: usize,
    parent: u32,
    slot: usize,
    side: Side,
}

/// One side of a split: its size, the bounds of its boxes and of their centres.
#[derive(Clone, Copy)]
pub(crate) struct Side {
    pub(crate) count: usize,
    pub(super) bounds: Box3A,
    pub(super) centroids: Box3A,
}

impl Side {
    pub(super) const EMPTY: Side = Side {
        count: 0,
        bounds: Box3A::EMPTY,
        centroids: Box3A::EMPTY,
    };

    /// All the primitives `range` lists.
    pub(crate) fn of(prims: &Prims, range: &[u32]) -> Side {
        let (bounds, centroids) = prims.bounds(range);
        Side {
            count: range.len(),
            bounds,
            centroids,
        }
    }

    #[inline]
    fn add(&mut self, b: &Box3A, c: Vec3A) {
        self.count += 1;
        self.bounds = self.bounds.union(b);
        self.centroids.grow(c);
    }
}

/// Bin arrays, reused from node to node so that each split clears only the bins it uses.
pub(crate) struct Bins {
    boxes: [[Box3A; BINS]; 3],
    counts: [[u32; BINS]; 3],
}

impl Default for Bins {
    fn default() -> Self {
        Self {
            boxes: [[Box3A::EMPTY; BINS]; 3],
            counts: [[0; BINS]; 3],
        }
    }
}

/// Bin of each axis for a centre already scaled to `[0, bins)` (and clamped there).
#[inline]
fn bin_of(rel: Vec3A) -> [usize; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128, _mm_cvttps_epi32};
        // SAFETY: SSE2 is part of x86-64; the lanes are finite and in [0, BINS), so truncation is
        // exact and no lane can overflow.
        let lanes: [i32; 4] = unsafe { std::mem::transmute(_mm_cvttps_epi32(__m128::from(rel))) };
        [lanes[0] as usize, lanes[1] as usize, lanes[2] as usize]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        [rel.x as usize, rel.y as usize, rel.z as usize]
    }
}

/// Splits `range` (at least two primitives, all of `whole`) at the cheapest bin boundary of any
/// axis, partitioning it in place: the first returned side's primitives come first. Both sides are
/// non-empty.
pub(crate) fn split(
    prims: &Prims,
    scratch: &mut Bins,
    range: &mut [u32],
    whole: &Side,
) -> [Side; 2] {
    let m = range.len();
    if m <= SMALL {
        return split_small(prims, range);
    }
    if m <= SWEEP {
        return split_sweep(prims, range, &whole.centroids);
    }
    let cb = &whole.centroids;
    let ext = cb.max - cb.min;
    // Small ranges get as many bins as primitives: most nodes of a tree are near its leaves, and
    // setting up and sweeping 48 bins for a few primitives would cost more than the binning.
    let bins = m.min(BINS);
    let scale = Vec3A::select(
        ext.cmpgt(Vec3A::ZERO),
        Vec3A::splat(bins as f32) / ext,
        Vec3A::ZERO,
    );
    let top = Vec3A::splat(bins as f32 - 1.0);
    let (bin_box, bin_count) = (&mut scratch.boxes, &mut scratch.counts);
    for axis in 0..3 {
        bin_box[axis][..bins].fill(Box3A::EMPTY);
        bin_count[axis][..bins].fill(0);
    }
    for &p in range.iter() {
        let b = &prims.boxes[p as usize];
        let k = bin_of(((prims.centers[p as usize] - cb.min) * scale).clamp(Vec3A::ZERO, top));
        for axis in 0..3 {
            bin_box[axis][k[axis]] = bin_box[axis][k[axis]].union(b);
            bin_count[axis][k[axis]] += 1;
        }
    }
    let mut best = (f32::INFINITY, usize::MAX, 0usize);
    let mut right_area = [0.0f32; BINS];
    let mut right_count = [0u32; BINS];
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let (boxes, counts) = (&bin_box[axis], &bin_count[axis]);
        let (mut acc, mut cnt) = (Box3A::EMPTY, 0);
        for k in (1..bins).rev() {
            acc = acc.union(&boxes[k]);
            cnt += counts[k];
            right_area[k] = acc.area();
            right_count[k] = cnt;
        }
        let (mut acc, mut cnt) = (Box3A::EMPTY, 0);
        for k in 0..bins - 1 {
            acc = acc.union(&boxes[k]);
            cnt += counts[k];
            if cnt == 0 || right_count[k + 1] == 0 {
                continue;
            }
            let c = acc.area() * cnt as f32 + right_area[k + 1] * right_count[k + 1] as f32;
            if c < best.0 {
                best = (c, axis, k + 1);
            }
        }
    }
    let mut sides = [Side::EMPTY; 2];
    if best.1 == usize::MAX {
        // All centroids coincide: any split is as good as another.
        for (j, &p) in range.iter().enumerate() {
            sides[(j >= m / 2) as usize].add(&prims.boxes[p as usize], prims.centers[p as usize]);
        }
        return sides;
    }
    let (_, axis, split_bin) = best;
    let (min, s, top) = (cb.min[axis], scale[axis], bins as f32 - 1.0);
    let mut i = 0;
    for j in 0..m {
        let p = range[j];
        let c = prims.centers[p as usize];
        // The same arithmetic as the binning, so each primitive lands on the side its bin is on.
        let left = (((c[axis] - min) * s).clamp(0.0, top) as usize) < split_bin;
        sides[!left as usize].add(&prims.boxes[p as usize], c);
        if left {
            range.swap(i, j);
            i += 1;
        }
    }
    debug_assert!(
        i > 0 && i < m,
        "the chosen boundary has primitives on both sides"
    );
    sides
}

/// The SAH-best split of a range of at most [`SWEEP`] primitives among those that cut the order of
/// their centres on some axis: each axis is sorted (insertion sort: the ranges are tiny) and swept.
fn split_sweep(prims: &Prims, range: &mut [u32], cb: &Box3A) -> [Side; 2] {
    let m = range.len();
    let mut sorted = [(0.0f32, 0u32); SWEEP];
    let mut best_order = [0u32; SWEEP];
    let (mut best, mut best_at) = (f32::INFINITY, 0usize);
    let mut right_area = [0.0f32; SWEEP];
    for axis in [cb.largest_axis()] {
        for (k, &p) in range.iter().enumerate() {
            sorted[k] = (prims.centers[p as usize][axis], p);
        }
        for k in 1..m {
            let x = sorted[k];
            let mut j = k;
            while j > 0 && sorted[j - 1].0 > x.0 {
                sorted[j] = sorted[j - 1];
                j -= 1;
            }
            sorted[j] = x;
        }
        let mut acc = Box3A::EMPTY;
        for k in (1..m).rev() {
            acc = acc.union(&prims.boxes[sorted[k].1 as usize]);
            right_area[k] = acc.area();
        }
        let mut acc = Box3A::EMPTY;
        let mut improved = false;
        for k in 1..m {
            acc = acc.union(&prims.boxes[sorted[k - 1].1 as usize]);
            let c = acc.area() * k as f32 + right_area[k] * (m - k) as f32;
            if c < best {
                best = c;
                best_at = k;
                improved = true;
            }
        }
        if improved {
            for k in 0..m {
                best_order[k] = sorted[k].1;
            }
        }
    }
    if best_at == 0 {
        // Only NaN costs, which validated input never gives: split in the middle.
        best_at = m / 2;
        best_order[..m].copy_from_slice(range);
    }
    let mut sides = [Side::EMPTY; 2];
    for (k, &p) in best_order[..m].iter().enumerate() {
        range[k] = p;
        sides[(k >= best_at) as usize].add(&prims.boxes[p as usize], prims.centers[p as usize]);
    }
    sides
}

/// The SAH-best of all partitions of a range of 2 to [`SMALL`] primitives (most nodes of a bBVH are
/// this small, and binning them costs more than trying every way to split them).
fn split_small(prims: &Prims, range: &mut [u32]) -> [Side; 2] {
    let m = range.len();
    if m == 2 {
        let mut sides = [Side::EMPTY; 2];
        for (k, &p) in range.iter().enumerate() {
            sides[k].add(&prims.boxes[p as usize], prims.centers[p as usize]);
        }
        return sides;
    }
    let mut b = [Box3A::EMPTY; SMALL];
    for (k, &p) in range.iter().enumerate() {
        b[k] = prims.boxes[p as usize];
    }
    // Masks of the left side; the last primitive always goes right, so each partition comes once.
    let (mut best, mut best_mask) = (f32::INFINITY, 1u32);
    for mask in 1u32..(1 << (m - 1)) {
        let (mut l, mut r) = (Box3A::EMPTY, Box3A::EMPTY);
        for (k, x) in b[..m].iter().enumerate() {
            if mask & (1 << k) != 0 {
                l = l.union(x);
            } else {
                r = r.union(x);
            }
        }
        let nl = mask.count_ones();
        let c = l.area() * nl as f32 + r.area() * (m as u32 - nl) as f32;
        if c < best {
            best = c;
            best_mask = mask;
        }
    }
    let mut sides = [Side::EMPTY; 2];
    let mut i = 0;
    for k in 0..m {
        let p = range[k];
        let left = best_mask & (1 << k) != 0;
        sides[!left as usize].add(&b[k], prims.centers[p as usize]);
        if left {
            range.swap(i, k);
            i += 1;
        }
    }
    sides
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn every_node_box_is_the_union_of_its_children() {
        let mut rnd = crate::test_random(77u64);
        for n in [2usize, 3, 4, 5, 9, 16, 17, 40, 300] {
            let mut boxes: Vec<Aabb> = (0..n)
                .map(|_| {
                    let c = Vec3::new(rnd(), rnd(), rnd()) * 10.0;
                    Aabb::new(c, c + Vec3::new(rnd(), rnd(), rnd()))
                })
                .collect();
            // Coinciding centres and flat boxes too.
            boxes[0] = boxes[n - 1];
            boxes[n / 2].max.y = boxes[n / 2].min.y;
            let tree = build_binned(&boxes);
            assert_eq!(tree.nodes.len(), n - 1);
            let mut seen = vec![false; n];
            for node in &tree.nodes {
                let mut u = Aabb::EMPTY;
                for c in node.children {
                    let b = match c.kind() {
                        crate::NodeKind::Inner => tree.nodes[c.index() as usize].aabb,
                        _ => {
                            seen[c.index() as usize] = true;
                            boxes[c.index() as usize]
                        }
                    };
                    u = u.union(&b);
                }
                // Bounds handed down from the parent's split stay exact.
                assert_eq!(u, node.aabb);
            }
            assert!(seen.iter().all(|&s| s), "every primitive in one leaf");
        }
    }
}
