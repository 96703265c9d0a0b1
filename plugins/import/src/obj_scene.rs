//! OBJ through tobj, polygons fan-triangulated in file order.

use crate::{
    ImportError, ImportedMaterial, ImportedMesh, ImportedScene, check_indices, check_positions,
};
use glam::Mat4;
use std::path::Path;

/// Loads an OBJ file. Materials from .mtl files are not read (only the geometry is).
pub fn load_obj(path: &Path) -> Result<ImportedScene, ImportError> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let file = std::fs::File::open(path).map_err(|e| ImportError::new(path, e.to_string()))?;
    let mut reader = std::io::BufReader::new(file);
    // Material libraries are ignored so that no other file is opened.
    let (models, _) = tobj::load_obj_buf(&mut reader, &options, |_| Ok(Default::default()))
        .map_err(|e| ImportError::new(path, format!("not a readable OBJ file: {e}")))?;
    let mut scene = ImportedScene {
        materials: vec![ImportedMaterial::default()],
        ..Default::default()
    };
    for m in models {
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
            positions,
            normals,
            uvs,
            indices: m.mesh.indices,
            material: Some(0),
            same_as: None,
        });
    }
    Ok(scene)
}
