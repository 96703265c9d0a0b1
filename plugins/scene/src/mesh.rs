//! Bevy meshes to engine triangles (object space).

use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
use std::fmt;
use treelight_bvh::Triangle;
use treelight_bvh::glam::{Vec2, Vec3};

/// Why a mesh cannot be traced.
#[derive(Debug, Clone, PartialEq)]
pub enum MeshSkip {
    /// Not a triangle list.
    Topology(PrimitiveTopology),
    /// No `POSITION` attribute.
    NoPositions,
    /// Positions that are not three 32-bit floats.
    PositionFormat,
    /// The vertex data lives only in the render world (`RenderAssetUsages::RENDER_WORLD`).
    RenderWorldOnly,
    /// An index past the vertex arrays.
    IndexOutOfRange {
        /// The index.
        index: u32,
        /// Vertices in the mesh.
        vertices: usize,
    },
}

impl fmt::Display for MeshSkip {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshSkip::Topology(t) => write!(f, "its topology is {t:?}, not a triangle list"),
            MeshSkip::NoPositions => write!(f, "it has no vertex positions"),
            MeshSkip::PositionFormat => write!(f, "its positions are not Float32x3"),
            MeshSkip::RenderWorldOnly => write!(f, "its vertex data was moved to the render world"),
            MeshSkip::IndexOutOfRange { index, vertices } => {
                write!(f, "index {index} is past its {vertices} vertices")
            }
        }
    }
}

/// Per-triangle shading data, in the order of [`mesh_triangles`]: what a renderer interpolates at a
/// hit. Kept apart from the triangles because the BVH never needs it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleShading {
    /// Object-space vertex normals of each triangle's corners; empty when the mesh has none (the
    /// renderer then shades flat).
    pub normals: Vec<[Vec3; 3]>,
    /// `UV_0` of each triangle's corners; empty when the mesh has none.
    pub uvs: Vec<[Vec2; 3]>,
}

/// A mesh as the scene BVH and a renderer see it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshGeometry {
    /// Object-space triangles, in index order.
    pub triangles: Vec<Triangle>,
    /// Their normals and texture coordinates.
    pub shading: TriangleShading,
}

/// The mesh's triangles in object space, in index order.
pub fn mesh_triangles(mesh: &Mesh) -> Result<Vec<Triangle>, MeshSkip> {
    Ok(mesh_geometry(mesh)?.triangles)
}

/// The mesh's triangles with their normals and texture coordinates. Normals or UVs in another format,
/// or with a count that does not match the positions, are left out rather than misread.
pub fn mesh_geometry(mesh: &Mesh) -> Result<MeshGeometry, MeshSkip> {
    let mut copy = GeometryCopy::new(mesh)?;
    copy.copy(mesh, usize::MAX)?;
    Ok(copy.finish())
}

/// Reads a mesh's geometry a range of triangles at a time, so that a mesh of millions of triangles
/// can be copied out of the world over several frames, each within a time budget.
#[derive(Debug)]
pub struct GeometryCopy {
    geometry: MeshGeometry,
    next: usize,
    total: usize,
    vertices: usize,
    normals: bool,
    uvs: bool,
    corners: Vec<[u32; 3]>,
}

fn positions_of(mesh: &Mesh) -> Result<&[[f32; 3]], MeshSkip> {
    match mesh.try_attribute_option(Mesh::ATTRIBUTE_POSITION) {
        Err(_) => Err(MeshSkip::RenderWorldOnly),
        Ok(None) => Err(MeshSkip::NoPositions),
        Ok(Some(VertexAttributeValues::Float32x3(p))) => Ok(p),
        Ok(Some(_)) => Err(MeshSkip::PositionFormat),
    }
}

fn triangle_count(mesh: &Mesh, vertices: usize) -> Result<usize, MeshSkip> {
    Ok(
        match mesh
            .try_indices_option()
            .map_err(|_| MeshSkip::RenderWorldOnly)?
        {
            Some(ix) => ix.len() / 3,
            None => vertices / 3,
        },
    )
}

