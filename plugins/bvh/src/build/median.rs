//! Spatial median: split the centroid bounds in the middle of their longest axis.

use super::{BuiltTree, assemble};
use crate::Aabb;

/// Spatial median builder, one primitive per leaf.
pub fn build_median(boxes: &[Aabb]) -> BuiltTree {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    assemble(boxes, &mut order, |_, range| {
        let m = range.len();
        let mut cb = Aabb::EMPTY;
        for &p in range.iter() {
            cb.grow(boxes[p as usize].center());
        }
        let axis = cb.largest_axis();
        let pivot = cb.center()[axis];
        let mut i = 0;
        for j in 0..m {
            if boxes[range[j] as usize].center()[axis] < pivot {
                range.swap(i, j);
                i += 1;
            }
        }
        if i == 0 || i == m { m / 2 } else { i }
    })
}
