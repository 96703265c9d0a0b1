//! Bevy meshes to engine triangles (object space).

use crate::types::packed::{encode_normal, encode_tangent};
use crate::types::shading::{MeshShading, ShadingVertices};
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
use std::fmt;
use treelight_bvh::Triangle;
use treelight_bvh::glam::{Vec2, Vec3, Vec4};

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

/// A mesh's positions and its triangles as indices into them, object space: what the tree keeps
/// of it ([`treelight_bvh::PreparedGroup::build_indexed`]), without a soup of triangles between.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshPositions {
    /// The positions, as the mesh has them.
    pub vertices: Vec<Vec3>,
    /// Each triangle's corners, indices into `vertices`, in index order.
    pub corners: Vec<[u32; 3]>,
}

impl MeshPositions {
    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    /// Whether there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// The triangles, in index order.
    pub fn triangles(&self) -> Vec<Triangle> {
        self.corners
            .iter()
            .map(|c| {
                let [a, b, c] = c.map(|i| self.vertices[i as usize]);
                Triangle::new(a, b, c)
            })
            .collect()
    }
}

/// A mesh as the scene BVH and a renderer see it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshGeometry {
    /// Object-space triangles, in index order.
    pub triangles: Vec<Triangle>,
    /// Their normals, texture coordinates and tangents.
    pub shading: MeshShading,
}

/// The mesh's triangles in object space, in index order.
pub fn mesh_triangles(mesh: &Mesh) -> Result<Vec<Triangle>, MeshSkip> {
    Ok(mesh_geometry(mesh)?.triangles)
}

/// The mesh's triangles with their normals and texture coordinates. Normals or UVs in another format,
/// or with a count that does not match the positions, are left out rather than misread.
pub fn mesh_geometry(mesh: &Mesh) -> Result<MeshGeometry, MeshSkip> {
    Ok(GeometryCopy::whole(mesh)?.finish())
}

/// Copies a mesh out of the world a slice of its arrays at a time, so that a mesh of millions of
/// triangles is copied over several frames, each within a time budget. The arrays are copied as they
/// are (positions, usable normals and UVs, indices: memory copies, with the indices checked); making
/// triangles of them ([`GeometryCopy::finish`]) is left to whoever takes the copy, off the frame.
/// The destination of a big mesh is allocated and first written on a thread of its own: touching
/// fresh memory costs several times the copy itself.
#[derive(Debug)]
pub struct GeometryCopy {
    arrays: Destination,
    /// The mesh's sizes as the copy began (a different shape restarts it).
    shape: Shape,
    /// Elements copied so far, over positions, normals, UVs and indices in that order.
    next: usize,
}

/// The copy's destination: room for the mesh's arrays, filled as the copy goes.
#[derive(Debug, Default)]
struct Arrays {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    uvs1: Vec<[f32; 2]>,
    tangents: Vec<[f32; 4]>,
    indices: Vec<u32>,
}

impl Arrays {
    /// Room for every array; with `touch`, every page of it written once (and emptied again), so
    /// the copy does not pay for first touching fresh memory.
    fn reserved(sh: Shape, touch: bool) -> Self {
        fn room<T: Copy>(n: usize, zero: T, touch: bool) -> Vec<T> {
            let mut v = Vec::with_capacity(n);
            if touch {
                v.resize(n, zero);
                v.clear();
            }
            v
        }
        let per_vertex = |used: bool| if used { sh.vertices } else { 0 };
        Self {
            positions: room(sh.vertices, [0.0; 3], touch),
            normals: room(per_vertex(sh.normals), [0.0; 3], touch),
            uvs: room(per_vertex(sh.uvs), [0.0; 2], touch),
            uvs1: room(per_vertex(sh.uvs1), [0.0; 2], touch),
            tangents: room(per_vertex(sh.tangents), [0.0; 4], touch),
            indices: room(if sh.indexed { 3 * sh.triangles } else { 0 }, 0, touch),
        }
    }
}

#[derive(Debug)]
enum Destination {
    Ready(Arrays),
    /// Being allocated on another thread.
    Coming(std::thread::JoinHandle<Arrays>),
}