/// Vertex count, triangle count, and whether normals and UVs are usable.
fn shape(mesh: &Mesh) -> Result<(usize, usize, bool, bool), MeshSkip> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(MeshSkip::Topology(mesh.primitive_topology()));
    }
    let vertices = positions_of(mesh)?.len();
    let total = triangle_count(mesh, vertices)?;
    let normals = matches!(
        mesh.try_attribute_option(Mesh::ATTRIBUTE_NORMAL),
        Ok(Some(VertexAttributeValues::Float32x3(v))) if v.len() == vertices
    );
    let uvs = matches!(
        mesh.try_attribute_option(Mesh::ATTRIBUTE_UV_0),
        Ok(Some(VertexAttributeValues::Float32x2(v))) if v.len() == vertices
    );
    Ok((vertices, total, normals, uvs))
}

impl GeometryCopy {
    /// Checks what can be checked without reading every triangle, and sizes the output.
    pub fn new(mesh: &Mesh) -> Result<Self, MeshSkip> {
        let (vertices, total, normals, uvs) = shape(mesh)?;
        Ok(Self {
            geometry: MeshGeometry {
                triangles: Vec::with_capacity(total),
                shading: TriangleShading {
                    normals: Vec::with_capacity(if normals { total } else { 0 }),
                    uvs: Vec::with_capacity(if uvs { total } else { 0 }),
                },
            },
            next: 0,
            total,
            vertices,
            normals,
            uvs,
            corners: Vec::new(),
        })
    }

    /// Triangles in the mesh.
    pub fn total(&self) -> usize {
        self.total
    }

    /// Triangles copied so far.
    pub fn copied(&self) -> usize {
        self.next
    }

