//! Full-sweep SAH: at every node, every split between consecutive centroids on all three axes.
//! Three index lists stay sorted by centroid and are partitioned stably, so each level costs O(n).

use super::{BuiltTree, assemble};
use crate::Aabb;

/// Full-sweep SAH builder, one primitive per leaf.
pub fn build_sweep_sah(boxes: &[Aabb]) -> BuiltTree {
    let n = boxes.len();
    let centers: Vec<[f32; 3]> = boxes.iter().map(|b| b.center().to_array()).collect();
    let mut sorted: [Vec<u32>; 3] = std::array::from_fn(|axis| {
        let mut v: Vec<u32> = (0..n as u32).collect();
        v.sort_unstable_by(|&a, &b| {
            centers[a as usize][axis]
                .total_cmp(&centers[b as usize][axis])
                .then(a.cmp(&b))
        });
        v
    });
    // Every range `assemble` asks about holds the same set of primitives in all three lists.
    let mut side = vec![false; n];
    let mut right_area = vec![0.0f32; n];
    let mut tmp: Vec<u32> = Vec::with_capacity(n);
    let mut order = sorted[0].clone();
    assemble(boxes, &mut order, |s, range| {
        let m = range.len();
        let e = s + m;
        let mut best = (f32::INFINITY, 0usize, m / 2);
        for (axis, list) in sorted.iter().enumerate() {
            let list = &list[s..e];
            let mut acc = Aabb::EMPTY;
            for i in (1..m).rev() {
                acc = acc.union(&boxes[list[i] as usize]);
                right_area[i] = acc.area();
            }
            let mut acc = Aabb::EMPTY;
            for i in 0..m - 1 {
                acc = acc.union(&boxes[list[i] as usize]);
                let c = acc.area() * (i + 1) as f32 + right_area[i + 1] * (m - i - 1) as f32;
                if c < best.0 {
                    best = (c, axis, i + 1);
                }
            }
        }
        let (_, axis, mid) = best;
        for (k, &p) in sorted[axis][s..e].iter().enumerate() {
            side[p as usize] = k >= mid;
        }
        for list in sorted.iter_mut() {
            let list = &mut list[s..e];
            tmp.clear();
            tmp.extend(list.iter().copied().filter(|&p| !side[p as usize]));
            tmp.extend(list.iter().copied().filter(|&p| side[p as usize]));
            list.copy_from_slice(&tmp);
        }
        range.copy_from_slice(&sorted[0][s..e]);
        mid
    })
}
