//! The triangles' shading on the GPU: a 12-byte record per triangle naming its three corners in a
//! pool of shading vertices (normal, tangent, UV; a second record holds the second UV set where a
//! material reads it), so that a mesh's vertices are uploaded once however many triangles share
//! them. Each mesh's vertices take one run of the pool (`vertex_pool.rs`). A triangle's group is not
//! in its record: the first corner of its position record names it
//! ([`GpuPosition`](treelight_bvh::GpuPosition)).

use bevy::math::{Vec2, Vec3, Vec4};
use bytemuck::{Pod, Zeroable};
use treelight_scene::ShadingVertices;
use treelight_scene::packed::{encode_normal, encode_tangent};

/// Bytes of one triangle's shading record.
pub const ATTRIBUTE_BYTES: u64 = size_of::<GpuAttribute>() as u64;
/// Bytes of one record of the shading vertices' pool.
pub const SHADING_VERTEX_BYTES: u64 = size_of::<GpuShadingVertex>() as u64;

/// Bit 31 of each of a shading record's corners, a flag apiece: on the first, the corners name
/// vertices (without, the triangle has no shading data: flat, no UVs); on the second, the vertices
/// have normals; on the third, each takes two records of the pool, the second holding the second
/// UV set.
const FLAG: u32 = 0x8000_0000;
/// The records of the shading vertices' pool a corner can name: those below its flag's bit.
pub const MAX_SHADING_VERTEX_RECORDS: u32 = FLAG;

/// `ShadingRecord` of `pathtrace.wgsl`: one triangle's shading.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuAttribute {
    /// The pool records of the triangle's three corners (each its first record), each with a flag
    /// in bit 31 ([`GpuAttribute::names_vertices`], [`GpuAttribute::has_normals`],
    /// [`GpuAttribute::has_two_uv_sets`]).
    pub corners: [u32; 3],
}

impl GpuAttribute {
    /// Whether the corners name vertices of the pool (without, the triangle is flat, without UVs).
    pub fn names_vertices(&self) -> bool {
        self.corners[0] & FLAG != 0
    }

    /// Whether the vertices have normals.
    pub fn has_normals(&self) -> bool {
        self.corners[1] & FLAG != 0
    }

    /// Whether each corner takes two records, the second holding the second UV set.
    pub fn has_two_uv_sets(&self) -> bool {
        self.corners[2] & FLAG != 0
    }

    /// The first pool record of each corner, without the flags.
    pub fn vertex_records(&self) -> [u32; 3] {
        self.corners.map(|c| c & !FLAG)
    }
}

/// `ShadingVertex` of `pathtrace.wgsl`: one vertex's shading, or (the second record of a vertex
/// with two UV sets) its second set in `uv`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuShadingVertex {
    /// Object-space normal, octahedral ([`encode_normal`]); zero without.
    pub normal: u32,
    /// Object-space tangent and the bitangent's sign ([`encode_tangent`]); zero without (the
    /// kernel then makes one per triangle from its UVs).
    pub tangent: u32,
    /// `UV_0`, or `UV_1` in a second record.
    pub uv: [f32; 2],
}

/// How a mesh's vertices are laid out in the pool.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct VertexLayout {
    /// Whether they have normals.
    pub normals: bool,
    /// Whether each takes a second record for its second UV set.
    pub two_uv_sets: bool,
}

impl VertexLayout {
    /// The layout of `vertices`, with their second UV set where a material reads it.
    pub fn of(vertices: &ShadingVertices, second_set_read: bool) -> Self {
        Self {
            normals: !vertices.normals.is_empty(),
            two_uv_sets: second_set_read && !vertices.uvs1.is_empty(),
        }
    }

    /// Pool records a vertex takes.
    pub fn stride(self) -> u32 {
        if self.two_uv_sets { 2 } else { 1 }
    }
}