    /// Copies up to `max` more triangles from `mesh` (the mesh this copy was made for; the caller
    /// starts a new copy when the asset changes). Returns whether the copy is complete.
    pub fn copy(&mut self, mesh: &Mesh, max: usize) -> Result<bool, MeshSkip> {
        if shape(mesh)? != (self.vertices, self.total, self.normals, self.uvs) {
            // Changed under us without the caller noticing: start over rather than mix versions.
            *self = GeometryCopy::new(mesh)?;
        }
        let positions = positions_of(mesh)?;
        let end = self.total.min(self.next.saturating_add(max));
        self.corners.clear();
        match mesh.try_indices_option() {
            Ok(Some(Indices::U16(ix))) => self.corners.extend(
                ix[3 * self.next..3 * end]
                    .chunks_exact(3)
                    .map(|f| [f[0] as u32, f[1] as u32, f[2] as u32]),
            ),
            Ok(Some(Indices::U32(ix))) => self.corners.extend(
                ix[3 * self.next..3 * end]
                    .chunks_exact(3)
                    .map(|f| [f[0], f[1], f[2]]),
            ),
            Ok(None) => self
                .corners
                .extend((self.next as u32..end as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2])),
            Err(_) => return Err(MeshSkip::RenderWorldOnly),
        }
        let vertices = self.vertices;
        if let Some(&index) = self
            .corners
            .iter()
            .flatten()
            .find(|&&i| i as usize >= vertices)
        {
            return Err(MeshSkip::IndexOutOfRange { index, vertices });
        }
        let g = &mut self.geometry;
        g.triangles.extend(self.corners.iter().map(|c| {
            let [a, b, c] = c.map(|i| Vec3::from_array(positions[i as usize]));
            Triangle::new(a, b, c)
        }));
        if self.normals
            && let Ok(Some(VertexAttributeValues::Float32x3(v))) =
                mesh.try_attribute_option(Mesh::ATTRIBUTE_NORMAL)
        {
            g.shading.normals.extend(
                self.corners
                    .iter()
                    .map(|c| c.map(|i| Vec3::from_array(v[i as usize]))),
            );
        }
        if self.uvs
            && let Ok(Some(VertexAttributeValues::Float32x2(v))) =
                mesh.try_attribute_option(Mesh::ATTRIBUTE_UV_0)
        {
            g.shading.uvs.extend(
                self.corners
                    .iter()
                    .map(|c| c.map(|i| Vec2::from_array(v[i as usize]))),
            );
        }
        self.next = end;
        Ok(end == self.total)
    }

    /// The geometry copied (complete once [`GeometryCopy::copy`] has returned `true`).
    pub fn finish(self) -> MeshGeometry {
        self.geometry
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::asset::RenderAssetUsages;
    use bevy::math::primitives::Cuboid;
    use bevy::mesh::{MeshBuilder, Meshable};

    #[test]
    fn cuboid_has_twelve_triangles_on_its_surface() {
        let tris = mesh_triangles(&Cuboid::new(2.0, 2.0, 2.0).mesh().build()).unwrap();
        assert_eq!(tris.len(), 12);
        for t in tris {
            for p in t.v {
                assert!((p.abs().max_element() - 1.0).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn unusable_meshes_say_why() {
        let lines = Mesh::new(PrimitiveTopology::LineList, RenderAssetUsages::default());
        assert_eq!(
            mesh_triangles(&lines),
            Err(MeshSkip::Topology(PrimitiveTopology::LineList))
        );
        let empty = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        assert_eq!(mesh_triangles(&empty), Err(MeshSkip::NoPositions));
        let bad = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; 3])
        .with_inserted_indices(Indices::U16(vec![0, 1, 7]));
        assert_eq!(
            mesh_triangles(&bad),
            Err(MeshSkip::IndexOutOfRange {
                index: 7,
                vertices: 3
            })
        );
        let unindexed = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_POSITION,
            vec![[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        );
        assert_eq!(mesh_triangles(&unindexed).unwrap().len(), 1);
    }

    #[test]
    fn copying_in_chunks_equals_copying_at_once() {
        use bevy::math::primitives::Sphere;
        let mesh = Sphere::new(1.0).mesh().uv(13, 7);
        let whole = mesh_geometry(&mesh).unwrap();
        assert!(!whole.shading.normals.is_empty() && !whole.shading.uvs.is_empty());
        let mut copy = GeometryCopy::new(&mesh).unwrap();
        let mut calls = 0;
        while !copy.copy(&mesh, 7).unwrap() {
            calls += 1;
            assert_eq!(copy.copied(), calls * 7);
        }
        assert_eq!(calls, copy.total().div_ceil(7) - 1);
        assert_eq!(copy.finish(), whole);
        // A mesh swapped for another between chunks is read again from the start.
        let other = Cuboid::new(1.0, 2.0, 3.0).mesh().build();
        let mut copy = GeometryCopy::new(&mesh).unwrap();
        copy.copy(&mesh, 7).unwrap();
        while !copy.copy(&other, 5).unwrap() {}
        assert_eq!(copy.finish(), mesh_geometry(&other).unwrap());
    }

    #[test]
    fn shading_follows_the_triangles() {
        let g = mesh_geometry(&Cuboid::new(2.0, 2.0, 2.0).mesh().build()).unwrap();
        assert_eq!(g.shading.normals.len(), g.triangles.len());
        assert_eq!(g.shading.uvs.len(), g.triangles.len());
        for (t, n) in g.triangles.iter().zip(&g.shading.normals) {
            // A cuboid's vertex normals are its face normals.
            let face = t.normal().normalize();
            for c in n {
                assert!(c.dot(face) > 0.999, "{c} vs {face}");
            }
        }
        let bare = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; 3])
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0f32, 1.0, 0.0]; 2]);
        let g = mesh_geometry(&bare).unwrap();
        assert!(
            g.shading.normals.is_empty(),
            "mismatched counts are left out"
        );
        assert!(g.shading.uvs.is_empty());
    }
}
