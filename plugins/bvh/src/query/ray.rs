//! Rays, hits and the watertight ray/triangle test (Woop, Benthin, Wald 2013).

use crate::Triangle;
use glam::{Affine3A, Vec3};

/// A ray `origin + t * dir` for `t` in `[t_min, t_max]`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Start point.
    pub origin: Vec3,
    /// Direction; need not be normalised, distances are in units of its length.
    pub dir: Vec3,
    /// Nearest accepted parameter.
    pub t_min: f32,
    /// Farthest accepted parameter.
    pub t_max: f32,
}

impl Ray {
    /// A ray over `[0, inf)`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// The same ray with a different range.
    pub fn with_range(mut self, t_min: f32, t_max: f32) -> Self {
        self.t_min = t_min;
        self.t_max = t_max;
        self
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// The ray in another space. Parameters `t` keep their meaning because the map is affine.
    pub fn transformed(&self, t: &Affine3A) -> Ray {
        Ray {
            origin: t.transform_point3(self.origin),
            dir: t.transform_vector3(self.dir),
            t_min: self.t_min,
            t_max: self.t_max,
        }
    }
}

/// The closest (or any) intersection found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Id of the triangle hit.
    pub triangle: u32,
    /// Ray parameter of the hit.
    pub t: f32,
    /// Barycentric weights of vertices 1 and 2 (vertex 0 has `1 - u - v`).
    pub u: f32,
    /// See `u`.
    pub v: f32,
    /// The instance the ray reached the triangle through ([`crate::NONE`] for a triangle stored in
    /// world space): it tells apart groups that share triangles ([`crate::Bvh::hit_group`]).
    pub instance: u32,
}

/// Precomputed per-ray data for the watertight test and the slab test.
#[derive(Clone, Copy, Debug)]
pub struct RayData {
    pub(crate) origin: Vec3,
    pub(crate) inv_dir: Vec3,
    // Watertight test: axis permutation and shear.
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl RayData {
    /// Precomputes what the tests need from `ray`.
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let ad = d.abs();
        let kz = if ad.x >= ad.y && ad.x >= ad.z {
            0
        } else if ad.y >= ad.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / d[kz];
        Self {
            origin: ray.origin,
            inv_dir: Vec3::ONE / d,
            kx,
            ky,
            kz,
            sx: d[kx] * sz,
            sy: d[ky] * sz,
            sz,
        }
    }

    /// Slab test: the entry parameter if the ray meets the box within `[t_min, t_max]`.
    #[inline]
    pub fn hit_box(&self, min: Vec3, max: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let t0 = (min - self.origin) * self.inv_dir;
        let t1 = (max - self.origin) * self.inv_dir;
        // A ray parallel to an axis and lying in one of the box's faces across it makes 0 * inf =
        // NaN there, beside an infinite bound: it lies within that slab, which then bounds
        // nothing (min and max alone would keep the infinity and miss the box).
        let on_face = t0.is_nan_mask() | t1.is_nan_mask();
        let tn = Vec3::select(on_face, Vec3::NEG_INFINITY, t0.min(t1));
        let tf = Vec3::select(on_face, Vec3::INFINITY, t0.max(t1));
        let enter = tn.x.max(tn.y).max(tn.z).max(t_min);
        let exit = tf.x.min(tf.y).min(tf.z).min(t_max);
        (enter <= exit * 1.000_000_4).then_some(enter)
    }