/// Bytes from which a destination is allocated on a thread of its own.
const BACKGROUND_BYTES: usize = 1 << 20;

fn positions_of(mesh: &Mesh) -> Result<&[[f32; 3]], MeshSkip> {
    match mesh.try_attribute_option(Mesh::ATTRIBUTE_POSITION) {
        Err(_) => Err(MeshSkip::RenderWorldOnly),
        Ok(None) => Err(MeshSkip::NoPositions),
        Ok(Some(VertexAttributeValues::Float32x3(p))) => Ok(p),
        Ok(Some(_)) => Err(MeshSkip::PositionFormat),
    }
}

/// What a copy is sized by: vertex count, triangle count, whether indexed, and whether normals, the
/// two UV sets and tangents are usable.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Shape {
    vertices: usize,
    triangles: usize,
    indexed: bool,
    normals: bool,
    uvs: bool,
    uvs1: bool,
    tangents: bool,
}

fn shape(mesh: &Mesh) -> Result<Shape, MeshSkip> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(MeshSkip::Topology(mesh.primitive_topology()));
    }
    let vertices = positions_of(mesh)?.len();
    let indices = mesh
        .try_indices_option()
        .map_err(|_| MeshSkip::RenderWorldOnly)?;
    let normals = matches!(
        mesh.try_attribute_option(Mesh::ATTRIBUTE_NORMAL),
        Ok(Some(VertexAttributeValues::Float32x3(v))) if v.len() == vertices
    );
    let uvs = matches!(
        mesh.try_attribute_option(Mesh::ATTRIBUTE_UV_0),
        Ok(Some(VertexAttributeValues::Float32x2(v))) if v.len() == vertices
    );
    let uvs1 = matches!(
        mesh.try_attribute_option(Mesh::ATTRIBUTE_UV_1),
        Ok(Some(VertexAttributeValues::Float32x2(v))) if v.len() == vertices
    );
    let tangents = matches!(
        mesh.try_attribute_option(Mesh::ATTRIBUTE_TANGENT),
        Ok(Some(VertexAttributeValues::Float32x4(v))) if v.len() == vertices
    );
    Ok(Shape {
        vertices,
        triangles: indices.map_or(vertices, Indices::len) / 3,
        indexed: indices.is_some(),
        normals,
        uvs,
        uvs1,
        tangents,
    })
}

impl GeometryCopy {
    /// Checks what can be checked without reading the arrays, and sizes the copy. A big mesh's
    /// destination is made on a thread of its own; copying starts when it is there.
    pub fn new(mesh: &Mesh) -> Result<Self, MeshSkip> {
        Self::sized(mesh, true)
    }

    /// The whole copy at once, for a thread other than the frame's (an importer's, as it makes the
    /// asset): what `SceneBvh::prepare` takes.
    pub fn whole(mesh: &Mesh) -> Result<Self, MeshSkip> {
        let mut copy = Self::sized(mesh, false)?;
        copy.copy(mesh, usize::MAX)?;
        Ok(copy)
    }

    /// `background`: whether a big destination may be made on a thread of its own.
    fn sized(mesh: &Mesh, background: bool) -> Result<Self, MeshSkip> {
        let sh = shape(mesh)?;
        let bytes = 4
            * (3 * sh.vertices * (1 + sh.normals as usize)
                + 2 * sh.vertices * (sh.uvs as usize + sh.uvs1 as usize)
                + 4 * sh.vertices * sh.tangents as usize
                + 3 * sh.triangles * sh.indexed as usize);
        let arrays = if background && bytes >= BACKGROUND_BYTES {
            let spawned = std::thread::Builder::new()
                .name("treelight-mesh-copy".into())
                .spawn(move || Arrays::reserved(sh, true));
            match spawned {
                Ok(handle) => Destination::Coming(handle),
                Err(_) => Destination::Ready(Arrays::reserved(sh, false)),
            }
        } else {
            // Small: the copy's own writes touch its pages, a slice at a time within the budget.
            Destination::Ready(Arrays::reserved(sh, false))
        };
        Ok(Self {
            arrays,
            shape: sh,
            next: 0,
        })
    }

