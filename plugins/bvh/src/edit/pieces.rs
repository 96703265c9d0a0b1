//! How the tree the editor traces takes a mesh in, the one rule the scene plugin's worker and the
//! bench's `--editor` runs follow ([`PieceRule`]): a mesh of at most `cut_above` triangles is one
//! group, built and baked into the tree, where idle updates improve it; a bigger one is cut into
//! spatial pieces of at most `piece` triangles, nearest the eye first, each a group kept whole (an
//! instance over its own subtree, never baked), so the first piece is traced long before the whole
//! would be built, and a first move or copy is one node per piece.

use crate::tree::vertices::{check_corners, gather};
use crate::{Aabb, BvhError, PreparedGroup, TopDown, Triangle};
use glam::{Affine3A, Vec3};

/// Which meshes are cut into pieces, and how big the pieces are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PieceRule {
    /// A mesh of more triangles than this (and than `piece`) is cut. Default 262,144: a smaller
    /// mesh builds whole in about the time of a few pieces, and baked it gains the idle updates.
    pub cut_above: usize,
    /// Most triangles in one piece of a cut mesh. Default 65,536.
    pub piece: usize,
}

impl Default for PieceRule {
    fn default() -> Self {
        Self {
            cut_above: 1 << 18,
            piece: 1 << 16,
        }
    }
}

impl PieceRule {
    /// Whether a mesh of `triangles` triangles is cut.
    pub fn cuts(&self, triangles: usize) -> bool {
        triangles > self.cut_above.max(self.piece).max(1)
    }
}

/// A mesh's pieces: each a list of its triangles' indices, nearest the eye first.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshPieces {
    pieces: Vec<Vec<u32>>,
}

impl MeshPieces {
    /// A mesh's pieces under `rule`: if it cuts the mesh, pieces of at most `rule.piece` triangles
    /// (median splits of the triangles' centroids along the widest axis, so pieces are compact and
    /// about equal) ordered by the distance from `eye` to their world-space boxes under
    /// `transform`, nearest first (without an eye, in the order of the splits); else one piece.
    pub fn cut(
        triangles: &[Triangle],
        rule: PieceRule,
        transform: &Affine3A,
        eye: Option<Vec3>,
    ) -> Self {
        Self::cut_by(triangles.len(), |t| triangles[t], rule, transform, eye)
    }

    /// [`MeshPieces::cut`] for a mesh as its vertices and each triangle's corners, indices into
    /// them (no soup of the whole mesh is made: a cut mesh is the largest there is). Corners past
    /// the vertices are refused, naming the first triangle that has one.
    pub fn cut_indexed(
        vertices: &[Vec3],
        corners: &[[u32; 3]],
        rule: PieceRule,
        transform: &Affine3A,
        eye: Option<Vec3>,
    ) -> Result<Self, BvhError> {
        check_corners(corners, vertices.len())?;
        let triangle = |t: usize| gather(vertices, corners[t]);
        Ok(Self::cut_by(corners.len(), triangle, rule, transform, eye))
    }

    /// The cut of [`MeshPieces::cut`] over `len` triangles read by `triangle`.
    fn cut_by(
        len: usize,
        triangle: impl Fn(usize) -> Triangle,
        rule: PieceRule,
        transform: &Affine3A,
        eye: Option<Vec3>,
    ) -> Self {
        let max = rule.piece.max(1);
        let mut order: Vec<u32> = (0..len as u32).collect();
        if !rule.cuts(len) {
            return Self {
                pieces: vec![order],
            };
        }
        let centroids: Vec<Vec3> = (0..len)
            .map(|t| {
                let t = triangle(t);
                (t.v[0] + t.v[1] + t.v[2]) / 3.0
            })
            .collect();
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
        let mut pieces: Vec<(f32, Vec<u32>)> = ranges
            .into_iter()
            .map(|(start, end)| {
                let ids = order[start..end].to_vec();
                let bounds = ids
                    .iter()
                    .fold(Aabb::EMPTY, |b, &t| b.union(&triangle(t as usize).aabb()))
                    .transformed(transform);
                let distance = eye.map_or(0.0, |eye| {
                    eye.distance_squared(eye.clamp(bounds.min, bounds.max))
                });
                (distance, ids)
            })
            .collect();
        // Stable: equal distances (and no eye) keep the split order.
        pieces.sort_by(|a, b| a.0.total_cmp(&b.0));
        Self {
            pieces: pieces.into_iter().map(|(_, ids)| ids).collect(),
        }
    }

