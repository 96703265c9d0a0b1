//! A mesh too big to wait for, cut into spatial chunks that enter the tree one at a time, nearest the
//! camera first, each a group of the same entity: the preview fills in from the front instead of
//! waiting for the whole mesh's build.

use crate::types::mesh::MeshPositions;
use crate::types::shading::MeshShading;
use std::sync::Arc;
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{BvhError, MeshPieces, PieceRule, PreparedGroup};

/// A mesh cut by the engine's rule ([`MeshPieces::cut_indexed`]: pieces nearest `eye` first under
/// the transform), kept as its positions and corners. Each chunk's triangles are gathered when it
/// is built, so no soup of the whole mesh (three corners a triangle) is made.
pub(crate) struct MeshChunks {
    pieces: MeshPieces,
    positions: MeshPositions,
    shading: Arc<MeshShading>,
}

impl MeshChunks {
    /// The cut; corners past the positions are refused, naming the first triangle with one.
    pub fn cut(
        positions: MeshPositions,
        shading: Arc<MeshShading>,
        rule: PieceRule,
        transform: &Affine3A,
        eye: Option<Vec3>,
    ) -> Result<Self, BvhError> {
        let pieces = MeshPieces::cut_indexed(
            &positions.vertices,
            &positions.corners,
            rule,
            transform,
            eye,
        )?;
        Ok(Self {
            pieces,
            positions,
            shading,
        })
    }

    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    /// Chunk `k`'s group under `transform`, built off the tree's thread ([`MeshPieces::build`]: a
    /// mesh in pieces is kept whole, an instance over its own subtree, so a first move or copy of it
    /// is one node per chunk).
    pub fn build(&self, k: usize, transform: Affine3A) -> Result<PreparedGroup, BvhError> {
        let MeshPositions { vertices, corners } = &self.positions;
        self.pieces.build_indexed(k, vertices, corners, transform)
    }

    /// Chunk `k`'s triangles' shading, in the order of its triangles, sharing the mesh's vertex
    /// arrays. Shading that does not cover the mesh's triangles is left out, not misread.
    pub fn shading(&self, k: usize) -> MeshShading {
        let ids = self.pieces.ids().nth(k).unwrap_or_default();
        if self.shading.len() != self.positions.len() {
            return MeshShading::default();
        }
        self.shading.subset(ids)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::shading::ShadingVertices;
    use treelight_bvh::glam::Vec2;

    const RULE: PieceRule = PieceRule {
        cut_above: 64,
        piece: 64,
    };

    #[test]
    fn chunks_hold_every_triangle_once_with_its_shading() {
        // A 30 × 30 grid of triangles, each with vertices (three of its own) that name it.
        let mut positions = MeshPositions::default();
        let mut vertices = ShadingVertices::default();
        let mut corners = Vec::new();
        for k in 0..900u32 {
            let p = Vec3::new((k % 30) as f32, 0.0, (k / 30) as f32);
            let at = positions.vertices.len() as u32;
            positions.vertices.extend([p, p + Vec3::X, p + Vec3::Z]);
            positions.corners.push([at, at + 1, at + 2]);
            // Corners in reverse, so that the chunks' must be gathered, not counted.
            let first = 3 * (899 - k);
            corners.push([first, first + 1, first + 2]);
        }
        for v in 0..2700u32 {
            let k = 899 - v / 3;
            vertices.normals.push(k);
            vertices.uvs.push(Vec2::splat(k as f32));
            vertices.tangents.push(k);
        }
        let shading = MeshShading::new(vertices, &corners);
        let transform = Affine3A::from_translation(Vec3::new(100.0, 0.0, 0.0));
        let eye = Vec3::new(100.0, 5.0, -10.0);
        let chunks =
            MeshChunks::cut(positions, Arc::new(shading), RULE, &transform, Some(eye)).unwrap();
        assert!(chunks.len() >= 900 / 64);
        let mut seen = vec![false; 900];
        for k in 0..chunks.len() {
            let group = chunks.build(k, transform).unwrap();
            let shading = chunks.shading(k);
            assert!(!group.is_empty() && group.len() <= 64);
            assert_eq!(shading.len(), group.len());
            for j in 0..shading.len() {
                let n = shading.normals(j).unwrap();
                let t = n[0] as usize;
                assert_eq!(n, [t as u32; 3]);
                let uv = shading.uvs(j).unwrap();
                assert_eq!(uv[0].x as usize, t, "normals and UVs of one triangle");
                let tangent = shading.vertex_tangents(j).unwrap();
                assert_eq!(
                    tangent[0] as usize, t,
                    "normals and tangents of one triangle"
                );
                assert!(!seen[t], "triangle {t} in two chunks");
                seen[t] = true;
            }
        }
        assert!(seen.into_iter().all(|s| s));
        // Shading that does not match the triangles is left out, not misread.
        let short = MeshShading::new(
            ShadingVertices {
                normals: vec![0; 3],
                ..Default::default()
            },
            &[[0, 1, 2]; 10],
        );
        let mut positions = chunks.positions.clone();
        let chunks =
            MeshChunks::cut(positions.clone(), Arc::new(short), RULE, &transform, None).unwrap();
        for k in 0..chunks.len() {
            let shading = chunks.shading(k);
            assert!(shading.is_empty() && shading.normals(0).is_none());
        }
        // A corner past the positions: the mesh is refused whole, its triangle named.
        positions.corners[700][1] = 2700;
        let refused = MeshChunks::cut(positions, chunks.shading, RULE, &transform, None);
        assert!(matches!(
            refused.err(),
            Some(BvhError::CornerOutOfRange {
                index: 700,
                vertices: 2700
            })
        ));
    }
}
