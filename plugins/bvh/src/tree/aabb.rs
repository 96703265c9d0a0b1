//! Axis-aligned bounding boxes and their surface area, the currency of the SAH cost model.

use glam::{Affine3A, Vec3, Vec3A};

/// An axis-aligned box. The empty box has `min = +inf`, `max = -inf`, so that union with it is the identity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The box containing nothing.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// A box from its two corners.
    #[inline]
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The smallest box containing all `points`.
    #[inline]
    pub fn from_points(points: &[Vec3]) -> Self {
        let mut b = Self::EMPTY;
        for &p in points {
            b.grow(p);
        }
        b
    }

    /// Whether the box contains nothing.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Extends the box to contain `p`.
    #[inline]
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box containing both.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Surface area; zero for the empty box.
    #[inline]
    pub fn area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        extent_area(d.x, d.y, d.z)
    }

    /// [`Aabb::area`] of a box that lies in memory (a node array), read in vector lanes: for
    /// loops over stored boxes. A box just computed in registers is better measured by
    /// [`Aabb::area`], which does not make it go through memory.
    #[inline]
    pub(crate) fn stored_area(&self) -> f32 {
        let b = LaneBox::new(self);
        LaneBox::area_of(b.max - b.min)
    }

    /// Surface area of the union, without building it (the search's innermost operation).
    #[inline]
    pub fn union_area(&self, o: &Aabb) -> f32 {
        let d = (self.max.max(o.max) - self.min.min(o.min)).max(Vec3::ZERO);
        extent_area(d.x, d.y, d.z)
    }

    /// Centre point.
    #[inline]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Extent along each axis.
    #[inline]
    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    /// Axis (0, 1, 2) of the largest extent.
    #[inline]
    pub fn largest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// Whether `o` lies inside this box, allowing `eps` of slack relative to the box size.
    pub fn contains_box(&self, o: &Aabb, eps: f32) -> bool {
        if o.is_empty() {
            return true;
        }
        let slack = eps
            * (1.0
                + self
                    .extent()
                    .max_element()
                    .max(self.min.abs().max_element())
                    .max(self.max.abs().max_element()));
        (o.min - self.min).min_element() >= -slack && (self.max - o.max).min_element() >= -slack
    }

    /// Whether the two boxes share any point.
    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.x <= o.max.x
            && self.max.x >= o.min.x
            && self.min.y <= o.max.y
            && self.max.y >= o.min.y
            && self.min.z <= o.max.z
            && self.max.z >= o.min.z
    }

    /// Whether every coordinate is a finite number.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// The box around this box's eight corners after `t`.
    pub fn transformed(&self, t: &Affine3A) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        // Arvo's method: each output axis is a sum of per-axis min/max contributions.
        let m = t.matrix3;
        let mut min = Vec3::from(t.translation);
        let mut max = min;
        for (i, col) in [m.x_axis, m.y_axis, m.z_axis].into_iter().enumerate() {
            let a = Vec3::from(col) * self.min[i];
            let b = Vec3::from(col) * self.max[i];
            min += a.min(b);
            max += a.max(b);
        }
        Aabb { min, max }
    }
}

/// Surface area of a box with non-negative extents `x`, `y`, `z`. Every scalar area in the engine
/// goes through this one sum, in this order, because the lane forms ([`LaneBox`]) reproduce it bit
/// for bit and the trees must not depend on which form measured a box.
#[inline(always)]
pub(crate) fn extent_area(x: f32, y: f32, z: f32) -> f32 {
    2.0 * (x * y + y * z + z * x)
}

/// A box in vector lanes: the search's query, measured against many stored boxes, and the form
/// in which stored boxes are measured ([`Aabb::stored_area`]). Its areas are
/// bit-for-bit those of [`Aabb::area`] and [`Aabb::union_area`] (the same products, summed in the
/// same order), so the trees it builds do not depend on which form measured them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneBox {
    min: Vec3A,
    max: Vec3A,
}

