//! Axis-aligned bounding boxes and their surface area, the currency of the SAH cost model.

use glam::{Affine3A, Vec3};

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
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// Surface area of the union, without building it (the search's innermost operation).
    #[inline]
    pub fn union_area(&self, o: &Aabb) -> f32 {
        let d = (self.max.max(o.max) - self.min.min(o.min)).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
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