    /// Number of pieces.
    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    /// Whether there are no pieces (never: an empty mesh is one empty piece).
    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }

    /// Whether the pieces are kept whole as instances (a cut mesh) rather than baked.
    pub fn keep_whole(&self) -> bool {
        self.pieces.len() > 1
    }

    /// Each piece's triangle indices, nearest the eye first.
    pub fn ids(&self) -> impl Iterator<Item = &[u32]> {
        self.pieces.iter().map(Vec::as_slice)
    }

    /// Piece `k`'s group, built (off the tree's thread) from the mesh's `triangles` under
    /// `transform`, kept whole or to be baked as [`MeshPieces::keep_whole`] says.
    pub fn build(
        &self,
        k: usize,
        triangles: &[Triangle],
        transform: Affine3A,
    ) -> Result<PreparedGroup, BvhError> {
        let piece: Vec<Triangle> = self.pieces[k]
            .iter()
            .map(|&t| triangles[t as usize])
            .collect();
        PreparedGroup::build(&piece, transform, self.keep_whole())
    }

    /// [`MeshPieces::build`] for a mesh cut by [`MeshPieces::cut_indexed`], from the same
    /// vertices and corners: only the piece's triangles are gathered, and they read back exactly
    /// as those of the soup would.
    pub fn build_indexed(
        &self,
        k: usize,
        vertices: &[Vec3],
        corners: &[[u32; 3]],
        transform: Affine3A,
    ) -> Result<PreparedGroup, BvhError> {
        let n = vertices.len();
        let piece: Vec<Triangle> = self.pieces[k]
            .iter()
            .map(|&t| {
                let c = corners.get(t as usize).copied().unwrap_or([u32::MAX; 3]);
                if c.iter().all(|&i| (i as usize) < n) {
                    Ok(gather(vertices, c))
                } else {
                    Err(BvhError::CornerOutOfRange {
                        index: t as usize,
                        vertices: n,
                    })
                }
            })
            .collect::<Result<_, _>>()?;
        PreparedGroup::build(&piece, transform, self.keep_whole())
    }
}

/// The editor's idle refinement: a still, baked mesh's binned build replaced by a full-sweep SAH
/// build of the same triangles (about twice the build time, for a better tree), made off the tree's
/// thread once the edits pause, then swapped in with [`Bvh::swap_group`](crate::Bvh::swap_group).
pub struct Refinement;

impl Refinement {
    /// Groups of fewer triangles are left as built: binned SAH's 32 bins already find nearly every
    /// split a full sweep would, and each swap costs an upload and a round of global updates.
    pub const MIN_TRIANGLES: usize = 4096;

    /// Whether a baked group of `triangles` triangles is worth rebuilding.
    pub fn is_worth(triangles: usize) -> bool {
        triangles >= Self::MIN_TRIANGLES
    }