impl LaneBox {
    /// `b` in lanes.
    #[inline]
    pub(crate) fn new(b: &Aabb) -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_loadu_ps, _mm_shuffle_ps};
            let p = (b as *const Aabb).cast::<f32>();
            // SAFETY: an `Aabb` is six contiguous f32s (two `Vec3`s of three), so both 16-byte
            // loads, of floats 0-3 and 2-5, stay inside it; SSE is part of x86-64.
            unsafe {
                let lo = _mm_loadu_ps(p);
                let hi = _mm_loadu_ps(p.add(2));
                // Lane 3 of each is another coordinate: nothing below reads it.
                Self {
                    min: Vec3A::from(lo),
                    max: Vec3A::from(_mm_shuffle_ps::<0b11_11_10_01>(hi, hi)),
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Self {
            min: Vec3A::from(b.min),
            max: Vec3A::from(b.max),
        }
    }

    /// Surface area of a box of extent `d` (negative extents count as zero), from lanes 0-2.
    #[inline]
    fn area_of(d: Vec3A) -> f32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{
                __m128, _mm_add_ss, _mm_cvtss_f32, _mm_max_ps, _mm_mul_ps, _mm_setzero_ps,
                _mm_shuffle_ps,
            };
            // SAFETY: SSE is part of x86-64.
            unsafe {
                let d = _mm_max_ps(__m128::from(d), _mm_setzero_ps());
                // (x·y, y·z, z·x), then summed left to right as `Aabb::area` sums them.
                let p = _mm_mul_ps(d, _mm_shuffle_ps::<0b11_00_10_01>(d, d));
                let s = _mm_add_ss(p, _mm_shuffle_ps::<0b11_11_11_01>(p, p));
                let s = _mm_add_ss(s, _mm_shuffle_ps::<0b11_11_11_10>(p, p));
                2.0 * _mm_cvtss_f32(s)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let d = d.max(Vec3A::ZERO);
            extent_area(d.x, d.y, d.z)
        }
    }

    /// Area of the union of this box and `b`, and area of `b`.
    #[inline]
    pub(crate) fn union_area_and_area(&self, b: &Aabb) -> (f32, f32) {
        let o = Self::new(b);
        let u = self.max.max(o.max) - self.min.min(o.min);
        let d = o.max - o.min;
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{
                __m128, _mm_add_ps, _mm_cvtss_f32, _mm_max_ps, _mm_movehl_ps, _mm_mul_ps,
                _mm_setzero_ps, _mm_shuffle_ps, _mm_unpackhi_ps, _mm_unpacklo_ps,
            };
            // Both products at once, then both sums in two lanes: (u, d) products interleaved
            // so that each lane adds its own three in `area_of`'s order.
            // SAFETY: SSE is part of x86-64.
            unsafe {
                let u = _mm_max_ps(__m128::from(u), _mm_setzero_ps());
                let d = _mm_max_ps(__m128::from(d), _mm_setzero_ps());
                let pu = _mm_mul_ps(u, _mm_shuffle_ps::<0b11_00_10_01>(u, u));
                let pd = _mm_mul_ps(d, _mm_shuffle_ps::<0b11_00_10_01>(d, d));
                let lo = _mm_unpacklo_ps(pu, pd);
                let hi = _mm_unpackhi_ps(pu, pd);
                let s = _mm_add_ps(_mm_add_ps(lo, _mm_movehl_ps(lo, lo)), hi);
                let s = _mm_add_ps(s, s);
                (
                    _mm_cvtss_f32(s),
                    _mm_cvtss_f32(_mm_shuffle_ps::<0b01_01_01_01>(s, s)),
                )
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        (Self::area_of(u), Self::area_of(d))
    }

    /// Area of the union of this box and `b`.
    #[inline]
    pub(crate) fn union_area(&self, b: &Aabb) -> f32 {
        let o = Self::new(b);
        Self::area_of(self.max.max(o.max) - self.min.min(o.min))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_and_union() {
        let a = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(a.area(), 6.0);
        let b = Aabb::new(Vec3::splat(1.0), Vec3::splat(2.0));
        assert_eq!(a.union(&b).area(), 24.0);
        assert_eq!(a.union_area(&b), 24.0);
        assert_eq!(Aabb::EMPTY.area(), 0.0);
        assert_eq!(Aabb::EMPTY.union(&a), a);
    }

    /// The vector forms must reproduce the scalar `area` and `union_area` bit for bit: trees must
    /// not depend on which form measured a box.
    #[test]
    fn vector_areas_equal_the_scalar_formula_bit_for_bit() {
        let mut rnd = crate::test_random(0x2545_f491_4f6c_dd1d);
        let mut boxes = vec![
            Aabb::EMPTY,
            Aabb::new(Vec3::ZERO, Vec3::ZERO),
            Aabb::new(Vec3::new(-1e30, 0.0, 5.0), Vec3::new(1e30, 1e-30, 5.0)),
        ];
        for k in 0..2000 {
            let scale = [1e-6f32, 1.0, 1e3, 1e12][k % 4];
            let c = Vec3::new(rnd(), rnd(), rnd()) * scale - scale * 0.5;
            let e = Vec3::new(rnd(), rnd(), rnd()) * scale * [0.0f32, 1e-3, 1.0][k % 3];
            boxes.push(Aabb::new(c, c + e));
        }
        for (i, a) in boxes.iter().enumerate() {
            assert_eq!(a.stored_area().to_bits(), a.area().to_bits());
            let b = &boxes[(i * 7919 + 13) % boxes.len()];
            let u = a.union_area(b);
            assert_eq!(LaneBox::new(a).union_area(b).to_bits(), u.to_bits());
            let (ua, ba) = LaneBox::new(a).union_area_and_area(b);
            assert_eq!(
                (ua.to_bits(), ba.to_bits()),
                (u.to_bits(), b.area().to_bits())
            );
        }
    }

    #[test]
    fn transformed_box_contains_transformed_corners() {
        let a = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 1.0, 5.0));
        let t = Affine3A::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.0),
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.7),
            Vec3::new(4.0, -2.0, 1.0),
        );
        let tb = a.transformed(&t);
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { a.min.x } else { a.max.x },
                if i & 2 == 0 { a.min.y } else { a.max.y },
                if i & 4 == 0 { a.min.z } else { a.max.z },
            );
            let p = t.transform_point3(c);
            assert!(tb.contains_box(&Aabb::new(p, p), 1e-5));
        }
    }
}
