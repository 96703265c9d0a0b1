//! OBJ through tobj, polygons fan-triangulated in file order.

use crate::files::sandbox::open_regular;
use crate::scene::imported::{ImportedMaterial, ImportedMesh, ImportedScene, MeshGeometry};
use crate::types::budget::{Budget, ImportOptions};
use crate::types::error::{ImportError, check_indices, check_positions};
use glam::Mat4;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// Most bytes tobj's arrays may take per byte of OBJ text: a corner (`1/1/1 `, 6 bytes) can make a
/// vertex of 32 bytes and 4 of index, and growing arrays double.
const BYTES_PER_TEXT_BYTE: u64 = 16;

/// Most bytes tobj keeps for one face, line or point element beside its text: the element (three
/// corners of three indices), its vector's growth, and the triangles it makes.
const BYTES_PER_ELEMENT: u64 = 160;

/// The face, line and point elements of the OBJ text in `file` (its first `len` bytes), read
/// through once; the file is left at its start.
fn count_elements(mut file: &std::fs::File, len: u64) -> std::io::Result<u64> {
    use std::io::{BufRead, Seek};
    let mut reader = std::io::BufReader::with_capacity(1 << 16, file.take(len));
    // Whether nothing but white space has come since the line began.
    let (mut count, mut at_line_start) = (0u64, true);
    loop {
        let buf = reader.fill_buf()?;
        if buf.is_empty() {
            break;
        }
        for &b in buf {
            if b == b'\n' {
                at_line_start = true;
            } else if at_line_start && !b.is_ascii_whitespace() {
                count += u64::from(matches!(b, b'f' | b'l' | b'p'));
                at_line_start = false;
            }
        }
        let n = buf.len();
        reader.consume(n);
    }
    drop(reader);
    file.rewind()?;
    Ok(count)
}

/// Loads an OBJ file within the default memory budget. Materials from .mtl files are not read
/// (only the geometry is).
pub fn load_obj(path: &Path) -> Result<ImportedScene, ImportError> {
    read_obj(path, &mut Budget::new(path, &ImportOptions::default()))
}

pub(crate) fn read_obj(path: &Path, budget: &mut Budget) -> Result<ImportedScene, ImportError> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (file, len) = open_regular(path, path, "file")?;
    // Each face (or line, or point) tobj keeps as an element of its own, however short its text
    // (`f 1` is 4 bytes): counted in a first pass, charged before any is parsed.
    let elements = count_elements(&file, len)
        .map_err(|e| ImportError::new(path, format!("cannot read it: {e}")))?;
    budget.charge(
        len.saturating_mul(BYTES_PER_TEXT_BYTE)
            .saturating_add(elements.saturating_mul(BYTES_PER_ELEMENT)),
        || format!("reading its OBJ text ({elements} faces, lines and points)"),
    )?;
    // Read no more than the length checked above, should the file grow meanwhile.
    let mut reader = std::io::BufReader::new(file.take(len));
    // Material libraries are ignored so that no other file is opened.
    let (models, _) = tobj::load_obj_buf(&mut reader, &options, |_| Ok(Default::default()))
        .map_err(|e| ImportError::new(path, format!("not a readable OBJ file: {e}")))?;
    let mut scene = ImportedScene {
        materials: vec![ImportedMaterial::default()],
        ..Default::default()
    };
    for m in models {
        budget.charge_elements(m.mesh.positions.len(), 12, || {
            format!("object '{}'", m.name)
        })?;
        let positions: Vec<[f32; 3]> = m
            .mesh
            .positions
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect();
        check_positions(path, &m.name, &positions)?;
        check_indices(path, &m.name, &m.mesh.indices, positions.len())?;
        let normals = (m.mesh.normals.len() == m.mesh.positions.len()).then(|| {
            m.mesh
                .normals
                .chunks_exact(3)
                .map(|p| [p[0], p[1], p[2]])
                .collect()
        });
        let uvs =
            (m.mesh.texcoords.len() / 2 == positions.len() && !positions.is_empty()).then(|| {
                m.mesh
                    .texcoords
                    .chunks_exact(2)
                    .map(|p| [p[0], p[1]])
                    .collect()
            });
        if m.mesh.indices.is_empty() {
            scene
                .warnings
                .push(format!("object '{}' has no faces, skipped", m.name));
            continue;
        }
        scene.meshes.push(ImportedMesh {
            name: m.name,
            transform: Mat4::IDENTITY,
            node: None,
            geometry: Arc::new(MeshGeometry {
                positions,
                normals,
                uvs,
                uvs1: None,
                tangents: None,
                indices: m.mesh.indices,
            }),
            material: Some(0),
            same_as: None,
        });
    }
    Ok(scene)
}
