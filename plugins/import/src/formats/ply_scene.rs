//! PLY, the format scanners write (ASCII or binary): vertex positions, and normals and texture
//! coordinates when every vertex has them; polygons fan-triangulated in file order.

use crate::files::sandbox::open_regular;
use crate::scene::imported::{ImportedMaterial, ImportedMesh, ImportedScene, MeshGeometry};
use crate::types::budget::{Budget, ImportOptions};
use crate::types::error::{ImportError, MAX_ELEMENTS, check_indices, check_positions};
use glam::Mat4;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{DefaultElement, Property, PropertyAccess, PropertyAccessResult};
use std::io::BufReader;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// One vertex; which optional attributes it had is tracked so that partial ones are left out.
#[derive(Default)]
struct PlyVertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
    /// Bits 0-2: x, y, z; 3-5: nx, ny, nz; 6-7: u, v.
    seen: u8,
}

fn scalar(p: &Property) -> Option<f32> {
    Some(match *p {
        Property::Float(x) => x,
        Property::Double(x) => x as f32,
        Property::Char(x) => x as f32,
        Property::UChar(x) => x as f32,
        Property::Short(x) => x as f32,
        Property::UShort(x) => x as f32,
        Property::Int(x) => x as f32,
        Property::UInt(x) => x as f32,
        _ => return None,
    })
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let (slot, bit): (&mut f32, u8) = match name {
            "x" => (&mut self.position[0], 0),
            "y" => (&mut self.position[1], 1),
            "z" => (&mut self.position[2], 2),
            "nx" => (&mut self.normal[0], 3),
            "ny" => (&mut self.normal[1], 4),
            "nz" => (&mut self.normal[2], 5),
            "u" | "s" | "texture_u" => (&mut self.uv[0], 6),
            "v" | "t" | "texture_v" => (&mut self.uv[1], 7),
            _ => return PropertyAccessResult::Ignored,
        };
        let Some(value) = scalar(&property) else {
            return PropertyAccessResult::UnsupportedType;
        };
        *slot = value;
        self.seen |= 1 << bit;
        PropertyAccessResult::Set
    }
}

/// One polygon's vertex indices; `negative` when an index was below zero.
#[derive(Default)]
struct PlyFace {
    indices: Vec<u32>,
    negative: bool,
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if name != "vertex_indices" && name != "vertex_index" {
            return PropertyAccessResult::Ignored;
        }
        let mut push = |v: i64| {
            if v < 0 || v > u32::MAX as i64 {
                self.negative = true;
            } else {
                self.indices.push(v as u32);
            }
        };
        match property {
            Property::ListChar(l) => l.into_iter().for_each(|v| push(v as i64)),
            Property::ListUChar(l) => l.into_iter().for_each(|v| push(v as i64)),
            Property::ListShort(l) => l.into_iter().for_each(|v| push(v as i64)),
            Property::ListUShort(l) => l.into_iter().for_each(|v| push(v as i64)),
            Property::ListInt(l) => l.into_iter().for_each(|v| push(v as i64)),
            Property::ListUInt(l) => l.into_iter().for_each(|v| push(v as i64)),
            _ => return PropertyAccessResult::UnsupportedType,
        }
        PropertyAccessResult::Set
    }
}

/// Most bytes the parsed elements may take per byte of the file: an ASCII face `3 0 0 0` (8 bytes)
/// becomes a list of its own (about 48 bytes), and growing arrays double.
const BYTES_PER_FILE_BYTE: u64 = 16;

/// The fewest bytes one `element` takes in a file of `encoding`: a binary scalar its width, a
/// binary list its count's; in ASCII a character per property and the line's end.
fn least_bytes(element: &ply_rs_bw::ply::ElementDef, encoding: &ply_rs_bw::ply::Encoding) -> u64 {
    use ply_rs_bw::ply::{Encoding, PropertyType, ScalarType};
    let width = |t: &ScalarType| match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    match encoding {
        Encoding::Ascii => element.properties.len() as u64 * 2,
        _ => element
            .properties
            .values()
            .map(|p| match &p.data_type {
                PropertyType::Scalar(t) | PropertyType::List(t, _) => width(t),
            })
            .sum(),
    }
}

/// What one element read past (an edge, a material) takes in memory: a map of its properties by
/// name, each name a string of its own.
fn other_element_bytes(element: &ply_rs_bw::ply::ElementDef) -> usize {
    let entry = std::mem::size_of::<String>() + std::mem::size_of::<Property>() + 16;
    64 + element
        .properties
        .keys()
        .map(|k| entry + k.len())
        .sum::<usize>()
}

/// Loads a PLY file as one mesh named after the file, within the default memory budget.
pub fn load_ply(path: &Path) -> Result<ImportedScene, ImportError> {
    read_ply(path, &mut Budget::new(path, &ImportOptions::default()))
}

