//! A mesh's shading data as the scene keeps it for a renderer: by vertex, as the mesh has it, with
//! each triangle's three corners into those vertices. An indexed mesh shares most vertices between
//! triangles (half a vertex a triangle on a smooth grid), so keeping the corners' data by triangle
//! would hold each vertex six times; the corners take 16 bits each where the vertices fit.

use std::sync::Arc;
use treelight_bvh::glam::Vec2;

/// The shading arrays of a mesh's vertices. Each holds one entry per vertex, or none when the
/// mesh has no such attribute (or one the copy could not read).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadingVertices {
    /// Object-space vertex normals, packed ([`encode_normal`](crate::types::packed::encode_normal));
    /// empty when the mesh has none (the renderer then shades flat).
    pub normals: Vec<u32>,
    /// `UV_0`.
    pub uvs: Vec<Vec2>,
    /// `UV_1`, the second set, which some of a material's maps may read.
    pub uvs1: Vec<Vec2>,
    /// Object-space tangents (xyz, and the bitangent's sign in w, as glTF and Bevy's
    /// `ATTRIBUTE_TANGENT` have them), packed
    /// ([`encode_tangent`](crate::types::packed::encode_tangent)), so a renderer bends normal maps along
    /// the same frame as Bevy's.
    pub tangents: Vec<u32>,
}

impl ShadingVertices {
    /// Whether no attribute is kept (a triangle's corners then name nothing).
    pub fn is_empty(&self) -> bool {
        self.normals.is_empty()
            && self.uvs.is_empty()
            && self.uvs1.is_empty()
            && self.tangents.is_empty()
    }

    /// Vertices they hold (the longest array: each holds all of them or none).
    pub fn len(&self) -> usize {
        self.normals
            .len()
            .max(self.uvs.len())
            .max(self.uvs1.len())
            .max(self.tangents.len())
    }

    /// Heap bytes of the arrays, at their capacities.
    pub fn heap_bytes(&self) -> usize {
        (self.normals.capacity() + self.tangents.capacity()) * size_of::<u32>()
            + (self.uvs.capacity() + self.uvs1.capacity()) * size_of::<Vec2>()
    }
}

/// Each triangle's three vertices, in the narrowest form that names them.
#[derive(Clone, Debug, PartialEq)]
enum Corners {
    /// Triangle `k`'s corners are vertices `3k`, `3k + 1` and `3k + 2` (an unindexed mesh, or
    /// shading with no vertex data): nothing to keep but the count.
    Sequential(usize),
    /// Indices under 65,536.
    Short(Vec<[u16; 3]>),
    /// Any others.
    Long(Vec<[u32; 3]>),
}

impl Default for Corners {
    fn default() -> Self {
        Corners::Sequential(0)
    }
}

/// Per-triangle shading data, in the order of a mesh's triangles (`MeshGeometry::triangles`):
/// what a renderer interpolates at a hit, kept apart from the triangles because the BVH never
/// needs it. Its vertices are shared: the chunks of a mesh cut
/// into several groups ([`MeshShading::subset`]) hold the mesh's vertex arrays once.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshShading {
    vertices: Arc<ShadingVertices>,
    corners: Corners,
}

impl MeshShading {
    /// The shading of triangles whose corners are `corners` into `vertices`. A corner past a
    /// vertex array it would read makes that triangle's attribute absent, never a wrong one.
    pub fn new(vertices: ShadingVertices, corners: &[[u32; 3]]) -> Self {
        let sequential = corners
            .iter()
            .enumerate()
            .all(|(k, c)| *c == [3 * k as u32, 3 * k as u32 + 1, 3 * k as u32 + 2]);
        Self {
            corners: Self::narrowest(vertices.is_empty() || sequential, corners),
            vertices: Arc::new(vertices),
        }
    }

    fn narrowest(sequential: bool, corners: &[[u32; 3]]) -> Corners {
        if sequential {
            Corners::Sequential(corners.len())
        } else if corners.iter().flatten().all(|&i| i <= u32::from(u16::MAX)) {
            Corners::Short(corners.iter().map(|c| c.map(|i| i as u16)).collect())
        } else {
            Corners::Long(corners.to_vec())
        }
    }

    /// Triangles it covers.
    pub fn len(&self) -> usize {
        match &self.corners {
            Corners::Sequential(n) => *n,
            Corners::Short(c) => c.len(),
            Corners::Long(c) => c.len(),
        }
    }

    /// Whether it covers no triangle.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The vertex arrays.
    pub fn vertices(&self) -> &ShadingVertices {
        &self.vertices
    }

    /// The vertex arrays as shared: the same for every shading made from one mesh (its chunks,
    /// the groups that show it), so a renderer uploads them once.
    pub fn shared_vertices(&self) -> &Arc<ShadingVertices> {
        &self.vertices
    }

    /// Triangle `k`'s three vertices, if it has them.
    pub fn corners(&self, k: usize) -> Option<[u32; 3]> {
        match &self.corners {
            Corners::Sequential(n) => (k < *n).then(|| {
                let first = 3 * k as u32;
                [first, first + 1, first + 2]
            }),
            Corners::Short(c) => c.get(k).map(|c| c.map(u32::from)),
            Corners::Long(c) => c.get(k).copied(),
        }
    }

