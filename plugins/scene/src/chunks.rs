//! A mesh too big to wait for, cut into spatial chunks that enter the tree one at a time, nearest the
//! camera first, each a group of the same entity: the preview fills in from the front instead of
//! waiting for the whole mesh's build.

use crate::TriangleShading;
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{MeshPieces, PieceRule, Triangle};

/// One piece of a mesh: object-space triangles and their shading, in the same order.
pub(crate) struct Chunk {
    pub triangles: Vec<Triangle>,
    pub shading: TriangleShading,
}

/// Cuts a mesh by the engine's rule ([`MeshPieces::cut`]: pieces nearest `eye` first under
/// `transform`), each with its triangles' shading.
pub(crate) fn spatial_chunks(
    triangles: &[Triangle],
    shading: &TriangleShading,
    rule: PieceRule,
    transform: &Affine3A,
    eye: Option<Vec3>,
) -> Vec<Chunk> {
    let whole = triangles.len();
    MeshPieces::cut(triangles, rule, transform, eye)
        .ids()
        .map(|ids| Chunk {
            triangles: ids.iter().map(|&t| triangles[t as usize]).collect(),
            shading: TriangleShading {
                normals: gather(&shading.normals, ids, whole),
                uvs: gather(&shading.uvs, ids, whole),
            },
        })
        .collect()
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
            shading.normals.push([Vec3::splat(k as f32); 3]);
            shading.uvs.push([Vec2::splat(k as f32); 3]);
        }
        let transform = Affine3A::from_translation(Vec3::new(100.0, 0.0, 0.0));
        let eye = Vec3::new(100.0, 5.0, -10.0);
        let chunks = spatial_chunks(&triangles, &shading, RULE, &transform, Some(eye));
        assert!(chunks.len() >= 900 / 64);
        let mut seen = vec![false; 900];
        for c in &chunks {
            assert!(!c.triangles.is_empty() && c.triangles.len() <= 64);
            assert_eq!(c.shading.normals.len(), c.triangles.len());
            assert_eq!(c.shading.uvs.len(), c.triangles.len());
            for (t, n) in c.triangles.iter().zip(&c.shading.normals) {
                let k = n[0].x as usize;
                assert_eq!(*t, triangles[k], "shading follows its triangle");
                assert!(!seen[k], "triangle {k} in two chunks");
                seen[k] = true;
            }
        }
        assert!(seen.into_iter().all(|s| s));
        // Shading that does not match the triangles is left out, not misread.
        let short = TriangleShading {
            normals: vec![[Vec3::ZERO; 3]; 10],
            uvs: Vec::new(),
        };
        for c in spatial_chunks(&triangles, &short, RULE, &transform, None) {
            assert!(c.shading.normals.is_empty() && c.shading.uvs.is_empty());
        }
    }
}
