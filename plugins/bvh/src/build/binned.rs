//! Binned SAH (32 bins on each axis over the centroid bounds): fast, used for bBVHs.

use super::{BuiltTree, assemble};
use crate::Aabb;

const BINS: usize = 32;

/// Binned SAH builder, one primitive per leaf.
pub fn build_binned(boxes: &[Aabb]) -> BuiltTree {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    assemble(boxes, &mut order, |_, range| split_binned(boxes, range))
}

pub(crate) fn split_binned(boxes: &[Aabb], range: &mut [u32]) -> usize {
    let m = range.len();
    let mut cb = Aabb::EMPTY;
    for &p in range.iter() {
        cb.grow(boxes[p as usize].center());
    }
    let ext = cb.extent();
    let mut best = (f32::INFINITY, usize::MAX, 0usize);
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / ext[axis];
        let mut bin_box = [Aabb::EMPTY; BINS];
        let mut bin_count = [0u32; BINS];
        for &p in range.iter() {
            let b = &boxes[p as usize];
            let k = (((b.center()[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1);
            bin_box[k] = bin_box[k].union(b);
            bin_count[k] += 1;
        }
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for k in (1..BINS).rev() {
            acc = acc.union(&bin_box[k]);
            cnt += bin_count[k];
            right_area[k] = acc.area();
            right_count[k] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for k in 0..BINS - 1 {
            acc = acc.union(&bin_box[k]);
            cnt += bin_count[k];
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
        return m / 2;
    }
    let (_, axis, split_bin) = best;
    let scale = BINS as f32 / ext[axis];
    let goes_left = |p: u32| {
        let c = boxes[p as usize].center()[axis];
        ((((c - cb.min[axis]) * scale) as usize).min(BINS - 1)) < split_bin
    };
    let mut i = 0;
    for j in 0..m {
        if goes_left(range[j]) {
            range.swap(i, j);
            i += 1;
        }
    }
    if i == 0 || i == m { m / 2 } else { i }
}
