//! A mesh asset's vertex data kept compressed while nothing reads it: meshoptimizer's lossless
//! vertex and index codecs, and smooth normals left out where Bevy's own computation gives them
//! back bit for bit (an imported file without normals). Parking takes the data out of the asset;
//! restoring puts back exactly what was taken.

use bevy::math::bounding::Aabb3d;
use bevy::mesh::{Indices, MeshVertexAttribute, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;

/// One attribute's values, encoded.
struct PackedAttribute {
    attribute: MeshVertexAttribute,
    /// Which of [`VertexAttributeValues`]' variants the values were.
    variant: Variant,
    count: usize,
    /// meshoptimizer's vertex codec over the values' bytes, a vertex at a time.
    bytes: Box<[u8]>,
}

/// A mesh's indices, encoded.
struct PackedIndices {
    /// Whether they were 32-bit.
    wide: bool,
    count: usize,
    /// meshoptimizer's triangle codec (a triangle list) or its sequence codec (anything else).
    bytes: Box<[u8]>,
    /// For the triangle codec, each triangle's turn back to its first corner, two bits a triangle
    /// (empty where none turned); `None` for the sequence codec.
    rotations: Option<Box<[u8]>>,
}

/// A mesh asset's attributes and indices, compressed losslessly ([`ParkedMesh::park`]).
pub struct ParkedMesh {
    attributes: Vec<PackedAttribute>,
    indices: Option<PackedIndices>,
    /// The normals were Bevy's smooth normals of the positions and indices, left out: computed
    /// again on restoring.
    smooth_normals: bool,
    vertices: usize,
    /// The asset's `final_aabb` before parking set it.
    bounds_before: Option<Aabb3d>,
}

macro_rules! variants {
    ($($name:ident: $t:ty),* $(,)?) => {
        /// The vertex formats parked: those whose vertex is a whole number of 4-byte words, as
        /// meshoptimizer's vertex codec takes them.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        enum Variant { $($name),* }

        /// `values` encoded, or `None` for a format not parked.
        fn encode(values: &VertexAttributeValues) -> Option<(Variant, usize, Vec<u8>)> {
            match values {
                $(VertexAttributeValues::$name(v) => Some((
                    Variant::$name,
                    v.len(),
                    meshopt::encoding::encode_vertex_buffer::<$t>(v).ok()?,
                )),)*
                _ => None,
            }
        }

        /// The values `encode` gave `bytes` for.
        fn decode(variant: Variant, count: usize, bytes: &[u8]) -> Option<VertexAttributeValues> {
            match variant {
                $(Variant::$name => meshopt::encoding::decode_vertex_buffer::<$t>(bytes, count)
                    .ok()
                    .map(VertexAttributeValues::$name),)*
            }
        }
    };
}

variants! {
    Float32: f32, Float32x2: [f32; 2], Float32x3: [f32; 3], Float32x4: [f32; 4],
    Uint32: u32, Uint32x2: [u32; 2], Uint32x3: [u32; 3], Uint32x4: [u32; 4],
    Sint32: i32, Sint32x2: [i32; 2], Sint32x3: [i32; 3], Sint32x4: [i32; 4],
    Uint16x2: [u16; 2], Uint16x4: [u16; 4], Unorm16x2: [u16; 2], Unorm16x4: [u16; 4],
    Sint16x2: [i16; 2], Sint16x4: [i16; 4], Snorm16x2: [i16; 2], Snorm16x4: [i16; 4],
    Uint8x4: [u8; 4], Unorm8x4: [u8; 4], Sint8x4: [i8; 4], Snorm8x4: [i8; 4],
}

impl ParkedMesh {
    /// Takes `mesh`'s attributes and indices out, compressed, and records its bounds in
    /// `final_aabb` (as a mesh whose data went to the render world keeps them, so Bevy's bounds of
    /// a new entity showing it are right). `None`, with the mesh untouched, for one that cannot be
    /// parked: no attributes in the main world, or a vertex format the codec does not take.
    /// Morph targets, if any, stay in the asset.
    pub fn park(mesh: &mut Mesh) -> Option<ParkedMesh> {
        let smooth_normals = normals_are_smooth(mesh);
        let attributes = mesh.try_attributes().ok()?;
        let mut vertices = 0;
        let mut packed = Vec::new();
        for (attribute, values) in attributes {
            if smooth_normals && attribute.id == Mesh::ATTRIBUTE_NORMAL.id {
                continue;
            }
            let (variant, count, bytes) = encode(values)?;
            vertices = count;
            packed.push(PackedAttribute {
                attribute: *attribute,
                variant,
                count,
                bytes: bytes.into_boxed_slice(),
            });
        }
        if packed.is_empty() {
            return None;
        }
        let triangles = mesh.primitive_topology() == PrimitiveTopology::TriangleList;
        let indices = match mesh.try_indices_option().ok()? {
            None => None,
            Some(indices) => Some(encode_indices(indices, vertices, triangles)?),
        };
        let bounds_before = mesh.final_aabb;
        let bounds = positions_bounds(mesh);
        for p in &packed {
            mesh.try_remove_attribute(p.attribute).ok()?;
        }
        if smooth_normals {
            mesh.try_remove_attribute(Mesh::ATTRIBUTE_NORMAL).ok()?;
        }
        mesh.try_remove_indices().ok()?;
        if bounds.is_some() {
            mesh.final_aabb = bounds;
        }
        Some(ParkedMesh {
            attributes: packed,
            indices,
            smooth_normals,
            vertices,
            bounds_before,
        })
    }

    /// Puts the parked data back into `mesh` (the asset it was taken from): each attribute and the
    /// indices, where the mesh has none of its own now. `false` if a part failed to decode (the
    /// rest is put back).
    pub fn restore(&self, mesh: &mut Mesh) -> bool {
        let mut whole = true;
        for p in &self.attributes {
            if mesh.try_contains_attribute(p.attribute.id).unwrap_or(true) {
                continue;
            }
            match decode(p.variant, p.count, &p.bytes) {
                Some(values) => {
                    whole &= mesh.try_insert_attribute(p.attribute, values).is_ok();
                }
                None => whole = false,
            }
        }
        if let Some(i) = &self.indices
            && matches!(mesh.try_indices_option(), Ok(None))
        {
            match decode_indices(i, self.vertices) {
                Some(indices) => whole &= mesh.try_insert_indices(indices).is_ok(),
                None => whole = false,
            }
        }
        if self.smooth_normals
            && !mesh
                .try_contains_attribute(Mesh::ATTRIBUTE_NORMAL)
                .unwrap_or(true)
        {
            whole &= mesh.try_compute_smooth_normals().is_ok();
        }
        mesh.final_aabb = self.bounds_before;
        whole
    }

    /// Forgets the parked data of `mesh`, whose asset has data of its own again: its bounds are
    /// Bevy's to compute once more.
    pub fn forget(self, mesh: &mut Mesh) {
        mesh.final_aabb = self.bounds_before;
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.attributes.iter().map(|p| p.bytes.len()).sum::<usize>()
            + self.indices.as_ref().map_or(0, |i| {
                i.bytes.len() + i.rotations.as_ref().map_or(0, |r| r.len())
            })
    }

    /// Triangles of the parked mesh (a triangle list's), as they were.
    pub fn triangles(&self) -> usize {
        match &self.indices {
            Some(i) => i.count / 3,
            None => self.vertices / 3,
        }
    }
}

fn encode_indices(indices: &Indices, vertices: usize, triangles: bool) -> Option<PackedIndices> {
    let wide: Vec<u32>;
    let all: &[u32] = match indices {
        Indices::U32(i) => i,
        Indices::U16(i) => {
            wide = i.iter().map(|&v| u32::from(v)).collect();
            &wide
        }
    };
    // The codecs read vertices by index: one out of range is not parked.
    if all.iter().any(|&v| v as usize >= vertices) {
        return None;
    }
    let wide = matches!(indices, Indices::U32(_));
    if triangles
        && all.len().is_multiple_of(3)
        && let Some(packed) = encode_triangles(all, vertices, wide)
    {
        return Some(packed);
    }
    let bytes = meshopt::encoding::encode_index_sequence(all, vertices).ok()?;
    Some(PackedIndices {
        wide,
        count: all.len(),
        bytes: bytes.into_boxed_slice(),
        rotations: None,
    })
}

/// A triangle list in meshoptimizer's triangle codec, which keeps the triangles' order and
/// winding but may start a triangle at another corner: each triangle's turn back is kept too (two
/// bits, and none at all where no triangle turned).
fn encode_triangles(all: &[u32], vertices: usize, wide: bool) -> Option<PackedIndices> {
    let bytes = meshopt::encoding::encode_index_buffer(all, vertices).ok()?;
    let decoded: Vec<u32> = meshopt::encoding::decode_index_buffer(&bytes, all.len()).ok()?;
    let mut rotations = vec![0u8; (all.len() / 3).div_ceil(4)];
    let mut turned = false;
    for (t, (was, now)) in all.chunks_exact(3).zip(decoded.chunks_exact(3)).enumerate() {
        let turn = (0..3u8).find(|&r| (0..3).all(|k| now[(k + r as usize) % 3] == was[k]))?;
        rotations[t / 4] |= turn << (2 * (t % 4));
        turned |= turn != 0;
    }
    Some(PackedIndices {
        wide,
        count: all.len(),
        bytes: bytes.into_boxed_slice(),
        rotations: Some(if turned {
            rotations.into_boxed_slice()
        } else {
            Box::default()
        }),
    })
}

fn decode_indices(i: &PackedIndices, vertices: usize) -> Option<Indices> {
    let mut all: Vec<u32> = match &i.rotations {
        Some(_) => meshopt::encoding::decode_index_buffer(&i.bytes, i.count).ok()?,
        None => meshopt::encoding::decode_index_sequence(&i.bytes, i.count).ok()?,
    };
    if let Some(rotations) = i.rotations.as_deref().filter(|r| !r.is_empty()) {
        for (t, tri) in all.chunks_exact_mut(3).enumerate() {
            let turn = rotations.get(t / 4).map_or(0, |b| (b >> (2 * (t % 4))) & 3) as usize;
            let now = [tri[0], tri[1], tri[2]];
            for (k, v) in tri.iter_mut().enumerate() {
                *v = now[(k + turn) % 3];
            }
        }
    }
    if all.iter().any(|&v| v as usize >= vertices) {
        return None;
    }
    Some(if i.wide {
        Indices::U32(all)
    } else {
        Indices::U16(all.into_iter().map(|v| v as u16).collect())
    })
}

/// Whether `mesh`'s normals are exactly what Bevy's smooth normals of its positions and indices
/// are (so they need not be kept).
fn normals_are_smooth(mesh: &Mesh) -> bool {
    let (
        Ok(Some(VertexAttributeValues::Float32x3(positions))),
        Ok(Some(VertexAttributeValues::Float32x3(normals))),
        Ok(Some(indices)),
    ) = (
        mesh.try_attribute_option(Mesh::ATTRIBUTE_POSITION),
        mesh.try_attribute_option(Mesh::ATTRIBUTE_NORMAL),
        mesh.try_indices_option(),
    )
    else {
        return false;
    };
    // Bevy's computation panics on these; they are checked first.
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList
        || !indices.len().is_multiple_of(3)
        || indices.iter().any(|v| v >= positions.len())
    {
        return false;
    }
    let mut scratch = Mesh::new(PrimitiveTopology::TriangleList, default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions.clone())
        .with_inserted_indices(indices.clone());
    if scratch.try_compute_smooth_normals().is_err() {
        return false;
    }
    matches!(
        scratch.try_attribute_option(Mesh::ATTRIBUTE_NORMAL),
        Ok(Some(VertexAttributeValues::Float32x3(computed)))
            if computed.len() == normals.len()
                && computed.iter().zip(normals).all(|(a, b)| {
                    a.map(f32::to_bits) == b.map(f32::to_bits)
                })
    )
}

/// The bounds of `mesh`'s positions, if it has any.
fn positions_bounds(mesh: &Mesh) -> Option<Aabb3d> {
    let Ok(Some(VertexAttributeValues::Float32x3(p))) =
        mesh.try_attribute_option(Mesh::ATTRIBUTE_POSITION)
    else {
        return None;
    };
    let mut it = p.iter().map(|&v| Vec3::from(v));
    let first = it.next()?;
    let (lo, hi) = it.fold((first, first), |(lo, hi), v| (lo.min(v), hi.max(v)));
    Some(Aabb3d::from_min_max(lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::asset::RenderAssetUsages;
    use treelight_test_support::Xorshift;

    /// A bumpy grid of `rows × rows × 2` triangles with random UVs, indexed.
    fn grid(rows: u32, rng: &mut Xorshift) -> Mesh {
        let n = rows + 1;
        let positions: Vec<[f32; 3]> = (0..n * n)
            .map(|k| {
                let (x, z) = ((k % n) as f32 / rows as f32, (k / n) as f32 / rows as f32);
                [x, 0.05 * (x * 17.0).sin() * (z * 13.0).cos(), z]
            })
            .collect();
        let uvs: Vec<[f32; 2]> = (0..n * n).map(|_| [rng.unit(), rng.unit()]).collect();
        let mut indices = Vec::new();
        for j in 0..rows {
            for i in 0..rows {
                let a = j * n + i;
                indices.extend([a, a + 1, a + n, a + 1, a + n + 1, a + n]);
            }
        }
        Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::MAIN_WORLD,
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
        .with_inserted_indices(Indices::U32(indices))
    }

    type Contents = (
        Vec<(bevy::mesh::MeshVertexAttributeId, Vec<u8>)>,
        Option<Vec<u32>>,
        Option<Aabb3d>,
    );

    /// Every attribute's bytes, the indices, and the bounds Bevy computes.
    fn contents(mesh: &Mesh) -> Contents {
        let attributes = mesh
            .try_attributes()
            .unwrap()
            .map(|(a, v)| (a.id, v.get_bytes().to_vec()))
            .collect();
        let indices = mesh.indices().map(|i| i.iter().map(|v| v as u32).collect());
        (attributes, indices, mesh.final_aabb)
    }

    /// Asserts `a` is `b`, naming the first part that differs (the arrays are long to print).
    fn same(a: &Contents, b: &Contents) {
        let ids = |c: &Contents| c.0.iter().map(|(id, _)| *id).collect::<Vec<_>>();
        assert_eq!(ids(a), ids(b), "the attributes");
        for ((id, x), (_, y)) in a.0.iter().zip(&b.0) {
            let at = x.iter().zip(y).position(|(p, q)| p != q);
            assert!(
                x.len() == y.len() && at.is_none(),
                "{id:?}: {} / {} bytes, first difference at {at:?}",
                x.len(),
                y.len()
            );
        }
        assert!(
            a.1 == b.1,
            "the indices: {:?} / {:?}",
            a.1.as_ref().map(Vec::len),
            b.1.as_ref().map(Vec::len)
        );
        assert_eq!(a.2, b.2, "the bounds");
    }

    fn round_trip(mut mesh: Mesh) -> (ParkedMesh, Mesh) {
        let before = contents(&mesh);
        let parked = ParkedMesh::park(&mut mesh).expect("parked");
        assert!(
            !mesh
                .try_contains_attribute(Mesh::ATTRIBUTE_POSITION)
                .unwrap()
        );
        assert!(mesh.try_indices_option().unwrap().is_none());
        assert!(parked.restore(&mut mesh));
        same(&contents(&mesh), &before);
        (parked, mesh)
    }

    #[test]
    fn smooth_normals_are_left_out_and_come_back_bit_for_bit() {
        let mut rng = Xorshift(11);
        let mut mesh = grid(100, &mut rng);
        mesh.compute_smooth_normals();
        let raw = 101 * 101 * (12 + 12 + 8) + 6 * 100 * 100 * 4;
        let (parked, _) = round_trip(mesh);
        assert!(parked.smooth_normals);
        assert_eq!(parked.triangles(), 20_000);
        // Positions and indices compress well; the random UVs do not.
        assert!(parked.bytes() < raw / 2, "{} of {raw}", parked.bytes());
    }

    #[test]
    fn other_normals_tangents_and_narrow_indices_are_kept_exactly() {
        let mut rng = Xorshift(3);
        for rows in [1, 2, 7, 40] {
            let mut mesh = grid(rows, &mut rng);
            let count = ((rows + 1) * (rows + 1)) as usize;
            let normals: Vec<[f32; 3]> = (0..count)
                .map(|_| [rng.range(-1.0, 1.0), 1.0, rng.range(-1.0, 1.0)])
                .collect();
            let tangents: Vec<[f32; 4]> =
                (0..count).map(|_| [1.0, 0.0, rng.unit(), -1.0]).collect();
            mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
            mesh.insert_attribute(Mesh::ATTRIBUTE_TANGENT, tangents);
            let narrow: Vec<u16> = mesh.indices().unwrap().iter().map(|v| v as u16).collect();
            mesh.insert_indices(Indices::U16(narrow));
            let (parked, back) = round_trip(mesh);
            assert!(!parked.smooth_normals);
            assert!(matches!(back.indices(), Some(Indices::U16(_))));
        }
    }

    #[test]
    fn random_triangle_lists_come_back_corner_for_corner() {
        let mut rng = Xorshift(17);
        for case in 0..60 {
            let vertices = 3 + rng.below(300);
            let triangles = rng.below(400);
            // Random corners, with degenerate triangles (a corner twice) and repeats of a triangle
            // turned, which the triangle codec may start at another corner.
            let mut indices: Vec<u32> = Vec::new();
            for _ in 0..triangles {
                let mut t = [0u32; 3].map(|_| rng.below(vertices) as u32);
                if rng.below(8) == 0 {
                    t[2] = t[0];
                }
                indices.extend(t);
                if rng.below(4) == 0 {
                    indices.extend([t[1], t[2], t[0]]);
                }
            }
            let positions: Vec<[f32; 3]> = (0..vertices)
                .map(|_| [rng.unit(), rng.unit(), rng.unit()])
                .collect();
            let mesh = Mesh::new(
                PrimitiveTopology::TriangleList,
                RenderAssetUsages::MAIN_WORLD,
            )
            .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
            .with_inserted_indices(if case % 2 == 0 {
                Indices::U32(indices)
            } else {
                Indices::U16(indices.iter().map(|&v| v as u16).collect())
            });
            round_trip(mesh);
        }
    }

    #[test]
    fn a_mesh_without_indices_and_its_bounds_while_parked() {
        let mut mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::MAIN_WORLD,
        )
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_POSITION,
            vec![[0.0, 0.0, 0.0], [2.0, -1.0, 0.5], [0.0, 3.0, -4.0]],
        );
        let before = contents(&mesh);
        let parked = ParkedMesh::park(&mut mesh).unwrap();
        assert_eq!(parked.triangles(), 1);
        // Bevy's bounds of a new entity showing it are the positions' while parked.
        assert_eq!(
            mesh.final_aabb,
            Some(Aabb3d::from_min_max([0.0, -1.0, -4.0], [2.0, 3.0, 0.5]))
        );
        assert!(parked.restore(&mut mesh));
        same(&contents(&mesh), &before);
    }

    #[test]
    fn what_the_codec_does_not_take_is_left_alone() {
        let mut rng = Xorshift(5);
        // A two-byte vertex format.
        let mut mesh = grid(3, &mut rng).with_inserted_attribute(
            MeshVertexAttribute::new("Bytes", 988_540_917, bevy::mesh::VertexFormat::Uint8x2),
            VertexAttributeValues::Uint8x2(vec![[1u8, 2u8]; 16]),
        );
        let before = contents(&mesh);
        assert!(ParkedMesh::park(&mut mesh).is_none());
        same(&contents(&mesh), &before);
        // An index past the vertices.
        let mut mesh = grid(3, &mut rng);
        mesh.insert_indices(Indices::U32(vec![0, 1, 16]));
        let before = contents(&mesh);
        assert!(ParkedMesh::park(&mut mesh).is_none());
        same(&contents(&mesh), &before);
        // Nothing in the main world.
        let mut empty = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::MAIN_WORLD,
        );
        assert!(ParkedMesh::park(&mut empty).is_none());
    }

    #[test]
    fn what_the_asset_has_of_its_own_again_is_kept() {
        let mut rng = Xorshift(9);
        let mut mesh = grid(4, &mut rng);
        let parked = ParkedMesh::park(&mut mesh).unwrap();
        let own = vec![[5.0f32, 5.0, 5.0]; 25];
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, own.clone());
        assert!(parked.restore(&mut mesh));
        assert_eq!(
            mesh.attribute(Mesh::ATTRIBUTE_POSITION),
            Some(&VertexAttributeValues::Float32x3(own))
        );
        assert!(mesh.contains_attribute(Mesh::ATTRIBUTE_UV_0));
        assert_eq!(mesh.indices().map(Indices::len), Some(96));
    }
}
