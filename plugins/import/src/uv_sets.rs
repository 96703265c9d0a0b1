//! Which UV set a mesh's first slot holds. A path tracer keeps one set per triangle corner (its
//! records have room for no more), so a material that reads every map it traces through glTF's
//! `TEXCOORD_1` has its meshes' two sets exchanged on import, and its maps' `tex_coord`s with them:
//! the raster view reads the same texels through the same coordinates as before, and a consumer
//! that reads set 0 alone draws the material whole.

use crate::{ImportedMaterial, ImportedScene, TextureRef};
use std::collections::HashMap;
use std::sync::Arc;

/// The maps a path tracer reads for itself, with their roles' names. Occlusion is not among them:
/// a tracer traces the occlusion.
fn traced_maps(m: &ImportedMaterial) -> [(Option<TextureRef>, &'static str); 4] {
    [
        (m.base_color_texture, "base colour texture"),
        (m.metallic_roughness_texture, "metallic-roughness texture"),
        (m.normal_texture, "normal map"),
        (m.emissive_texture, "emission texture"),
    ]
}

/// Whether every map of `m` a tracer reads goes through set 1 (and there is one).
fn reads_second_set(m: &ImportedMaterial) -> bool {
    let sets: Vec<u32> = traced_maps(m)
        .iter()
        .filter_map(|(r, _)| r.map(|r| r.tex_coord))
        .collect();
    !sets.is_empty() && sets.iter().all(|&s| s == 1)
}

/// Exchanges sets 0 and 1 in the meshes of each material that reads its traced maps through set 1
/// alone, and in those materials' maps; warns of each material whose traced maps read both sets
/// (a set-0-only consumer draws it without its set-1 maps). Meshes that shared vertex data keep
/// sharing it where both are exchanged or neither is.
pub(crate) fn first_set_for_tracing(scene: &mut ImportedScene) {
    let exchanged: Vec<bool> = scene.materials.iter().map(reads_second_set).collect();
    for (m, &swap) in scene.materials.iter_mut().zip(&exchanged) {
        if swap {
            for r in [
                &mut m.base_color_texture,
                &mut m.metallic_roughness_texture,
                &mut m.normal_texture,
                &mut m.occlusion_texture,
                &mut m.emissive_texture,
            ]
            .into_iter()
            .flatten()
            {
                r.tex_coord = 1 - r.tex_coord;
            }
            continue;
        }
        let second: Vec<&str> = traced_maps(m)
            .iter()
            .filter(|(r, _)| r.is_some_and(|r| r.tex_coord == 1))
            .map(|(_, role)| *role)
            .collect();
        if !second.is_empty() {
            scene.warnings.push(format!(
                "material '{}' reads its {} through texture coordinate set 1 and other maps \
                 through set 0: the raster view draws them all, the path-traced view draws the \
                 material without its set-1 maps",
                m.name,
                second.join(" and ")
            ));
        }
    }
    if !exchanged.contains(&true) {
        return;
    }
    // One exchanged copy of each vertex data, made once however many meshes place it.
    let mut copies: HashMap<*const crate::MeshGeometry, Arc<crate::MeshGeometry>> = HashMap::new();
    let swapped: Vec<bool> = scene
        .meshes
        .iter()
        .map(|m| m.material.is_some_and(|k| exchanged[k]))
        .collect();
    for (mesh, &swap) in scene.meshes.iter_mut().zip(&swapped) {
        if swap {
            let copy = copies
                .entry(Arc::as_ptr(&mesh.geometry))
                .or_insert_with(|| {
                    let mut g = (*mesh.geometry).clone();
                    // The file's tangents were made for the set its normal map reads: they stay.
                    std::mem::swap(&mut g.uvs, &mut g.uvs1);
                    Arc::new(g)
                })
                .clone();
            mesh.geometry = copy;
        }
    }
    // A mesh shares its data with the first one of its kind that was exchanged alike (one pass: a
    // file may place one mesh a million times).
    let mut first: HashMap<(usize, bool), usize> = HashMap::new();
    for (i, (mesh, &swap)) in scene.meshes.iter_mut().zip(&swapped).enumerate() {
        let kind = (mesh.same_as.unwrap_or(i), swap);
        let earliest = *first.entry(kind).or_insert(i);
        mesh.same_as = (earliest != i).then_some(earliest);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ImportedMesh, MeshGeometry, UV_IDENTITY, WrapMode};
    use glam::Mat4;

    fn map(tex_coord: u32) -> Option<TextureRef> {
        Some(TextureRef {
            texture: 0,
            wrap: [WrapMode::Repeat; 2],
            uv_transform: UV_IDENTITY,
            tex_coord,
        })
    }

    /// Three placements of one vertex data: the first with a material on set 0, the others with
    /// one on set 1. The two on set 1 share one exchanged copy; the first keeps the file's.
    #[test]
    fn placements_share_what_was_exchanged_alike() {
        let geometry = Arc::new(MeshGeometry {
            positions: vec![[0.0; 3]; 3],
            uvs: Some(vec![[0.0, 0.0]; 3]),
            uvs1: Some(vec![[1.0, 1.0]; 3]),
            indices: vec![0, 1, 2],
            ..Default::default()
        });
        let mesh = |material, same_as| ImportedMesh {
            name: String::new(),
            transform: Mat4::IDENTITY,
            node: None,
            geometry: geometry.clone(),
            material: Some(material),
            same_as,
        };
        let mut scene = ImportedScene {
            materials: vec![
                ImportedMaterial {
                    base_color_texture: map(0),
                    ..Default::default()
                },
                ImportedMaterial {
                    base_color_texture: map(1),
                    normal_texture: map(1),
                    occlusion_texture: map(0),
                    ..Default::default()
                },
            ],
            meshes: vec![mesh(0, None), mesh(1, Some(0)), mesh(1, Some(0))],
            ..Default::default()
        };
        first_set_for_tracing(&mut scene);
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        let [a, b, c] = &scene.meshes[..] else {
            panic!()
        };
        assert!(Arc::ptr_eq(&a.geometry, &geometry));
        assert_eq!(b.geometry.uvs, geometry.uvs1);
        assert_eq!(b.geometry.uvs1, geometry.uvs);
        assert!(Arc::ptr_eq(&b.geometry, &c.geometry));
        assert_eq!((a.same_as, b.same_as, c.same_as), (None, None, Some(1)));
        let m = &scene.materials[1];
        let sets = [m.base_color_texture, m.normal_texture, m.occlusion_texture]
            .map(|r| r.map(|r| r.tex_coord));
        assert_eq!(sets, [Some(0), Some(0), Some(1)]);
        assert_eq!(scene.materials[0].base_color_texture, map(0));
    }
}
