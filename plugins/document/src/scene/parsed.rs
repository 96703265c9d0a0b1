//! Scenes parsed off the main thread, with their Bevy meshes and images made there too, waiting
//! to be spawned.

use crate::values::object::SceneId;
use bevy::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;
use treelight_import::ImportedScene;

/// A file parsed, with its meshes and textures already made into Bevy assets (off the main thread,
/// so the frame that adds them to the scene only moves them in).
pub struct ParsedScene {
    /// What the file holds.
    pub scene: Arc<ImportedScene>,
    /// Its Bevy meshes and images.
    pub parts: Prebuilt,
    /// Its world-space bounds ([`scene_bounds`]), made with the rest off the main thread.
    pub bounds: Option<(Vec3, Vec3)>,
}

/// Bevy meshes and images made from a scene ahead of spawning it; `spawn_scene` takes them and
/// makes whatever is missing.
#[derive(Default)]
pub struct Prebuilt {
    /// One Bevy mesh per mesh of the scene, `None` for one that repeats an earlier one (`same_as`)
    /// and for those already taken.
    pub meshes: Vec<Option<Mesh>>,
    /// The images the materials' maps use, by texture, wrap modes and storage.
    pub images: HashMap<crate::scene::convert::ImageKey, Image>,
    /// Each mesh's bounds (of `meshes[i]`, or of the mesh it repeats), so that Bevy need not
    /// compute them on the main thread when the objects are spawned.
    pub bounds: Vec<Option<bevy::camera::primitives::Aabb>>,
    /// The content of each of `meshes` ([`crate::scene::share::mesh_hash`]), so that a mesh
    /// already in the scene is shared without hashing it on the main thread.
    pub mesh_hashes: Vec<Option<u64>>,
    /// The content of each of the scene's textures ([`crate::scene::share::texture_hash`]).
    pub texture_hashes: Vec<u64>,
    /// The scene BVH's copy of each of `meshes` ([`treelight_scene::GeometryCopy::whole`]), made
    /// with it: handed to the scene plugin with the asset ([`treelight_scene::SceneBvh::prepare`]),
    /// so the main thread never copies a mesh out for the tree and a large import fills it at the
    /// worker's pace. `None` where `meshes` is, and for a mesh the tree cannot trace.
    pub geometry: Vec<Option<treelight_scene::GeometryCopy>>,
}

/// The content of a scene's meshes (`None` for one that repeats an earlier one) and textures, as
/// [`crate::scene::share`] hashes them: what finds an import's assets among those already in the
/// scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContentHashes {
    /// By mesh.
    pub meshes: Vec<Option<u64>>,
    /// By texture.
    pub textures: Vec<u64>,
}

impl ContentHashes {
    /// The hashes of `scene`'s meshes (as the Bevy meshes made of them, tangents or not) and
    /// textures.
    pub fn of(scene: &ImportedScene) -> Self {
        use crate::scene::share::{mesh_hash, texture_hash};
        let tangents = crate::scene::convert::tangents_needed(scene);
        Self {
            meshes: scene
                .meshes
                .iter()
                .zip(&tangents)
                .map(|(m, &t)| m.same_as.is_none().then(|| mesh_hash(&m.geometry, t)))
                .collect(),
            textures: scene.textures.iter().map(texture_hash).collect(),
        }
    }
}

impl ParsedScene {
    /// A scene read ahead of its import (the Assets panel's, with its hashes and bounds made on
    /// the panel's thread): nothing is made now; spawning it makes the meshes and images not
    /// already in the scene, so a second placement of one file makes none.
    pub fn read_ahead(
        scene: Arc<ImportedScene>,
        hashes: ContentHashes,
        bounds: (Vec3, Vec3),
    ) -> Self {
        Self {
            scene,
            parts: Prebuilt {
                mesh_hashes: hashes.meshes,
                texture_hashes: hashes.textures,
                ..default()
            },
            bounds: Some(bounds),
        }
    }
}

impl From<ImportedScene> for ParsedScene {
    fn from(scene: ImportedScene) -> Self {
        use bevy::camera::primitives::MeshAabb;
        let tangents = crate::scene::convert::tangents_needed(&scene);
        let ContentHashes {
            meshes: mesh_hashes,
            textures: texture_hashes,
        } = ContentHashes::of(&scene);
        let meshes: Vec<Option<Mesh>> = scene
            .meshes
            .iter()
            .zip(&tangents)
            .map(|(m, &t)| {
                m.same_as
                    .is_none()
                    .then(|| crate::scene::convert::to_bevy_mesh(m, t))
            })
            .collect();
        let geometry = meshes
            .iter()
            .map(|m| {
                m.as_ref()
                    .and_then(|m| treelight_scene::GeometryCopy::whole(m).ok())
            })
            .collect();
        let own: Vec<_> = meshes
            .iter()
            .map(|m| m.as_ref().and_then(MeshAabb::compute_aabb))
            .collect();
        let bounds = scene
            .meshes
            .iter()
            .enumerate()
            .map(|(i, m)| own.get(m.same_as.unwrap_or(i)).copied().flatten())
            .collect();
        let mut images = HashMap::new();
        for m in &scene.materials {
            for (_, r, role) in crate::scene::convert::material_maps(m) {
                if let Some(t) = scene.textures.get(r.texture) {
                    images
                        .entry((r.texture, r.wrap, role))
                        .or_insert_with(|| crate::scene::convert::to_bevy_image(t, r.wrap, role));
                }
            }
        }
        Self {
            bounds: scene_bounds(&scene),
            scene: Arc::new(scene),
            parts: Prebuilt {
                meshes,
                images,
                bounds,
                mesh_hashes,
                texture_hashes,
                geometry,
            },
        }
    }
}

/// Files parsed in the background and not yet in the scene, by the id their import command gives
/// its root: the command takes its scene from here (and parses the file itself when a script or a
/// redo names one that is not).
#[derive(Resource, Default)]
pub struct ParsedImports(pub HashMap<SceneId, ParsedScene>);

/// The world-space bounds of a parsed scene's triangles.
pub fn scene_bounds(scene: &ImportedScene) -> Option<(Vec3, Vec3)> {
    let mut bounds: Option<(Vec3, Vec3)> = None;
    for m in &scene.meshes {
        for tri in m.world_triangles() {
            for p in tri {
                bounds = Some(bounds.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
            }
        }
    }
    bounds
}