    /// Array elements to copy: positions, usable normals, UV sets and tangents, and indices.
    pub fn total(&self) -> usize {
        self.sections().iter().sum()
    }

    /// Elements in each section, in copy order: positions, normals, UVs, tangents, second UVs,
    /// indices (0 for one that is not copied).
    fn sections(&self) -> [usize; 6] {
        let sh = self.shape;
        let v = sh.vertices;
        [
            v,
            if sh.normals { v } else { 0 },
            if sh.uvs { v } else { 0 },
            if sh.tangents { v } else { 0 },
            if sh.uvs1 { v } else { 0 },
            if sh.indexed { 3 * sh.triangles } else { 0 },
        ]
    }

    /// Whether the copy is whole and of a mesh of `mesh`'s sizes (what a copy handed over must be
    /// to go to the worker as it is).
    pub fn is_whole_copy_of(&self, mesh: &Mesh) -> bool {
        self.next == self.total() && shape(mesh).is_ok_and(|sh| sh == self.shape)
    }

    /// Elements copied so far.
    pub fn copied(&self) -> usize {
        self.next
    }

    /// Triangles in the mesh.
    pub fn triangles(&self) -> usize {
        self.shape.triangles
    }

    /// Copies up to `max` more array elements from `mesh` (the mesh this copy was made for; the
    /// caller starts a new copy when the asset changes). Returns whether the copy is complete.
    pub fn copy(&mut self, mesh: &Mesh, max: usize) -> Result<bool, MeshSkip> {
        if shape(mesh)? != self.shape {
            // Changed under us without the caller noticing: start over rather than mix versions.
            *self = GeometryCopy::new(mesh)?;
        }
        if let Destination::Coming(handle) = &self.arrays {
            if !handle.is_finished() {
                return Ok(false);
            }
            let placeholder = Destination::Ready(Arrays::default());
            if let Destination::Coming(handle) = std::mem::replace(&mut self.arrays, placeholder) {
                let sh = self.shape;
                self.arrays = Destination::Ready(
                    handle
                        .join()
                        .unwrap_or_else(|_| Arrays::reserved(sh, false)),
                );
            }
        }
        let mut left = max.max(1);
        let mut start = 0usize;
        for (k, len) in self.sections().into_iter().enumerate() {
            let end = start + len;
            if self.next < end && left > 0 {
                let from = self.next - start;
                let to = len.min(from.saturating_add(left));
                self.copy_section(mesh, k, from, to)?;
                left -= to - from;
                self.next = start + to;
            }
            start = end;
        }
        Ok(self.next == self.total())
    }

    /// Elements `from..to` of section `k` (positions, normals, UVs, tangents, second UVs, indices).
    fn copy_section(
        &mut self,
        mesh: &Mesh,
        k: usize,
        from: usize,
        to: usize,
    ) -> Result<(), MeshSkip> {
        let attribute = |id| match mesh.try_attribute_option(id) {
            Ok(Some(values)) => Ok(values),
            _ => Err(MeshSkip::RenderWorldOnly),
        };
        let Destination::Ready(a) = &mut self.arrays else {
            return Ok(());
        };
        match k {
            0 => a
                .positions
                .extend_from_slice(&positions_of(mesh)?[from..to]),
            1 => {
                if let VertexAttributeValues::Float32x3(n) = attribute(Mesh::ATTRIBUTE_NORMAL)? {
                    a.normals.extend_from_slice(&n[from..to]);
                }
            }
            2 => {
                if let VertexAttributeValues::Float32x2(uv) = attribute(Mesh::ATTRIBUTE_UV_0)? {
                    a.uvs.extend_from_slice(&uv[from..to]);
                }
            }
            3 => {
                if let VertexAttributeValues::Float32x4(t) = attribute(Mesh::ATTRIBUTE_TANGENT)? {
                    a.tangents.extend_from_slice(&t[from..to]);
                }
            }
            4 => {
                if let VertexAttributeValues::Float32x2(uv) = attribute(Mesh::ATTRIBUTE_UV_1)? {
                    a.uvs1.extend_from_slice(&uv[from..to]);
                }
            }
            _ => {
                let at = a.indices.len();
                match mesh.try_indices_option() {
                    Ok(Some(Indices::U16(ix))) => {
                        a.indices.extend(ix[from..to].iter().map(|&i| u32::from(i)))
                    }
                    Ok(Some(Indices::U32(ix))) => a.indices.extend_from_slice(&ix[from..to]),
                    _ => return Err(MeshSkip::RenderWorldOnly),
                }
                let vertices = self.shape.vertices;
                if let Some(&index) = a.indices[at..].iter().find(|&&i| i as usize >= vertices) {
                    return Err(MeshSkip::IndexOutOfRange { index, vertices });
                }
            }
        }
        Ok(())
    }

