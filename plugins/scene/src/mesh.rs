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
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(MeshSkip::Topology(mesh.primitive_topology()));
    }
    let positions = match mesh.try_attribute_option(Mesh::ATTRIBUTE_POSITION) {
        Err(_) => return Err(MeshSkip::RenderWorldOnly),
        Ok(None) => return Err(MeshSkip::NoPositions),
        Ok(Some(VertexAttributeValues::Float32x3(p))) => p,
        Ok(Some(_)) => return Err(MeshSkip::PositionFormat),
    };
    let n = positions.len();
    let corners = corner_indices(mesh, n)?;
    let triangles = corners
        .iter()
        .map(|c| {
            let [a, b, c] = c.map(|i| Vec3::from_array(positions[i as usize]));
            Triangle::new(a, b, c)
        })
        .collect();
    let normals = match mesh.try_attribute_option(Mesh::ATTRIBUTE_NORMAL) {
        Ok(Some(VertexAttributeValues::Float32x3(v))) if v.len() == n => corners
            .iter()
            .map(|c| c.map(|i| Vec3::from_array(v[i as usize])))
            .collect(),
        _ => Vec::new(),
    };
    let uvs = match mesh.try_attribute_option(Mesh::ATTRIBUTE_UV_0) {
        Ok(Some(VertexAttributeValues::Float32x2(v))) if v.len() == n => corners
            .iter()
            .map(|c| c.map(|i| Vec2::from_array(v[i as usize])))
            .collect(),
        _ => Vec::new(),
    };
    Ok(MeshGeometry {
        triangles,
        shading: TriangleShading { normals, uvs },
    })
}

/// The vertex indices of each triangle, checked against the vertex count.
fn corner_indices(mesh: &Mesh, vertices: usize) -> Result<Vec<[u32; 3]>, MeshSkip> {
    let indices = mesh
        .try_indices_option()
        .map_err(|_| MeshSkip::RenderWorldOnly)?;
    let corners: Vec<[u32; 3]> = match indices {
        Some(Indices::U16(ix)) => ix
            .chunks_exact(3)
            .map(|f| [f[0] as u32, f[1] as u32, f[2] as u32])
            .collect(),
        Some(Indices::U32(ix)) => ix.chunks_exact(3).map(|f| [f[0], f[1], f[2]]).collect(),
        None => (0..(vertices / 3) as u32)
            .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
            .collect(),
    };
    if let Some(&index) = corners.iter().flatten().find(|&&i| i as usize >= vertices) {
        return Err(MeshSkip::IndexOutOfRange { index, vertices });
    }
    Ok(corners)
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
