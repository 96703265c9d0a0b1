//! A group's triangles as shared vertices and corners: a mesh's triangles meet at its vertices, so
//! each position is kept once and each triangle is three indices (12 bytes against 36 for three
//! corners of its own; a mesh of tiles has half a vertex a triangle).

use crate::tree::corners::Corners;
use crate::tree::triangle::{point_within_limits, within_limits};
use crate::{BvhError, MAX_COORDINATE, Triangle, TriangleIds};
use glam::Vec3;
use std::collections::HashMap;

/// Triangles as shared vertices and the corners that index them.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Indexed {
    /// Each distinct position once.
    pub(crate) vertices: Vec<Vec3>,
    /// Each triangle's corners, indices into `vertices`.
    pub(crate) corners: Vec<[u32; 3]>,
}

/// Positions kept once each (the same to the bit: `-0.0` and `0.0` stay apart), in the order
/// first met: the one map both ways into an [`Indexed`] go through.
struct DistinctPositions {
    seen: HashMap<[u32; 3], u32, foldhash::fast::FixedState>,
    vertices: Vec<Vec3>,
}

impl DistinctPositions {
    fn with_capacity(n: usize) -> Self {
        Self {
            seen: HashMap::with_capacity_and_hasher(n, Default::default()),
            vertices: Vec::with_capacity(n),
        }
    }

    /// The index of `p` among the positions kept, kept now if it is new.
    #[inline]
    fn index(&mut self, p: Vec3) -> u32 {
        let vertices = &mut self.vertices;
        *self
            .seen
            .entry(p.to_array().map(f32::to_bits))
            .or_insert_with(|| {
                vertices.push(p);
                vertices.len() as u32 - 1
            })
    }

    fn into_vertices(self) -> Vec<Vec3> {
        let mut vertices = self.vertices;
        vertices.shrink_to_fit();
        vertices
    }
}

impl Indexed {
    /// A soup of triangles indexed: each position that is the same to the bit (so `-0.0` and `0.0`
    /// stay apart) becomes one vertex, in the order first met, and every triangle reads back exactly
    /// as given.
    pub(crate) fn from_soup(tris: &[Triangle]) -> Self {
        // A mesh has about half a vertex a triangle; the map is sized for that and grows if not.
        let mut positions = DistinctPositions::with_capacity(tris.len() / 2 + 4);
        let corners = tris
            .iter()
            .map(|t| t.v.map(|p| positions.index(p)))
            .collect();
        Self {
            vertices: positions.into_vertices(),
            corners,
        }
    }

    /// A mesh's own vertices and corners, with the vertices at the same position to the bit
    /// merged into one (a mesh splits a vertex where its normals or texture coordinates part;
    /// the tree needs only positions) and the corners renumbered to match: one lookup a vertex
    /// rather than a corner. Every triangle reads back exactly as given.
    pub(crate) fn merged(vertices: Vec<Vec3>, mut corners: Vec<[u32; 3]>) -> Self {
        let mut positions = DistinctPositions::with_capacity(vertices.len());
        let renumber: Vec<u32> = vertices.iter().map(|&p| positions.index(p)).collect();
        if positions.vertices.len() == vertices.len() {
            // Nothing merged: the mesh's vertices and corners as they are.
            return Self { vertices, corners };
        }
        drop(vertices);
        // A corner past the vertices is left past them, for the validation to name.
        for c in &mut corners {
            *c = c.map(|i| renumber.get(i as usize).copied().unwrap_or(u32::MAX));
        }
        Self {
            vertices: positions.into_vertices(),
            corners,
        }
    }

    /// Number of triangles.
    pub(crate) fn len(&self) -> usize {
        self.corners.len()
    }

    /// Triangle `k`, gathered from its corners.
    #[inline]
    pub(crate) fn triangle(&self, k: usize) -> Triangle {
        gather(&self.vertices, self.corners[k])
    }