    /// Watertight ray/triangle test: rays through shared edges or vertices hit exactly one side.
    #[inline]
    pub fn hit_triangle(&self, tri: &Triangle, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let a = tri.v[0] - self.origin;
        let b = tri.v[1] - self.origin;
        let c = tri.v[2] - self.origin;
        let ax = a[self.kx] - self.sx * a[self.kz];
        let ay = a[self.ky] - self.sy * a[self.kz];
        let bx = b[self.kx] - self.sx * b[self.kz];
        let by = b[self.ky] - self.sy * b[self.kz];
        let cx = c[self.kx] - self.sx * c[self.kz];
        let cy = c[self.ky] - self.sy * c[self.kz];
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Fall back to double precision on edges so that the edge test is exact.
            let (ax, ay, bx, by, cx, cy) = (
                ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
            );
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[self.kz];
        let bz = self.sz * b[self.kz];
        let cz = self.sz * c[self.kz];
        let t_scaled = u * az + v * bz + w * cz;
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !(t >= t_min && t <= t_max) {
            return None;
        }
        // u weights vertex 0, v vertex 1, w vertex 2.
        Some((t, v * inv, w * inv))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_inside_misses_outside() {
        let tri = Triangle::new(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        let r = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let (t, u, v) = RayData::new(&r)
            .hit_triangle(&tri, 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (u - 0.25).abs() < 1e-6 && (v - 0.25).abs() < 1e-6);
        let r = Ray::new(Vec3::new(0.75, 0.75, 1.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(
            RayData::new(&r)
                .hit_triangle(&tri, 0.0, f32::INFINITY)
                .is_none()
        );
    }

    #[test]
    fn a_ray_in_a_box_face_plane_meets_the_box() {
        // Along +z at y = 2 exactly: in the plane of a box's minimum y, then of its maximum.
        let r = RayData::new(&Ray::new(Vec3::new(8.25, 2.0, -1.0), Vec3::Z));
        let (lo, hi) = (Vec3::new(8.0, 2.0, 0.6), Vec3::new(9.0, 3.0, 0.6));
        assert_eq!(r.hit_box(lo, hi, 0.0, f32::INFINITY), Some(1.6));
        let (lo, hi) = (Vec3::new(8.0, 1.0, 0.6), Vec3::new(9.0, 2.0, 0.6));
        assert_eq!(r.hit_box(lo, hi, 0.0, f32::INFINITY), Some(1.6));
        // Beside a box, parallel to it, above and below: missed.
        let (lo, hi) = (Vec3::new(8.0, 2.5, 0.6), Vec3::new(9.0, 3.0, 0.6));
        assert_eq!(r.hit_box(lo, hi, 0.0, f32::INFINITY), None);
        let (lo, hi) = (Vec3::new(8.0, 1.0, 0.6), Vec3::new(9.0, 1.5, 0.6));
        assert_eq!(r.hit_box(lo, hi, 0.0, f32::INFINITY), None);
        // The same along -z, whose zero components are -0.0 (infinite reciprocals of both signs).
        let r = RayData::new(&Ray::new(
            Vec3::new(8.25, 2.0, 3.0),
            Vec3::new(-0.0, -0.0, -1.0),
        ));
        let (lo, hi) = (Vec3::new(8.0, 1.0, 0.6), Vec3::new(9.0, 2.0, 0.6));
        assert_eq!(r.hit_box(lo, hi, 0.0, f32::INFINITY), Some(2.4));
        // The triangle on that face's edge is hit through a tree as by brute force.
        let tri = Triangle::new(
            Vec3::new(8.0, 2.0, 0.6),
            Vec3::new(9.0, 2.0, 0.6),
            Vec3::new(8.0, 3.0, 0.6),
        );
        let far = Triangle::new(
            Vec3::splat(50.0),
            Vec3::new(51.0, 50.0, 50.0),
            Vec3::splat(51.0),
        );
        let mut bvh = crate::Bvh::new(crate::BvhConfig::default());
        bvh.insert_triangles(&[tri, far]).unwrap();
        let ray = Ray::new(Vec3::new(8.25, 2.0, -1.0), Vec3::Z);
        let brute = bvh.brute_force_closest_hit(&ray);
        assert!(brute.is_some());
        assert_eq!(bvh.closest_hit(&ray), brute);
    }

    #[test]
    fn shared_edge_is_hit_by_exactly_one_side() {
        // Two triangles sharing the diagonal of a unit square; rays along the diagonal.
        let t1 = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0));
        let t2 = Triangle::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        for i in 1..100 {
            let s = i as f32 / 100.0;
            let r = Ray::new(Vec3::new(s, s, 1.0), Vec3::new(0.0, 0.0, -1.0));
            let d = RayData::new(&r);
            let hits = d.hit_triangle(&t1, 0.0, 10.0).is_some() as u32
                + d.hit_triangle(&t2, 0.0, 10.0).is_some() as u32;
            assert!(hits >= 1, "ray through the shared edge leaked at {s}");
        }
    }
}