    /// The full-sweep build of a baked group from its world vertices, corners and transform
    /// ([`Bvh::group_world_indexed`](crate::Bvh::group_world_indexed),
    /// [`Bvh::group_transform`](crate::Bvh::group_transform)): the same triangles, so the same
    /// hits, and the same vertices, so the group keeps its object-space copy through the swap.
    pub fn build(
        vertices: Vec<Vec3>,
        corners: Vec<[u32; 3]>,
        transform: Affine3A,
    ) -> Result<PreparedGroup, BvhError> {
        PreparedGroup::build_world_indexed(vertices, corners, transform, TopDown::SweepSah)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_hold_every_triangle_once_nearest_first() {
        // A 30 × 30 grid of triangles.
        let triangles: Vec<Triangle> = (0..900)
            .map(|k| {
                let p = Vec3::new((k % 30) as f32, 0.0, (k / 30) as f32);
                Triangle::new(p, p + Vec3::X, p + Vec3::Z)
            })
            .collect();
        let transform = Affine3A::from_translation(Vec3::new(100.0, 0.0, 0.0));
        let eye = Vec3::new(100.0, 5.0, -10.0);
        let rule = PieceRule {
            cut_above: 300,
            piece: 64,
        };
        let pieces = MeshPieces::cut(&triangles, rule, &transform, Some(eye));
        assert!(pieces.len() >= 900 / 64 && pieces.keep_whole());
        let mut seen = [false; 900];
        let mut last = 0.0f32;
        for ids in pieces.ids() {
            assert!(!ids.is_empty() && ids.len() <= 64);
            for &t in ids {
                assert!(!seen[t as usize], "triangle {t} in two pieces");
                seen[t as usize] = true;
            }
            let b = ids
                .iter()
                .fold(Aabb::EMPTY, |b, &t| b.union(&triangles[t as usize].aabb()))
                .transformed(&transform);
            let d = eye.distance(eye.clamp(b.min, b.max));
            assert!(d >= last - 1e-4, "a piece {d} away after one {last} away");
            last = d;
        }
        assert!(seen.into_iter().all(|s| s));
        // Piece 0 builds kept whole, in object space under the transform.
        let g = pieces.build(0, &triangles, transform).unwrap();
        assert_eq!(g.len(), pieces.ids().next().unwrap().len());
        // Small enough: one piece, baked.
        let rule = PieceRule {
            cut_above: 900,
            ..rule
        };
        let one = MeshPieces::cut(&triangles, rule, &transform, Some(eye));
        assert_eq!(one.len(), 1);
        assert!(!one.keep_whole());
        assert_eq!(one.ids().next().unwrap().len(), 900);
    }

    #[test]
    fn an_indexed_mesh_is_cut_and_built_as_its_soup() {
        // A 40 × 40 grid of quads over shared vertices, with the soup it stands for.
        let n = 40u32;
        let vertices: Vec<Vec3> = (0..(n + 1) * (n + 1))
            .map(|i| {
                Vec3::new(
                    (i % (n + 1)) as f32,
                    ((i * 7) % 5) as f32 * 0.1,
                    (i / (n + 1)) as f32,
                )
            })
            .collect();
        let at = |i: u32, j: u32| j * (n + 1) + i;
        let corners: Vec<[u32; 3]> = (0..n * n)
            .flat_map(|k| {
                let (i, j) = (k % n, k / n);
                [
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                    [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                ]
            })
            .collect();
        let soup: Vec<Triangle> = corners.iter().map(|&c| gather(&vertices, c)).collect();
        let transform = Affine3A::from_translation(Vec3::new(3.0, 0.0, -2.0));
        let eye = Some(Vec3::new(0.0, 4.0, -9.0));
        let rule = PieceRule {
            cut_above: 500,
            piece: 256,
        };
        let from_soup = MeshPieces::cut(&soup, rule, &transform, eye);
        let indexed = MeshPieces::cut_indexed(&vertices, &corners, rule, &transform, eye).unwrap();
        assert_eq!(indexed, from_soup);
        assert!(indexed.len() > 1);
        for k in 0..indexed.len() {
            let mut a = crate::Bvh::default();
            let mut b = crate::Bvh::default();
            let ga = a
                .insert_prepared(from_soup.build(k, &soup, transform).unwrap())
                .unwrap();
            let gb = b
                .insert_prepared(
                    indexed
                        .build_indexed(k, &vertices, &corners, transform)
                        .unwrap(),
                )
                .unwrap();
            assert_eq!(a.group_object(ga).unwrap(), b.group_object(gb).unwrap());
            assert_eq!(a.bounds(), b.bounds());
        }
        // A corner past the vertices is refused, naming its triangle, by the cut and the build.
        let mut bad = corners.clone();
        bad[1234][2] = vertices.len() as u32;
        assert_eq!(
            MeshPieces::cut_indexed(&vertices, &bad, rule, &transform, eye),
            Err(BvhError::CornerOutOfRange {
                index: 1234,
                vertices: vertices.len()
            })
        );
        let k = (0..indexed.len())
            .find(|&k| indexed.ids().nth(k).unwrap().contains(&1234))
            .unwrap();
        assert!(matches!(
            indexed.build_indexed(k, &vertices, &bad, transform),
            Err(BvhError::CornerOutOfRange { index: 1234, .. })
        ));
    }
}
