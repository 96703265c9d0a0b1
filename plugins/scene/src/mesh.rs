//! Bevy meshes to engine triangles (object space).

use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
use std::fmt;
use treelight_bvh::Triangle;
use treelight_bvh::glam::Vec3;

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

/// The mesh's triangles in object space, in index order.
pub fn mesh_triangles(mesh: &Mesh) -> Result<Vec<Triangle>, MeshSkip> {
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
    let v = |i: u32| -> Result<Vec3, MeshSkip> {
        positions
            .get(i as usize)
            .map(|p| Vec3::from_array(*p))
            .ok_or(MeshSkip::IndexOutOfRange {
                index: i,
                vertices: n,
            })
    };
    let indices = mesh
        .try_indices_option()
        .map_err(|_| MeshSkip::RenderWorldOnly)?;
    let tri = |a: u32, b: u32, c: u32| Ok(Triangle::new(v(a)?, v(b)?, v(c)?));
    match indices {
        Some(Indices::U16(ix)) => ix
            .chunks_exact(3)
            .map(|f| tri(f[0] as u32, f[1] as u32, f[2] as u32))
            .collect(),
        Some(Indices::U32(ix)) => ix.chunks_exact(3).map(|f| tri(f[0], f[1], f[2])).collect(),
        None => (0..(n / 3) as u32)
            .map(|k| tri(3 * k, 3 * k + 1, 3 * k + 2))
            .collect(),
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
}
