//! Triangles as the engine stores them: three vertices, world space unless owned by a transformed group.

use crate::{Aabb, BvhError};
use glam::{Affine3A, Vec3};

/// One triangle. Leaves hold exactly one.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Triangle {
    /// The three corners, counter-clockwise seen from the front.
    pub v: [Vec3; 3],
}

impl Triangle {
    /// A triangle from its corners.
    #[inline]
    pub fn new(a: Vec3, b: Vec3, c: Vec3) -> Self {
        Self { v: [a, b, c] }
    }

    /// Bounding box.
    #[inline]
    pub fn aabb(&self) -> Aabb {
        Aabb {
            min: self.v[0].min(self.v[1]).min(self.v[2]),
            max: self.v[0].max(self.v[1]).max(self.v[2]),
        }
    }

    /// Centroid of the bounding box, which the builders sort by.
    #[inline]
    pub fn center(&self) -> Vec3 {
        self.aabb().center()
    }

    /// Geometric normal (not normalised; zero for degenerate triangles).
    #[inline]
    pub fn normal(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }

    /// The triangle after the affine map `t`.
    #[inline]
    pub fn transformed(&self, t: &Affine3A) -> Triangle {
        Triangle {
            v: self.v.map(|p| t.transform_point3(p)),
        }
    }

    /// Whether all coordinates are finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.v.iter().all(|p| p.is_finite())
    }
}

/// Largest coordinate magnitude accepted. Beyond it the surface areas the SAH sums overflow f32.
pub const MAX_COORDINATE: f32 = 1.0e15;

/// Whether every coordinate of `t` is finite and within [`MAX_COORDINATE`], without a branch:
/// `|x| <= limit` is false for NaN and infinities too.
#[inline]
pub(crate) fn within_limits(t: &Triangle) -> bool {
    t.v.iter().fold(true, |ok, &p| ok & point_within_limits(p))
}

/// [`within_limits`] for one point.
#[inline]
pub(crate) fn point_within_limits(p: Vec3) -> bool {
    (p.x.abs() <= MAX_COORDINATE) & (p.y.abs() <= MAX_COORDINATE) & (p.z.abs() <= MAX_COORDINATE)
}

/// Rejects a whole batch if any triangle has a NaN, infinite or absurdly large coordinate,
/// so that a failed call inserts nothing.
pub fn validate_triangles(tris: &[Triangle]) -> Result<(), BvhError> {
    // Every insertion pays for this pass before it starts, so the common case is one
    // branch-free sweep. Only a batch that fails looks again, triangle by triangle, for the first
    // culprit and why.
    if tris.iter().fold(true, |ok, t| ok & within_limits(t)) {
        return Ok(());
    }
    for (index, t) in tris.iter().enumerate() {
        if !t.is_finite() {
            return Err(BvhError::NonFiniteVertex { index });
        }
        if t.v.iter().any(|p| p.abs().max_element() > MAX_COORDINATE) {
            return Err(BvhError::CoordinateTooLarge {
                index,
                limit: MAX_COORDINATE,
            });
        }
    }
    Ok(())
}