    /// Rejects corners past the vertices, and triangles with a NaN, infinite or absurdly large
    /// coordinate (as [`crate::validate_triangles`] does for a soup), naming the first triangle at
    /// fault. A vertex no triangle uses is never at fault.
    pub(crate) fn validate(&self) -> Result<(), BvhError> {
        check_corners(&self.corners, self.vertices.len())?;
        let ok = self
            .vertices
            .iter()
            .fold(true, |ok, &p| ok & point_within_limits(p));
        if ok {
            return Ok(());
        }
        for k in 0..self.len() {
            let t = self.triangle(k);
            if within_limits(&t) {
                continue;
            }
            return Err(if t.is_finite() {
                BvhError::CoordinateTooLarge {
                    index: k,
                    limit: MAX_COORDINATE,
                }
            } else {
                BvhError::NonFiniteVertex { index: k }
            });
        }
        Ok(())
    }
}

/// Refuses corners at or past `vertices`, naming the first triangle with one.
pub(crate) fn check_corners(corners: &[[u32; 3]], vertices: usize) -> Result<(), BvhError> {
    match corners
        .iter()
        .position(|c| c.iter().any(|&i| i as usize >= vertices))
    {
        Some(index) => Err(BvhError::CornerOutOfRange { index, vertices }),
        None => Ok(()),
    }
}

/// The triangle of `corners` in `vertices`.
#[inline]
pub(crate) fn gather(vertices: &[Vec3], [a, b, c]: [u32; 3]) -> Triangle {
    Triangle::new(
        vertices[a as usize],
        vertices[b as usize],
        vertices[c as usize],
    )
}

