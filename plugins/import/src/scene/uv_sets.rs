//! Which UV set a mesh's first slot holds, and whether it keeps a second. A path tracer's shading
//! record holds one set at full precision with the mesh's corner tangents, or two sets more
//! tightly without them, so a material that reads every map but its occlusion through glTF's
//! `TEXCOORD_1` has its meshes' two sets exchanged on import, and its maps' `tex_coord`s with them:
//! the raster view reads the same texels through the same coordinates as before, and a consumer
//! that reads set 0 alone draws the material whole. A mesh no map reads the second set of drops it:
//! neither view would read it, and every copy of it costs memory.

use crate::scene::imported::{ImportedMaterial, ImportedScene};

use crate::scene::texture::TextureRef;
use std::collections::HashMap;
use std::sync::Arc;

/// The maps a material reads the mesh's most detailed set through. Occlusion is not among them:
/// it is often baked through a set of its own.
fn detail_maps(m: &ImportedMaterial) -> [Option<TextureRef>; 4] {
    [
        m.base_color_texture,
        m.metallic_roughness_texture,
        m.normal_texture,
        m.emissive_texture,
    ]
}

/// Whether every detail map of `m` goes through set 1 (and there is one).
fn reads_second_set(m: &ImportedMaterial) -> bool {
    let sets: Vec<u32> = detail_maps(m)
        .iter()
        .filter_map(|r| r.map(|r| r.tex_coord))
        .collect();
    !sets.is_empty() && sets.iter().all(|&s| s == 1)
}

/// Whether any map of `m` reads set 1.
fn reads_set_one(m: &ImportedMaterial) -> bool {
    m.maps().iter().flatten().any(|r| r.tex_coord == 1)
}

/// Exchanges sets 0 and 1 in the meshes of each material that reads its detail maps through set 1
/// alone, and in those materials' maps; then drops the second set of vertex data no map reads it
/// of. Meshes that shared vertex data keep sharing it where both are changed alike.
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
        }
    }
    exchange_sets(scene, &exchanged);
    drop_unread_second_sets(scene);
}

/// Exchanges the two sets of the meshes whose material `exchanged` says.
fn exchange_sets(scene: &mut ImportedScene, exchanged: &[bool]) {
    if !exchanged.contains(&true) {
        return;
    }
    // One exchanged copy of each vertex data, made once however many meshes place it.
    let mut copies: HashMap<
        *const crate::scene::imported::MeshGeometry,
        Arc<crate::scene::imported::MeshGeometry>,
    > = HashMap::new();
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

/// Drops the second UV set of each vertex data that no mesh placing it reads through a map.
fn drop_unread_second_sets(scene: &mut ImportedScene) {
    let mut read: HashMap<*const crate::scene::imported::MeshGeometry, bool> = HashMap::new();
    for mesh in &scene.meshes {
        let reads = mesh
            .material
            .and_then(|k| scene.materials.get(k))
            .is_some_and(reads_set_one);
        *read.entry(Arc::as_ptr(&mesh.geometry)).or_default() |= reads;
    }
    // Each vertex data taken out of its meshes first, so that it is changed in place, not copied.
    let mut taken: HashMap<
        *const crate::scene::imported::MeshGeometry,
        (Arc<crate::scene::imported::MeshGeometry>, Vec<usize>),
    > = HashMap::new();
    for (i, mesh) in scene.meshes.iter_mut().enumerate() {
        let key = Arc::as_ptr(&mesh.geometry);
        if mesh.geometry.uvs1.is_none() || read.get(&key) == Some(&true) {
            continue;
        }
        let geometry = std::mem::take(&mut mesh.geometry);
        taken
            .entry(key)
            .or_insert_with(|| (geometry, Vec::new()))
            .1
            .push(i);
    }
    for (_, (mut geometry, meshes)) in taken {
        Arc::make_mut(&mut geometry).uvs1 = None;
        for i in meshes {
            scene.meshes[i].geometry = geometry.clone();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::imported::{ImportedMesh, MeshGeometry};
    use crate::scene::texture::{UV_IDENTITY, WrapMode};
    use glam::Mat4;

    /// `geometry` placed at the origin with material `material`.
    fn placed(
        geometry: &Arc<MeshGeometry>,
        material: usize,
        same_as: Option<usize>,
    ) -> ImportedMesh {
        ImportedMesh {
            name: String::new(),
            transform: Mat4::IDENTITY,
            node: None,
            geometry: geometry.clone(),
            material: Some(material),
            same_as,
        }
    }

    fn map(tex_coord: u32) -> Option<TextureRef> {
        Some(TextureRef {
            texture: 0,
            wrap: [WrapMode::Repeat; 2],
            uv_transform: UV_IDENTITY,
            tex_coord,
        })
    }

    /// Three placements of one vertex data: the first with a material on set 0, the others with
    /// one on set 1. The two on set 1 share one exchanged copy; the first keeps the file's first
    /// set alone.
    #[test]
    fn placements_share_what_was_exchanged_alike() {
        let geometry = Arc::new(MeshGeometry {
            positions: vec![[0.0; 3]; 3],
            uvs: Some(vec![[0.0, 0.0]; 3]),
            uvs1: Some(vec![[1.0, 1.0]; 3]),
            indices: vec![0, 1, 2],
            ..Default::default()
        });
        let mesh = |material, same_as| placed(&geometry, material, same_as);
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
        // The first reads no map through set 1: its data keeps set 0 alone.
        assert_eq!((&a.geometry.uvs, &a.geometry.uvs1), (&geometry.uvs, &None));
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

    /// A second set that one placement's material reads stays for every placement of that data;
    /// one no placement reads is dropped from each, the placements still sharing one copy.
    #[test]
    fn a_second_set_stays_where_a_map_reads_it() {
        let data = || {
            Arc::new(MeshGeometry {
                positions: vec![[0.0; 3]; 3],
                uvs: Some(vec![[0.0, 0.0]; 3]),
                uvs1: Some(vec![[1.0, 1.0]; 3]),
                indices: vec![0, 1, 2],
                ..Default::default()
            })
        };
        let (read, unread) = (data(), data());
        let mesh = |geometry, material| placed(geometry, material, None);
        let mut scene = ImportedScene {
            materials: vec![
                ImportedMaterial {
                    base_color_texture: map(0),
                    ..Default::default()
                },
                // Occlusion baked through set 1: a mixed material, traced through both sets.
                ImportedMaterial {
                    base_color_texture: map(0),
                    occlusion_texture: map(1),
                    ..Default::default()
                },
            ],
            meshes: vec![
                mesh(&read, 0),
                mesh(&read, 1),
                mesh(&unread, 0),
                mesh(&unread, 0),
            ],
            ..Default::default()
        };
        drop((read, unread));
        first_set_for_tracing(&mut scene);
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        let m = &scene.meshes;
        assert!(m[0].geometry.uvs1.is_some() && Arc::ptr_eq(&m[0].geometry, &m[1].geometry));
        assert!(m[2].geometry.uvs1.is_none() && Arc::ptr_eq(&m[2].geometry, &m[3].geometry));
        assert_eq!(m[2].geometry.uvs, Some(vec![[0.0, 0.0]; 3]));
        let sets = [
            scene.materials[1].base_color_texture,
            scene.materials[1].occlusion_texture,
        ]
        .map(|r| r.map(|r| r.tex_coord));
        assert_eq!(sets, [Some(0), Some(1)], "not exchanged");
    }
}
