//! OBJ through tobj, polygons fan-triangulated in file order.

use crate::budget::{Budget, ImportOptions};
use crate::sandbox::open_regular;
use crate::{
    ImportError, ImportedMaterial, ImportedMesh, ImportedScene, MeshGeometry, check_indices,
    check_positions,
};
use glam::Mat4;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// Most bytes tobj's arrays may take per byte of OBJ text: a corner (`1/1/1 `, 6 bytes) can make a
/// vertex of 32 bytes and 4 of index, and growing arrays double.
const BYTES_PER_TEXT_BYTE: u64 = 16;

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
    budget.charge(len.saturating_mul(BYTES_PER_TEXT_BYTE), || {
        "reading its OBJ text".to_owned()
    })?;
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