/// Drops the vertices no corner of the triangles `ids` uses (their corners in `corners`, by id)
/// and renumbers those corners to match, in place; the kept vertices keep their order. `also`,
/// if given, is a copy in step with `vertices` (a baked group's object-space one), compacted
/// alike.
pub(crate) fn compact(
    vertices: &mut Vec<Vec3>,
    corners: &mut Corners,
    ids: &TriangleIds,
    also: Option<&mut Vec<Vec3>>,
) {
    let mut renumber = vec![u32::MAX; vertices.len()];
    for t in ids {
        for i in corners.get(t as usize) {
            renumber[i as usize] = 0;
        }
    }
    let mut kept = 0u32;
    let mut also = also.filter(|a| a.len() == vertices.len());
    for (i, slot) in renumber.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = kept;
            vertices[kept as usize] = vertices[i];
            if let Some(a) = also.as_deref_mut() {
                a[kept as usize] = a[i];
            }
            kept += 1;
        }
    }
    vertices.truncate(kept as usize);
    vertices.shrink_to_fit();
    if let Some(a) = also {
        a.truncate(kept as usize);
        a.shrink_to_fit();
    }
    for t in ids {
        let c = corners.get(t as usize);
        corners.set(t as usize, c.map(|i| renumber[i as usize]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Vec<Triangle> {
        let v = |x: f32, y: f32| Vec3::new(x, y, 0.0);
        vec![
            Triangle::new(v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0)),
            Triangle::new(v(0.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)),
        ]
    }

    #[test]
    fn a_soup_shares_its_corners_and_reads_back_exactly() {
        let mut tris = quad();
        // Zero's two signs are two positions: read back, each keeps its own.
        tris.push(Triangle::new(
            Vec3::new(-0.0, 0.0, 0.0),
            Vec3::X,
            Vec3::new(0.0, 0.0, 1.0),
        ));
        let indexed = Indexed::from_soup(&tris);
        assert_eq!(indexed.vertices.len(), 6);
        assert_eq!(indexed.corners[0], [0, 1, 2]);
        assert_eq!(indexed.corners[1], [0, 2, 3]);
        for (k, t) in tris.iter().enumerate() {
            let back = indexed.triangle(k);
            let bits = |t: &Triangle| t.v.map(|p| p.to_array().map(f32::to_bits));
            assert_eq!(bits(&back), bits(t));
        }
        assert_eq!(indexed.validate(), Ok(()));
    }

    #[test]
    fn a_meshs_split_vertices_are_merged_and_read_back_exactly() {
        // A quad whose shared edge is split (as a mesh does where its UVs part), and one vertex
        // no triangle uses.
        let v = |x: f32, y: f32| Vec3::new(x, y, 0.0);
        let vertices = vec![
            v(0.0, 0.0),
            v(1.0, 0.0),
            v(1.0, 1.0),
            v(0.0, 0.0),
            v(1.0, 1.0),
            v(0.0, 1.0),
            v(5.0, 5.0),
        ];
        let corners = vec![[0, 1, 2], [3, 4, 5]];
        let before: Vec<Triangle> = corners.iter().map(|&c| gather(&vertices, c)).collect();
        let merged = Indexed::merged(vertices, corners);
        assert_eq!(merged.vertices.len(), 5);
        assert_eq!(merged.corners, vec![[0, 1, 2], [0, 2, 3]]);
        let after: Vec<Triangle> = (0..2).map(|k| merged.triangle(k)).collect();
        assert_eq!(before, after);
        // A corner past the vertices stays past them, for the validation to name.
        let bad = Indexed::merged(vec![v(0.0, 0.0), v(0.0, 0.0), v(1.0, 0.0)], vec![[0, 2, 7]]);
        assert!(matches!(
            bad.validate(),
            Err(BvhError::CornerOutOfRange { index: 0, .. })
        ));
    }

    #[test]
    fn bad_corners_and_bad_coordinates_name_the_triangle() {
        let mut indexed = Indexed::from_soup(&quad());
        indexed.corners[1][2] = 9;
        assert_eq!(
            indexed.validate(),
            Err(BvhError::CornerOutOfRange {
                index: 1,
                vertices: 4
            })
        );
        let mut indexed = Indexed::from_soup(&quad());
        indexed.vertices[3].y = f32::NAN;
        assert_eq!(
            indexed.validate(),
            Err(BvhError::NonFiniteVertex { index: 1 })
        );
        indexed.vertices[3].y = 1e30;
        assert!(matches!(
            indexed.validate(),
            Err(BvhError::CoordinateTooLarge { index: 1, .. })
        ));
        // A vertex no triangle uses is not the triangles' fault.
        let mut indexed = Indexed::from_soup(&quad());
        indexed.vertices.push(Vec3::splat(f32::INFINITY));
        assert_eq!(indexed.validate(), Ok(()));
    }

    #[test]
    fn compaction_keeps_what_the_corners_read() {
        let tris = quad();
        let mut indexed = Indexed::from_soup(&tris);
        // Triangle 0 moved to three vertices of its own, as a triangle edited alone is.
        indexed.vertices.extend([Vec3::Z, Vec3::Y, Vec3::ONE]);
        indexed.corners[0] = [4, 5, 6];
        let mut copy: Vec<Vec3> = indexed.vertices.iter().map(|p| *p * 2.0).collect();
        let before: Vec<Triangle> = (0..2).map(|k| indexed.triangle(k)).collect();
        let mut corners = Corners::default();
        for (k, &c) in indexed.corners.iter().enumerate() {
            corners.set(k, c);
        }
        compact(
            &mut indexed.vertices,
            &mut corners,
            &TriangleIds::new(vec![0, 1]),
            Some(&mut copy),
        );
        // Vertex 1 (used by the old triangle 0 alone) is gone, from the copy too.
        assert_eq!(indexed.vertices.len(), 6);
        let after: Vec<Triangle> = (0..2)
            .map(|k| gather(&indexed.vertices, corners.get(k)))
            .collect();
        assert_eq!(before, after);
        let doubled: Vec<Vec3> = indexed.vertices.iter().map(|p| *p * 2.0).collect();
        assert_eq!(copy, doubled);
    }
}
