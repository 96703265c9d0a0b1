//! A mesh too big to wait for, cut into spatial chunks that enter the tree one at a time, nearest the
//! camera first, each a group of the same entity: the preview fills in from the front instead of
//! waiting for the whole mesh's build.

use crate::TriangleShading;
use std::sync::Arc;
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{BvhError, MeshPieces, PieceRule, PreparedGroup, Triangle};

/// A mesh cut by the engine's rule ([`MeshPieces::cut`]: pieces nearest `eye` first under the
/// transform). Each chunk is gathered when it is built, so the mesh is not held twice.
pub(crate) struct MeshChunks {
    pieces: MeshPieces,
    triangles: Arc<Vec<Triangle>>,
    shading: Arc<TriangleShading>,
}

impl MeshChunks {
    pub fn cut(
        triangles: Arc<Vec<Triangle>>,
        shading: Arc<TriangleShading>,
        rule: PieceRule,
        transform: &Affine3A,
        eye: Option<Vec3>,
    ) -> Self {
        Self {
            pieces: MeshPieces::cut(&triangles, rule, transform, eye),
            triangles,
            shading,
        }
    }

    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    /// Chunk `k`'s group under `transform`, built off the tree's thread ([`MeshPieces::build`]: a
    /// mesh in pieces is kept whole, an instance over its own subtree, so a first move or copy of it
    /// is one node per chunk).
    pub fn build(&self, k: usize, transform: Affine3A) -> Result<PreparedGroup, BvhError> {
        self.pieces.build(k, &self.triangles, transform)
    }

    /// Chunk `k`'s triangles' shading, in the order of its triangles.
    pub fn shading(&self, k: usize) -> TriangleShading {
        let ids = self.pieces.ids().nth(k).unwrap_or_default();
        let whole = self.triangles.len();
        TriangleShading {
            normals: gather(&self.shading.normals, ids, whole),
            uvs: gather(&self.shading.uvs, ids, whole),
            uvs1: gather(&self.shading.uvs1, ids, whole),
            tangents: gather(&self.shading.tangents, ids, whole),
        }
    }
}

/// The entries of `ids` from a per-triangle array. Shading arrays hold one entry per triangle or
/// none (`GeometryCopy` leaves out what it cannot read); any other length is left out, not misread.
fn gather<T: Copy>(all: &[T], ids: &[u32], whole: usize) -> Vec<T> {
    if all.len() == whole {
        ids.iter().map(|&t| all[t as usize]).collect()
    } else {
        Vec::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use treelight_bvh::glam::Vec2;

    const RULE: PieceRule = PieceRule {
        cut_above: 64,
        piece: 64,
    };

    #[test]
    fn chunks_hold_every_triangle_once_with_its_shading() {
        // A 30 × 30 grid of triangles, each with shading that names it.
        let mut triangles = Vec::new();
        let mut shading = TriangleShading::default();
        for k in 0..900 {
            let p = Vec3::new((k % 30) as f32, 0.0, (k / 30) as f32);
            triangles.push(Triangle::new(p, p + Vec3::X, p + Vec3::Z));
            shading.normals.push([k; 3]);
            shading.uvs.push([Vec2::splat(k as f32); 3]);
            shading.tangents.push([k; 2]);
        }
        let transform = Affine3A::from_translation(Vec3::new(100.0, 0.0, 0.0));
        let eye = Vec3::new(100.0, 5.0, -10.0);
        let chunks = MeshChunks::cut(
            Arc::new(triangles),
            Arc::new(shading),
            RULE,
            &transform,
            Some(eye),
        );
        assert!(chunks.len() >= 900 / 64);
        let mut seen = vec![false; 900];
        for k in 0..chunks.len() {
            let group = chunks.build(k, transform).unwrap();
            let shading = chunks.shading(k);
            assert!(!group.is_empty() && group.len() <= 64);
            assert_eq!(shading.normals.len(), group.len());
            assert_eq!(shading.uvs.len(), group.len());
            assert_eq!(shading.tangents.len(), group.len());
            for ((n, uv), tangent) in shading
                .normals
                .iter()
                .zip(&shading.uvs)
                .zip(&shading.tangents)
            {
                let t = n[0] as usize;
                assert_eq!(uv[0].x as usize, t, "normals and UVs of one triangle");
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
        let short = TriangleShading {
            normals: vec![[0; 3]; 10],
            ..Default::default()
        };
        let triangles = chunks.triangles.clone();
        let chunks = MeshChunks::cut(triangles, Arc::new(short), RULE, &transform, None);
        for k in 0..chunks.len() {
            let shading = chunks.shading(k);
            assert!(shading.normals.is_empty() && shading.uvs.is_empty());
        }
    }
}