    /// The triangles and their shading, made from the arrays copied (complete once
    /// [`GeometryCopy::copy`] has returned `true`). Of a partial copy it gives the triangles whose
    /// corners were copied, with normals and UVs only where those arrays were copied in full.
    pub fn finish(self) -> MeshGeometry {
        let (positions, shading) = self.finish_positions();
        MeshGeometry {
            triangles: positions.triangles(),
            shading,
        }
    }

    /// [`GeometryCopy::finish`] with the triangles as the mesh's positions and corners.
    pub fn finish_positions(self) -> (MeshPositions, MeshShading) {
        let Destination::Ready(a) = self.arrays else {
            return Default::default();
        };
        // The arrays hold what was copied.
        let v = a.positions.len();
        let corners: Vec<[u32; 3]> = if self.shape.indexed {
            a.indices
                .chunks_exact(3)
                .map(|f| [f[0], f[1], f[2]])
                .collect()
        } else {
            (0..(v / 3) as u32)
                .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
                .collect()
        };
        let corners: Vec<[u32; 3]> = corners
            .into_iter()
            .filter(|c| c.iter().all(|&i| (i as usize) < v))
            .collect();
        // An attribute the mesh lacks was never copied, and one copied in part is left out: a
        // vertex array holds an entry for every vertex or none.
        fn whole<T: Copy, U>(all: &[T], v: usize, to: impl Fn(T) -> U) -> Vec<U> {
            if all.len() != v {
                return Vec::new();
            }
            all.iter().map(|&x| to(x)).collect()
        }
        let vertices = ShadingVertices {
            normals: whole(&a.normals, v, |n| encode_normal(Vec3::from_array(n))),
            uvs: whole(&a.uvs, v, Vec2::from_array),
            uvs1: whole(&a.uvs1, v, Vec2::from_array),
            tangents: whole(&a.tangents, v, |t| encode_tangent(Vec4::from_array(t))),
        };
        let shading = MeshShading::new(vertices, &corners);
        let positions = MeshPositions {
            vertices: a.positions.iter().map(|&p| Vec3::from_array(p)).collect(),
            corners,
        };
        (positions, shading)
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
        let mut mesh = Sphere::new(1.0).mesh().uv(13, 7);
        // Tangents that tell their vertices apart.
        let vertices = mesh.count_vertices();
        let tangent_of = |i: usize| {
            let a = i as f32 * 0.37;
            Vec4::new(a.cos(), a.sin(), 0.3, -1.0)
        };
        let tangents: Vec<[f32; 4]> = (0..vertices).map(|i| tangent_of(i).to_array()).collect();
        mesh.insert_attribute(Mesh::ATTRIBUTE_TANGENT, tangents);
        // A second UV set that tells its vertices apart too.
        let uv1_of = |i: usize| Vec2::new(i as f32 * 0.25, 1.0 - i as f32 * 0.125);
        let uvs1: Vec<[f32; 2]> = (0..vertices).map(|i| uv1_of(i).to_array()).collect();
        mesh.insert_attribute(Mesh::ATTRIBUTE_UV_1, uvs1);
        let whole = mesh_geometry(&mesh).unwrap();
        let v = &whole.shading.vertices();
        assert!(!v.normals.is_empty() && !v.uvs.is_empty());
        assert_eq!(v.normals.len(), vertices, "one entry a vertex");
        let mut copy = GeometryCopy::new(&mesh).unwrap();
        assert_eq!(copy.triangles(), whole.triangles.len());
        let mut calls = 0;
        while !copy.copy(&mesh, 7).unwrap() {
            calls += 1;
            assert_eq!(copy.copied(), calls * 7);
        }
        assert_eq!(calls, copy.total().div_ceil(7) - 1);
        assert_eq!(copy.finish(), whole);
        // The triangles are the mesh's, corner by corner.
        let VertexAttributeValues::Float32x3(p) = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap()
        else {
            unreachable!()
        };
        let ix: Vec<usize> = mesh.indices().unwrap().iter().collect();
        assert_eq!(whole.shading.len(), whole.triangles.len());
        for (k, (t, f)) in whole.triangles.iter().zip(ix.chunks_exact(3)).enumerate() {
            let uvs1 = whole.shading.uvs1(k).unwrap();
            for c in 0..3 {
                assert_eq!(t.v[c], Vec3::from_array(p[f[c]]));
                assert_eq!(uvs1[c], uv1_of(f[c]));
            }
            assert_eq!(
                whole.shading.vertex_tangents(k).unwrap(),
                [tangent_of(f[0]), tangent_of(f[1]), tangent_of(f[2])].map(encode_tangent)
            );
        }
        // A mesh swapped for another between chunks is read again from the start.
        let other = Cuboid::new(1.0, 2.0, 3.0).mesh().build();
        let mut copy = GeometryCopy::new(&mesh).unwrap();
        copy.copy(&mesh, 7).unwrap();
        while !copy.copy(&other, 5).unwrap() {}
        assert_eq!(copy.finish(), mesh_geometry(&other).unwrap());
    }

