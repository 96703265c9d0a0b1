//! The primitives of the top-down builders and of IncrUPB's batcher, converted once into 16-byte
//! vector lanes: a union is two vector instructions and a side test one compare, where `Aabb`'s
//! packed `Vec3`s need a scalar operation per axis.

use crate::Aabb;
use crate::tree::aabb::extent_area;
use glam::Vec3A;

/// A box in vector lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Box3A {
    pub(crate) min: Vec3A,
    pub(crate) max: Vec3A,
}

impl Box3A {
    pub(crate) const EMPTY: Box3A = Box3A {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    #[inline]
    pub(crate) fn union(&self, o: &Box3A) -> Box3A {
        Box3A {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    pub(crate) fn grow(&mut self, p: Vec3A) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    #[inline]
    pub(crate) fn area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3A::ZERO);
        extent_area(d.x, d.y, d.z)
    }

    /// The axis of the largest extent (the first of equal ones), as [`Aabb::largest_axis`] has it.
    #[inline]
    pub(crate) fn largest_axis(&self) -> usize {
        self.aabb().largest_axis()
    }

    #[inline]
    pub(crate) fn center(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }

    #[inline]
    pub(crate) fn aabb(&self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }
}

/// The primitives of one or more builds: boxes, centres and areas, converted once.
pub(crate) struct Prims {
    pub(crate) boxes: Vec<Box3A>,
    pub(crate) centers: Vec<Vec3A>,
    areas: Vec<f32>,
}

impl Prims {
    pub(crate) fn new(boxes: &[Aabb]) -> Self {
        let boxes: Vec<Box3A> = boxes
            .iter()
            .map(|b| Box3A {
                min: b.min.into(),
                max: b.max.into(),
            })
            .collect();
        let centers = boxes.iter().map(Box3A::center).collect();
        let areas = boxes.iter().map(Box3A::area).collect();
        Self {
            boxes,
            centers,
            areas,
        }
    }

    /// Bounds of the boxes and of the centres of the primitives `range` lists.
    pub(crate) fn bounds(&self, range: &[u32]) -> (Box3A, Box3A) {
        let (mut b, mut c) = (Box3A::EMPTY, Box3A::EMPTY);
        for &p in range {
            b = b.union(&self.boxes[p as usize]);
            c.grow(self.centers[p as usize]);
        }
        (b, c)
    }

    /// Bounds of the boxes the primitives `range` lists, and the sum of their areas.
    pub(crate) fn bounds_and_area(&self, range: &[u32]) -> (Box3A, f32) {
        // Two running sums: one would make each addition wait for the last (a float add's
        // latency is several times the rest of the loop's work per primitive).
        let (mut b, mut sums) = (Box3A::EMPTY, [0.0f32; 2]);
        let mut pairs = range.chunks_exact(2);
        for pair in &mut pairs {
            let (p, q) = (pair[0] as usize, pair[1] as usize);
            b = b.union(&self.boxes[p]).union(&self.boxes[q]);
            sums[0] += self.areas[p];
            sums[1] += self.areas[q];
        }
        for &p in pairs.remainder() {
            b = b.union(&self.boxes[p as usize]);
            sums[0] += self.areas[p as usize];
        }
        (b, sums[0] + sums[1])
    }

    /// Partitions `range` in place: primitives whose centre lies below `pivot` on `axis` first.
    /// Returns how many those are. The order within each side is not kept.
    ///
    /// Every primitive is written whichever side it falls on (the swap of a branch-free Lomuto
    /// partition), so the loop has no branch on the data: in a coherent stream the side changes
    /// every few primitives, too often for a predictor and too seldom to be ignored. The side
    /// test is one vector compare and a mask bit, since picking a vector lane by a runtime axis
    /// would branch on the axis.
    pub(crate) fn split_at(&self, range: &mut [u32], axis: usize, pivot: f32) -> usize {
        let pivot = Vec3A::splat(pivot);
        let mut i = 0;
        for j in 0..range.len() {
            let p = range[j];
            let below = (self.centers[p as usize].cmplt(pivot).bitmask() >> axis) & 1;
            range[j] = range[i];
            range[i] = p;
            i += below as usize;
        }
        i
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn random_boxes(n: usize, seed: u64) -> Vec<Aabb> {
        let mut rnd = crate::test_random(seed);
        let mut boxes: Vec<Aabb> = (0..n)
            .map(|_| {
                let c = Vec3::new(rnd(), rnd(), rnd()) * 10.0;
                Aabb::new(c, c + Vec3::new(rnd(), rnd(), rnd()))
            })
            .collect();
        // Coinciding centres, so some lie exactly on a pivot.
        if n > 2 {
            boxes[1] = boxes[0];
        }
        boxes
    }

    #[test]
    fn split_at_puts_the_centres_below_the_pivot_first_and_keeps_every_primitive() {
        for (n, seed) in [(0usize, 1u64), (1, 2), (2, 3), (7, 4), (100, 5), (1000, 6)] {
            let boxes = random_boxes(n, seed);
            let prims = Prims::new(&boxes);
            for axis in 0..3 {
                // Pivots outside the range, through it, and exactly on a centre.
                let on_centre = boxes.first().map_or(0.0, |b| b.center()[axis]);
                for pivot in [-1.0, 5.0, 11.0, on_centre] {
                    let mut order: Vec<u32> = (0..n as u32).rev().collect();
                    let i = prims.split_at(&mut order, axis, pivot);
                    let below = |&p: &u32| boxes[p as usize].center()[axis] < pivot;
                    assert!(
                        order[..i].iter().all(below),
                        "n {n} axis {axis} pivot {pivot}"
                    );
                    assert!(
                        !order[i..].iter().any(below),
                        "n {n} axis {axis} pivot {pivot}"
                    );
                    let mut sorted = order.clone();
                    sorted.sort_unstable();
                    assert!(sorted.iter().copied().eq(0..n as u32), "a permutation");
                }
            }
        }
    }

    #[test]
    fn bounds_and_area_equal_a_plain_fold() {
        for (n, seed) in [(0usize, 7u64), (1, 8), (2, 9), (3, 10), (101, 11)] {
            let boxes = random_boxes(n, seed);
            let prims = Prims::new(&boxes);
            // An order that is not the identity, with an odd and an even length.
            let order: Vec<u32> = (0..n as u32).rev().collect();
            let (b, sum) = prims.bounds_and_area(&order);
            let want = boxes.iter().fold(Aabb::EMPTY, |u, b| u.union(b));
            let want_sum: f64 = boxes.iter().map(|b| b.area() as f64).sum();
            if n == 0 {
                assert_eq!(sum, 0.0);
                assert!(b.min.x > b.max.x, "empty");
                continue;
            }
            assert_eq!(b.aabb(), want);
            assert!(
                (sum as f64 - want_sum).abs() <= 1e-5 * want_sum,
                "{sum} vs {want_sum}"
            );
        }
    }
}
