//! # treelight_scene
//!
//! [`SceneBvhPlugin`] keeps one global BVH of every mesh entity in a Bevy world, for ray picking and for
//! path tracing. The main thread only turns world changes into commands; a background worker builds
//! each mesh's bBVH in parallel and inserts it into the tree, so the main thread never waits.
//!
//! Watched: entities gaining [`Mesh3d`] (also when the asset finishes loading later), edits of mesh
//! assets, [`GlobalTransform`] changes, visibility, removal and despawn. Entities showing the same
//! mesh asset share its triangles in the tree, each one instance node (with its own material). Published: the [`SceneBvh`]
//! resource, with the tree, its version, stats and [`SceneBvh::cast_ray`].

// Every public item says what it is for: the crate is meant to be used from other apps.
#![warn(missing_docs)]

//! The crate's layers, lowest first: `types` (the settings, the tree, rays, meshes as the worker
//! takes them), `worker` (the thread that keeps the tree), `world` (the resource, the systems that
//! follow the world, picking). This file holds the plugin, which starts the worker and adds the systems.

mod types;
mod worker;
mod world;

/// The engine's named policies, which [`SceneBvhConfig::preset`] takes.
pub use treelight_bvh::Preset;
pub use types::config::SceneBvhConfig;
pub use types::hit::{SceneHit, cast_on, cast_on_filtered};
pub use types::mesh::{
    GeometryCopy, MeshGeometry, MeshPositions, MeshSkip, mesh_geometry, mesh_triangles,
};
pub use types::shading::{MeshShading, ShadingVertices};
pub use types::tree::{SceneChanges, SceneStats, SceneTree};
pub use types::{packed, priority};
pub use world::picking::SceneBvhPickingPlugin;
pub use world::scene_bvh::SceneBvh;
pub use world::track::NotTraced;

use bevy::prelude::*;
use bevy::transform::TransformSystems;
use world::track::{park_meshes, publish, release_traced_meshes, track_world};

/// Keeps a global BVH of all mesh entities, built on a background worker.
#[derive(Default)]
pub struct SceneBvhPlugin {
    /// Settings.
    pub config: SceneBvhConfig,
}

impl Plugin for SceneBvhPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<NotTraced>();
        let (shared, commands) = worker::start::start_worker(&self.config);
        app.insert_resource(SceneBvh::new(shared, commands, &self.config))
            .add_systems(
                PostUpdate,
                (
                    track_world,
                    release_traced_meshes
                        .run_if(|scene: Res<SceneBvh>| !scene.to_release.is_empty()),
                    park_meshes.run_if(|scene: Res<SceneBvh>| scene.parking.has_candidates()),
                    publish,
                )
                    .chain()
                    .in_set(SceneBvhSystems)
                    .after(TransformSystems::Propagate)
                    // This frame's asset edits are seen this frame: none is missed by a copy handed
                    // over before it.
                    .after(bevy::asset::AssetEventSystems)
                    // A mesh spawned this frame is seen with this frame's visibility (before it, as
                    // hidden, so not sent for a frame: the scene looked idle with it unsent).
                    .after(bevy::camera::visibility::VisibilitySystems::VisibilityPropagate),
            );
    }
}

/// The plugin's main-thread systems (in `PostUpdate`, after transform propagation): turning the
/// frame's world changes into worker commands, and publishing the worker's figures. Order against it
/// to see this frame's [`SceneBvh`] figures, or to measure what the plugin costs a frame.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SceneBvhSystems;