    #[test]
    fn a_big_mesh_is_copied_once_its_destination_is_made() {
        use bevy::math::primitives::Sphere;
        let mesh = Sphere::new(1.0).mesh().uv(200, 100);
        let mut copy = GeometryCopy::new(&mesh).unwrap();
        assert!(matches!(copy.arrays, Destination::Coming(..)), "over 1 MB");
        let start = std::time::Instant::now();
        while !copy.copy(&mesh, 10_000).unwrap() {
            assert!(start.elapsed().as_secs() < 30, "never copied");
        }
        assert_eq!(copy.finish(), mesh_geometry(&mesh).unwrap());
    }

    #[test]
    fn shading_follows_the_triangles() {
        let g = mesh_geometry(&Cuboid::new(2.0, 2.0, 2.0).mesh().build()).unwrap();
        assert_eq!(g.shading.len(), g.triangles.len());
        for (k, t) in g.triangles.iter().enumerate() {
            assert!(g.shading.uvs(k).is_some());
            // A cuboid's vertex normals are its face normals.
            let face = t.normal().normalize();
            for c in g.shading.normals(k).unwrap() {
                let c = crate::types::packed::decode_normal(c);
                assert!(c.dot(face) > 0.999, "{c} vs {face}");
            }
        }
        let bare = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; 3])
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0f32, 1.0, 0.0]; 2])
        .with_inserted_attribute(Mesh::ATTRIBUTE_TANGENT, vec![[1.0f32, 0.0, 0.0, 1.0]; 4]);
        let g = mesh_geometry(&bare).unwrap();
        assert_eq!(g.shading.vertex_tangents(0), None);
        assert_eq!(g.shading.normals(0), None, "mismatched counts are left out");
        assert_eq!(g.shading.uvs(0), None);
        assert!(g.shading.vertices().is_empty());
    }

    #[test]
    fn an_indexed_mesh_keeps_its_shading_by_vertex() {
        use bevy::math::primitives::Sphere;
        let mesh = Sphere::new(1.0).mesh().uv(32, 16);
        let g = mesh_geometry(&mesh).unwrap();
        let v = g.shading.vertices();
        assert_eq!(v.normals.len(), mesh.count_vertices());
        // Sixteen-bit corners where the vertices fit.
        assert_eq!(g.shading.corner_bytes(), 6 * g.triangles.len());
        assert!(g.shading.vertex_bytes().0 < 12 * g.triangles.len());
    }
}