    /// Triangle `k`'s entries of one vertex array, when the array covers its three corners.
    fn of<T: Copy>(&self, k: usize, array: &[T]) -> Option<[T; 3]> {
        let [a, b, c] = self.corners(k)?;
        Some([
            *array.get(a as usize)?,
            *array.get(b as usize)?,
            *array.get(c as usize)?,
        ])
    }

    /// Triangle `k`'s corner normals, packed.
    pub fn normals(&self, k: usize) -> Option<[u32; 3]> {
        self.of(k, &self.vertices.normals)
    }

    /// Triangle `k`'s corner `UV_0`s.
    pub fn uvs(&self, k: usize) -> Option<[Vec2; 3]> {
        self.of(k, &self.vertices.uvs)
    }

    /// Triangle `k`'s corner `UV_1`s.
    pub fn uvs1(&self, k: usize) -> Option<[Vec2; 3]> {
        self.of(k, &self.vertices.uvs1)
    }

    /// Triangle `k`'s corner tangents, packed by vertex
    /// ([`encode_tangent`](crate::types::packed::encode_tangent)).
    pub fn vertex_tangents(&self, k: usize) -> Option<[u32; 3]> {
        self.of(k, &self.vertices.tangents)
    }

    /// Whether it holds a second UV set.
    pub fn has_second_uv_set(&self) -> bool {
        !self.vertices.uvs1.is_empty()
    }

    /// The shading of triangles `ids` of these, in that order, sharing these vertices; empty when
    /// an id is past them.
    pub fn subset(&self, ids: &[u32]) -> MeshShading {
        let corners: Option<Vec<[u32; 3]>> =
            ids.iter().map(|&t| self.corners(t as usize)).collect();
        let Some(corners) = corners else {
            return MeshShading::default();
        };
        MeshShading {
            vertices: Arc::clone(&self.vertices),
            corners: Self::narrowest(self.vertices.is_empty(), &corners),
        }
    }

    /// Heap bytes of its corners (its vertices are counted by [`MeshShading::vertex_bytes`], once
    /// for all the shading that shares them).
    pub fn corner_bytes(&self) -> usize {
        match &self.corners {
            Corners::Sequential(_) => 0,
            Corners::Short(c) => c.capacity() * size_of::<[u16; 3]>(),
            Corners::Long(c) => c.capacity() * size_of::<[u32; 3]>(),
        }
    }

    /// Heap bytes of its vertex arrays, and an address that is the same for every shading sharing
    /// them.
    pub fn vertex_bytes(&self) -> (usize, *const ShadingVertices) {
        (self.vertices.heap_bytes(), Arc::as_ptr(&self.vertices))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vertices(n: usize) -> ShadingVertices {
        ShadingVertices {
            normals: (0..n as u32).collect(),
            uvs: (0..n).map(|i| Vec2::splat(i as f32)).collect(),
            uvs1: Vec::new(),
            tangents: Vec::new(),
        }
    }

    #[test]
    fn corners_take_the_narrowest_form_and_read_the_same() {
        let grid = [[0, 1, 2], [2, 1, 3]];
        let s = MeshShading::new(vertices(4), &grid);
        assert!(matches!(s.corners, Corners::Short(_)));
        assert_eq!(s.normals(1), Some([2, 1, 3]));
        assert_eq!(s.uvs(0), Some([0.0, 1.0, 2.0].map(Vec2::splat)));
        assert_eq!(s.uvs1(0), None, "no second set");
        assert_eq!(s.normals(2), None, "past the triangles");
        let flat = MeshShading::new(vertices(6), &[[0, 1, 2], [3, 4, 5]]);
        assert_eq!(flat.corners, Corners::Sequential(2));
        assert_eq!(flat.corner_bytes(), 0);
        assert_eq!(flat.normals(1), Some([3, 4, 5]));
        let far = MeshShading::new(vertices(70_000), &[[0, 69_999, 65_536]]);
        assert!(matches!(far.corners, Corners::Long(_)));
        assert_eq!(far.normals(0), Some([0, 69_999, 65_536]));
        let bare = MeshShading::new(ShadingVertices::default(), &grid);
        assert_eq!((bare.len(), bare.corner_bytes()), (2, 0));
        assert_eq!(bare.normals(0), None);
    }

    #[test]
    fn a_corner_past_its_array_leaves_that_attribute_out() {
        let mut v = vertices(3);
        v.uvs.truncate(2);
        let s = MeshShading::new(v, &[[0, 1, 2], [0, 1, 1]]);
        assert_eq!(s.normals(0), Some([0, 1, 2]));
        assert_eq!(s.uvs(0), None);
        assert_eq!(s.uvs(1), Some([0.0, 1.0, 1.0].map(Vec2::splat)));
    }

    #[test]
    fn a_subset_shares_the_vertices() {
        let s = MeshShading::new(vertices(5), &[[0, 1, 2], [2, 3, 4], [4, 0, 1]]);
        let part = s.subset(&[2, 0]);
        assert_eq!(part.len(), 2);
        assert_eq!(part.normals(0), Some([4, 0, 1]));
        assert_eq!(part.normals(1), Some([0, 1, 2]));
        assert_eq!(part.vertex_bytes().1, s.vertex_bytes().1);
        assert!(s.subset(&[0, 3]).is_empty(), "an id past the triangles");
    }
}