pub(crate) fn read_ply(path: &Path, budget: &mut Budget) -> Result<ImportedScene, ImportError> {
    let (file, file_len) = open_regular(path, path, "file")?;
    budget.charge(file_len.saturating_mul(BYTES_PER_FILE_BYTE), || {
        "reading its PLY elements".to_owned()
    })?;
    // Read no more than the length checked above, should the file grow meanwhile.
    let mut reader = Reader::new(BufReader::new(file.take(file_len)));
    let vertices_parser = Parser::<PlyVertex>::new();
    let faces_parser = Parser::<PlyFace>::new();
    let other_parser = Parser::<DefaultElement>::new();
    let header = vertices_parser
        .read_header(&mut reader)
        .map_err(|e| ImportError::new(path, format!("not a readable PLY header: {e}")))?;
    let mut vertices: Vec<PlyVertex> = Vec::new();
    let mut faces: Vec<PlyFace> = Vec::new();
    for (name, element) in &header.elements {
        // What each element takes in the file at least: a larger count is a lie, refused
        // before any reading. One without properties takes no bytes in a binary file, so only
        // the memory charged below bounds it.
        let least = least_bytes(element, &header.encoding);
        if element.count > MAX_ELEMENTS || (element.count as u64).saturating_mul(least) > file_len {
            return Err(ImportError::new(
                path,
                format!(
                    "the header declares {} '{name}' elements, more than the file can hold",
                    element.count
                ),
            ));
        }
        // What reading them allocates, charged before it is: one value per element whatever
        // the file spends on it (lists' entries are within the text's charge above).
        let each = match name.as_str() {
            "vertex" => std::mem::size_of::<PlyVertex>(),
            "face" => std::mem::size_of::<PlyFace>(),
            _ => other_element_bytes(element),
        };
        budget.charge_elements(element.count, each, || {
            format!("its {} '{name}' elements", element.count)
        })?;
        let read_error = |e: ply_rs_bw::parser::ParseError| {
            ImportError::new(path, format!("cannot read its {name} elements: {e}"))
        };
        match name.as_str() {
            "vertex" => {
                vertices = vertices_parser
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(read_error)?
            }
            "face" => {
                faces = faces_parser
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(read_error)?
            }
            // Other elements (edges, materials) are read past.
            _ => {
                other_parser
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(read_error)?;
            }
        }
    }
    if vertices.iter().any(|v| v.seen & 0b111 != 0b111) {
        return Err(ImportError::new(
            path,
            "some vertices lack an x, y or z coordinate",
        ));
    }
    if faces.is_empty() {
        return Err(ImportError::new(
            path,
            "the file has no faces (a point cloud cannot be traced)",
        ));
    }
    let name = path
        .file_stem()
        .map_or_else(|| "mesh".to_owned(), |s| s.to_string_lossy().into_owned());
    let corners: usize = faces
        .iter()
        .map(|f| f.indices.len().saturating_sub(2) * 3)
        .sum();
    budget.charge_elements(vertices.len(), 12 + 12 + 8, || {
        format!("mesh '{name}''s {} vertices", vertices.len())
    })?;
    budget.charge_elements(corners, 4, || format!("mesh '{name}''s {corners} indices"))?;
    let positions: Vec<[f32; 3]> = vertices.iter().map(|v| v.position).collect();
    check_positions(path, &name, &positions)?;
    let mut indices = Vec::new();
    let mut skipped = 0usize;
    for f in &faces {
        if f.negative {
            return Err(ImportError::new(
                path,
                format!("mesh '{name}' has a negative vertex index"),
            ));
        }
        if f.indices.len() < 3 {
            skipped += 1;
            continue;
        }
        for k in 1..f.indices.len() - 1 {
            indices.extend([f.indices[0], f.indices[k], f.indices[k + 1]]);
        }
    }
    check_indices(path, &name, &indices, positions.len())?;
    let all = |mask: u8| !vertices.is_empty() && vertices.iter().all(|v| v.seen & mask == mask);
    let normals = all(0b111000).then(|| vertices.iter().map(|v| v.normal).collect());
    let uvs = all(0b1100_0000).then(|| vertices.iter().map(|v| v.uv).collect());
    let mut warnings = Vec::new();
    if skipped > 0 {
        warnings.push(format!(
            "'{name}': {skipped} faces with fewer than 3 vertices, skipped"
        ));
    }
    Ok(ImportedScene {
        meshes: vec![ImportedMesh {
            name,
            transform: Mat4::IDENTITY,
            node: None,
            geometry: Arc::new(MeshGeometry {
                positions,
                normals,
                uvs,
                uvs1: None,
                tangents: None,
                indices,
            }),
            material: Some(0),
            same_as: None,
        }],
        nodes: Vec::new(),
        materials: vec![ImportedMaterial::default()],
        textures: Vec::new(),
        warnings,
    })
}
