//! A mesh too big to wait for, cut into spatial chunks that enter the tree one at a time, nearest the
//! camera first, each a group of the same entity: the preview fills in from the front instead of
//! waiting for the whole mesh's build.

use crate::TriangleShading;
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{Aabb, Triangle};

/// One piece of a mesh: object-space triangles and their shading, in the same order.
pub(crate) struct Chunk {
    pub triangles: Vec<Triangle>,
    pub shading: TriangleShading,
}

/// Cuts a mesh into chunks of at most `max` triangles (median splits of the triangles' centroids
/// along the widest axis, so chunks are compact and about equal) and orders them by the distance
/// from `eye` to their world-space boxes under `transform`, nearest first; without an eye they keep
/// the order of the splits.
pub(crate) fn spatial_chunks(
    triangles: &[Triangle],
    shading: &TriangleShading,
    max: usize,
    transform: &Affine3A,
    eye: Option<Vec3>,
) -> Vec<Chunk> {
    let max = max.max(1);
    let whole = triangles.len();
    let centroids: Vec<Vec3> = triangles
        .iter()
        .map(|t| (t.v[0] + t.v[1] + t.v[2]) / 3.0)
        .collect();
    let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
    let mut ranges: Vec<(usize, usize)> = Vec::new();
    // An explicit stack rather than recursion: the depth is log2(n / max), but no stack is cheaper.
    let mut todo = vec![(0usize, order.len())];
    while let Some((start, end)) = todo.pop() {
        if end - start <= max {
            ranges.push((start, end));
            continue;
        }
        let part = &mut order[start..end];
        let (lo, hi) = part.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &t| {
                let c = centroids[t as usize];
                (lo.min(c), hi.max(c))
            },
        );
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = part.len() / 2;
        part.select_nth_unstable_by(mid, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
        todo.push((start + mid, end));
        todo.push((start, start + mid));
    }
    let mut chunks: Vec<(f32, Chunk)> = ranges
        .into_iter()
        .map(|(start, end)| {
            let ids = &order[start..end];
            let triangles: Vec<Triangle> = ids.iter().map(|&t| triangles[t as usize]).collect();
            let shading = TriangleShading {
                normals: gather(&shading.normals, ids, whole),
                uvs: gather(&shading.uvs, ids, whole),
            };
            let bounds = triangles
                .iter()
                .fold(Aabb::EMPTY, |b, t| b.union(&t.aabb()))
                .transformed(transform);
            let distance = eye.map_or(0.0, |eye| {
                eye.distance_squared(eye.clamp(bounds.min, bounds.max))
            });
            (distance, Chunk { triangles, shading })
        })
        .collect();
    // Stable: equal distances (and no eye) keep the split order.
    chunks.sort_by(|a, b| a.0.total_cmp(&b.0));
    chunks.into_iter().map(|(_, c)| c).collect()
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

    #[test]
    fn chunks_hold_every_triangle_once_with_its_shading_nearest_first() {
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
        let chunks = spatial_chunks(&triangles, &shading, 64, &transform, Some(eye));
        assert!(chunks.len() >= 900 / 64);
        let mut seen = vec![false; 900];
        let mut last = 0.0f32;
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
            let b = c
                .triangles
                .iter()
                .fold(Aabb::EMPTY, |b, t| b.union(&t.aabb()))
                .transformed(&transform);
            let d = eye.distance(eye.clamp(b.min, b.max));
            assert!(d >= last - 1e-4, "a chunk {d} away after one {last} away");
            last = d;
        }
        assert!(seen.into_iter().all(|s| s));
        // Shading that does not match the triangles is left out, not misread.
        let short = TriangleShading {
            normals: vec![[Vec3::ZERO; 3]; 10],
            uvs: Vec::new(),
        };
        for c in spatial_chunks(&triangles, &short, 64, &transform, None) {
            assert!(c.shading.normals.is_empty() && c.shading.uvs.is_empty());
        }
    }
}