/// The pool records of vertex `i` of `vertices`: the first, and the second that holds its second
/// UV set (written only under a layout with two sets).
pub fn vertex_records(vertices: &ShadingVertices, i: usize) -> [GpuShadingVertex; 2] {
    let first = GpuShadingVertex {
        normal: vertices.normals.get(i).copied().unwrap_or(0),
        tangent: vertices.tangents.get(i).copied().unwrap_or(0),
        uv: vertices
            .uvs
            .get(i)
            .copied()
            .unwrap_or(Vec2::ZERO)
            .to_array(),
    };
    let second = GpuShadingVertex {
        uv: vertices
            .uvs1
            .get(i)
            .copied()
            .unwrap_or(Vec2::ZERO)
            .to_array(),
        ..Default::default()
    };
    [first, second]
}

/// A triangle's shading record: its corners `corners` (vertex numbers of a mesh whose vertices
/// begin at pool record `first`, laid out as `layout` says), or none. The corners' records must lie
/// below [`MAX_SHADING_VERTEX_RECORDS`] (the pool keeps its runs there).
pub fn shading_record(first: u32, corners: Option<[u32; 3]>, layout: VertexLayout) -> GpuAttribute {
    let Some(corners) = corners else {
        return GpuAttribute::default();
    };
    let [a, b, c] = corners.map(|c| first + c * layout.stride());
    let flag = |on: bool| if on { FLAG } else { 0 };
    GpuAttribute {
        corners: [
            a | FLAG,
            b | flag(layout.normals),
            c | flag(layout.two_uv_sets),
        ],
    }
}

/// One triangle's shading given corner by corner, as the GPU tests and tools make it: its corner
/// normals (none: flat), UVs, tangents and second UV set.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CornerShading {
    /// Corner normals, packed ([`encode_normal`]).
    pub normals: Option<[u32; 3]>,
    /// Corner `UV_0`s.
    pub uvs: [Vec2; 3],
    /// Corner tangents, packed by vertex ([`encode_tangent`]).
    pub tangents: Option<[u32; 3]>,
    /// Corner `UV_1`s.
    pub uvs1: Option<[Vec2; 3]>,
}

/// A triangle's shading from its corner normals (none: flat shading) and UVs (none: zero).
pub fn attribute_record(normals: Option<[Vec3; 3]>, uvs: Option<[Vec2; 3]>) -> CornerShading {
    CornerShading {
        normals: normals.map(|n| n.map(encode_normal)),
        uvs: uvs.unwrap_or([Vec2::ZERO; 3]),
        tangents: None,
        uvs1: None,
    }
}

impl CornerShading {
    /// With its corners' tangents (xyz and the bitangent's sign in w, glTF's convention), or
    /// without any.
    pub fn with_tangents(mut self, tangents: Option<[Vec4; 3]>) -> Self {
        self.tangents = tangents.map(|t| t.map(encode_tangent));
        self
    }

    /// With a second UV set, for a material whose maps read both.
    pub fn with_second_uv_set(mut self, uvs1: [Vec2; 3]) -> Self {
        self.uvs1 = Some(uvs1);
        self
    }
}

/// The two buffers of the triangles' shading, for triangles given corner by corner
/// ([`ShadingBuffers::put`]): each triangle's corners get vertices of their own.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadingBuffers {
    /// The triangles' records, by triangle id (zero where none was put).
    pub attributes: Vec<u8>,
    /// The pool of shading vertices.
    pub vertices: Vec<u8>,
}

