//! Binned SAH (32 bins on each axis over the centroid bounds): fast, used for bBVHs.

use super::{BuiltTree, assemble_with_bounds};
use crate::Aabb;
use glam::Vec3;

const BINS: usize = 32;

/// Binned SAH builder, one primitive per leaf.
pub fn build_binned(boxes: &[Aabb]) -> BuiltTree {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    let centers = centers(boxes);
    let mut bins = Bins::default();
    assemble_with_bounds(&mut order, |_, range| {
        split_binned(boxes, &centers, &mut bins, range)
    })
}

/// Bin arrays, reused from node to node so that each split clears only the bins it uses.
pub(crate) struct Bins {
    boxes: [[Aabb; BINS]; 3],
    counts: [[u32; BINS]; 3],
}

impl Default for Bins {
    fn default() -> Self {
        Self {
            boxes: [[Aabb::EMPTY; BINS]; 3],
            counts: [[0; BINS]; 3],
        }
    }
}

/// Primitive centroids, computed once per build rather than at every level.
pub(crate) fn centers(boxes: &[Aabb]) -> Vec<Vec3> {
    boxes.iter().map(Aabb::center).collect()
}

/// Splits `range` (at least two primitives) at the cheapest bin boundary of any axis, and returns
/// the split position with the bounds of the range's boxes. Three passes: bounds, binning of all
/// three axes at once, partition.
pub(crate) fn split_binned(
    boxes: &[Aabb],
    centers: &[Vec3],
    scratch: &mut Bins,
    range: &mut [u32],
) -> (usize, Aabb) {
    let m = range.len();
    let mut bounds = Aabb::EMPTY;
    let mut cb = Aabb::EMPTY;
    for &p in range.iter() {
        bounds = bounds.union(&boxes[p as usize]);
        cb.grow(centers[p as usize]);
    }
    let ext = cb.extent();
    // Small ranges get as many bins as primitives: most nodes of a tree are near its leaves, and
    // setting up and sweeping 96 bins for three primitives would cost more than the binning.
    let bins = m.clamp(2, BINS);
    let scale = Vec3::from_array([0, 1, 2].map(|a| {
        if ext[a] > 0.0 {
            bins as f32 / ext[a]
        } else {
            0.0
        }
    }));
    let (bin_box, bin_count) = (&mut scratch.boxes, &mut scratch.counts);
    for axis in 0..3 {
        bin_box[axis][..bins].fill(Aabb::EMPTY);
        bin_count[axis][..bins].fill(0);
    }
    for &p in range.iter() {
        let b = &boxes[p as usize];
        let rel = (centers[p as usize] - cb.min) * scale;
        for axis in 0..3 {
            let k = (rel[axis] as usize).min(bins - 1);
            bin_box[axis][k] = bin_box[axis][k].union(b);
            bin_count[axis][k] += 1;
        }
    }
    let mut best = (f32::INFINITY, usize::MAX, 0usize);
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let (boxes, counts) = (&bin_box[axis], &bin_count[axis]);
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for k in (1..bins).rev() {
            acc = acc.union(&boxes[k]);
            cnt += counts[k];
            right_area[k] = acc.area();
            right_count[k] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
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
    if best.1 == usize::MAX {
        // All centroids coincide: any split is as good as another.
        return (m / 2, bounds);
    }
    let (_, axis, split_bin) = best;
    let (min, s) = (cb.min[axis], scale[axis]);
    let goes_left =
        |p: u32| ((((centers[p as usize][axis] - min) * s) as usize).min(bins - 1)) < split_bin;
    let mut i = 0;
    for j in 0..m {
        if goes_left(range[j]) {
            range.swap(i, j);
            i += 1;
        }
    }
    (if i == 0 || i == m { m / 2 } else { i }, bounds)
}