impl ShadingBuffers {
    /// Sets triangle `id`'s shading to `s`.
    pub fn put(&mut self, id: u32, s: &CornerShading) {
        let vertices = ShadingVertices {
            normals: s.normals.map_or_else(Vec::new, |n| n.to_vec()),
            uvs: s.uvs.to_vec(),
            uvs1: s.uvs1.map_or_else(Vec::new, |u| u.to_vec()),
            tangents: s.tangents.map_or_else(Vec::new, |t| t.to_vec()),
        };
        let layout = VertexLayout::of(&vertices, s.uvs1.is_some());
        let first = (self.vertices.len() as u64 / SHADING_VERTEX_BYTES) as u32;
        // Flat and without UVs: a record naming no vertices reads the same.
        let corners = (*s != CornerShading::default()).then_some([0, 1, 2]);
        if corners.is_some() {
            for i in 0..3 {
                let records = vertex_records(&vertices, i);
                for r in &records[..layout.stride() as usize] {
                    self.vertices.extend_from_slice(bytemuck::bytes_of(r));
                }
            }
        }
        let record = shading_record(first, corners, layout);
        let at = id as usize * ATTRIBUTE_BYTES as usize;
        let end = at + ATTRIBUTE_BYTES as usize;
        if self.attributes.len() < end {
            self.attributes.resize(end, 0);
        }
        self.attributes[at..end].copy_from_slice(bytemuck::bytes_of(&record));
    }

    /// Room for the records of triangle ids below `capacity` (zero until put).
    pub fn reserve_triangles(&mut self, capacity: u32) {
        let need = capacity as usize * ATTRIBUTE_BYTES as usize;
        if self.attributes.len() < need {
            self.attributes.resize(need, 0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_names_its_corners_by_the_layout() {
        let v = ShadingVertices {
            normals: vec![1, 2, 3, 4],
            uvs: vec![Vec2::ONE; 4],
            uvs1: vec![Vec2::new(0.5, 0.25); 4],
            tangents: Vec::new(),
        };
        let one = VertexLayout::of(&v, false);
        let two = VertexLayout::of(&v, true);
        assert_eq!((one.stride(), two.stride()), (1, 2));
        let r = shading_record(100, Some([0, 3, 2]), two);
        assert_eq!(r.vertex_records(), [100, 106, 104]);
        assert!(r.names_vertices() && r.has_normals() && r.has_two_uv_sets());
        let r = shading_record(100, Some([0, 3, 2]), one);
        assert_eq!(r.vertex_records(), [100, 103, 102]);
        assert!(r.names_vertices() && r.has_normals() && !r.has_two_uv_sets());
        let bare = VertexLayout::default();
        let r = shading_record(100, Some([0, 3, 2]), bare);
        assert!(r.names_vertices() && !r.has_normals() && !r.has_two_uv_sets());
        let flat = shading_record(100, None, one);
        assert_eq!(flat, GpuAttribute::default(), "no flag without vertices");
        assert!(!flat.names_vertices() && !flat.has_normals());
        let [a, b] = vertex_records(&v, 3);
        assert_eq!((a.normal, a.uv, b.uv), (4, [1.0, 1.0], [0.5, 0.25]));
        assert_eq!(v.len(), 4);
        assert_eq!(ShadingVertices::default().len(), 0);
    }

    #[test]
    fn corners_given_one_by_one_get_vertices_of_their_own() {
        let mut b = ShadingBuffers::default();
        let n = [Vec3::X, Vec3::Y, Vec3::Z];
        b.put(2, &attribute_record(Some(n), None));
        b.put(1, &attribute_record(None, None));
        b.put(
            0,
            &attribute_record(None, Some([Vec2::ONE; 3])).with_second_uv_set([Vec2::ZERO; 3]),
        );
        assert_eq!(b.attributes.len() as u64, 3 * ATTRIBUTE_BYTES);
        assert_eq!(b.vertices.len() as u64, 9 * SHADING_VERTEX_BYTES);
        let records: Vec<GpuAttribute> = bytemuck::pod_collect_to_vec(&b.attributes);
        assert_eq!(records[2].vertex_records(), [0, 1, 2]);
        assert!(records[2].has_normals() && !records[2].has_two_uv_sets());
        assert_eq!(records[0].vertex_records(), [3, 5, 7]);
        assert!(records[0].names_vertices() && records[0].has_two_uv_sets());
        assert!(!records[0].has_normals());
        assert!(!records[1].names_vertices(), "flat, no UVs: no vertices");
        let vertices: Vec<GpuShadingVertex> = bytemuck::pod_collect_to_vec(&b.vertices);
        assert_eq!(vertices[1].normal, encode_normal(Vec3::Y));
    }
}
