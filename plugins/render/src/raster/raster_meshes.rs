//! Meshes reach the render world only while a camera rasterises them. A path-traced camera draws
//! no meshes (`raster_skip.rs`); while every active 3D camera is path traced, a new mesh asset stays
//! in the main world: its `RenderAssetUsages` lose `RENDER_WORLD`, changed untracked so nothing
//! takes its vertices for changed. No copy of it goes to the render world and no raster vertex
//! buffer holds it. When a rasterising camera becomes active, the meshes held back are sent; when
//! the last one goes, the render world's copies are dropped and held back again. A mesh held back
//! may be parked by the scene plugin (`SceneBvhConfig::park_meshes`: its vertices compressed); the
//! parked ones are put back before any is sent.

use bevy::asset::{AssetEventSystems, RenderAssetUsages};
use bevy::pbr::{MeshExtractionSystems, MeshesToReextractNextFrame};
use bevy::prelude::*;
use bevy::render::mesh::RenderMesh;
use bevy::render::render_asset::{AssetExtractionSystems, ExtractedAssets};
use bevy::render::sync_world::MainEntity;
use bevy::render::{Extract, ExtractSchedule, RenderApp};
use std::collections::HashSet;

use crate::types::figures::PathTracerStats;
use crate::types::view::PathTraced;
use treelight_scene::{SceneBvh, SceneBvhSystems};

/// Whether the path tracer keeps mesh assets out of the render world while every active 3D camera
/// is path traced (the default, `true`). Insert `HoldBackRasterMeshes(false)` in an app whose own
/// render passes read meshes for a path-traced camera.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct HoldBackRasterMeshes(pub bool);

impl Default for HoldBackRasterMeshes {
    fn default() -> Self {
        Self(true)
    }
}

/// The meshes held back, and this frame's changes for the render world.
#[derive(Resource, Default)]
pub(crate) struct HeldMeshes {
    /// Meshes whose `RENDER_WORLD` usage was removed here.
    held: HashSet<AssetId<Mesh>>,
    /// Meshes to send to the render world this frame (a rasterising camera appeared).
    send: Vec<AssetId<Mesh>>,
    /// Meshes whose render-world copies to drop this frame (the last rasterising camera went).
    drop: Vec<AssetId<Mesh>>,
    /// Whether a rasterising camera was active in the last frame, or meshes are not held back
    /// ([`HoldBackRasterMeshes`]): Bevy's own raster work goes on as the app set it up.
    pub(crate) rasterised: bool,
}

pub(crate) fn build(app: &mut App) {
    app.init_resource::<HoldBackRasterMeshes>()
        .init_resource::<HeldMeshes>()
        .add_systems(
            PostUpdate,
            hold_back_meshes
                .after(AssetEventSystems)
                // The scene plugin parks meshes held back this frame, and never one sent.
                .before(SceneBvhSystems),
        );
    if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
        render_app.add_systems(
            ExtractSchedule,
            send_and_drop_meshes
                .after(AssetExtractionSystems)
                .before(MeshExtractionSystems),
        );
    }
}

fn hold_back_meshes(
    mut state: ResMut<HeldMeshes>,
    hold: Res<HoldBackRasterMeshes>,
    mut events: MessageReader<AssetEvent<Mesh>>,
    mut meshes: ResMut<Assets<Mesh>>,
    cameras: Query<&Camera, (With<Camera3d>, Without<PathTraced>)>,
    stats: Res<PathTracerStats>,
    mut scene: Option<ResMut<SceneBvh>>,
) {
    let state = &mut *state;
    let before = state.held.len();
    state.send.clear();
    state.drop.clear();
    let rasterised = !hold.0 || cameras.iter().any(|c| c.is_active);
    let was_rasterised = std::mem::replace(&mut state.rasterised, rasterised);
    if rasterised {
        events.clear();
        if !state.held.is_empty()
            && let Some(scene) = scene.as_deref_mut()
        {
            // Their vertices are read again: parked ones are put back first.
            scene.restore_parked_meshes(&mut meshes);
        }
        for id in state.held.drain() {
            if let Some(m) = meshes.get_mut_untracked(id) {
                m.asset_usage.insert(RenderAssetUsages::RENDER_WORLD);
                state.send.push(id);
            }
        }
        if before > 0 {
            stats.update(|f| f.meshes_held_back = 0);
        }
        return;
    }
    // Every mesh when the last rasterising camera went; else the new and replaced ones.
    let candidates: Vec<AssetId<Mesh>> = if was_rasterised {
        events.clear();
        meshes.ids().collect()
    } else {
        events
            .read()
            .filter_map(|e| match e {
                AssetEvent::Added { id } | AssetEvent::Modified { id } => Some(*id),
                _ => None,
            })
            .collect()
    };
    for id in candidates {
        // A mesh only the render world keeps could not be sent later: it is left as it is.
        if let Some(m) = meshes.get_mut_untracked(id)
            && m.asset_usage.contains(RenderAssetUsages::all())
        {
            m.asset_usage.remove(RenderAssetUsages::RENDER_WORLD);
            state.held.insert(id);
            if let Some(scene) = scene.as_deref_mut() {
                scene.park_mesh_later(id);
            }
            if was_rasterised {
                state.drop.push(id);
            }
        }
    }
    if state.held.len() != before {
        stats.update(|f| f.meshes_held_back = state.held.len());
    }
}

/// Adds the meshes sent this frame to what the render world prepares (as Bevy's own extraction
/// would have, had they kept their usage), and removes those dropped. The entities drawing them are
/// extracted again: Bevy records where an entity's mesh lies in the raster buffers only when it
/// extracts the entity.
fn send_and_drop_meshes(
    state: Extract<Res<HeldMeshes>>,
    meshes: Extract<Res<Assets<Mesh>>>,
    users: Extract<Query<(Entity, &Mesh3d)>>,
    mut extracted: ResMut<ExtractedAssets<RenderMesh>>,
    reextract: Option<ResMut<MeshesToReextractNextFrame>>,
) {
    if state.send.is_empty() && state.drop.is_empty() {
        return;
    }
    for &id in &state.send {
        if let Some(m) = meshes.get(id) {
            extracted.extracted.push((id, m.clone()));
            extracted.added.insert(id);
        }
    }
    for &id in &state.drop {
        extracted.removed.insert(id);
    }
    if let Some(mut reextract) = reextract {
        let changed: HashSet<AssetId<Mesh>> =
            state.send.iter().chain(&state.drop).copied().collect();
        for (e, m) in &users {
            if changed.contains(&m.0.id()) {
                reextract.insert(MainEntity::from(e));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::mesh::{Indices, PrimitiveTopology};

    #[derive(Resource, Default)]
    struct Modified(usize);

    fn count_modified(mut events: MessageReader<AssetEvent<Mesh>>, mut n: ResMut<Modified>) {
        n.0 += events
            .read()
            .filter(|e| matches!(e, AssetEvent::Modified { .. }))
            .count();
    }

    fn triangle_for(usage: RenderAssetUsages) -> Mesh {
        Mesh::new(PrimitiveTopology::TriangleList, usage)
            .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; 3])
            .with_inserted_indices(Indices::U32(vec![0, 1, 2]))
    }

    fn triangle() -> Mesh {
        triangle_for(RenderAssetUsages::all())
    }

    fn usage(app: &App, id: AssetId<Mesh>) -> RenderAssetUsages {
        app.world()
            .resource::<Assets<Mesh>>()
            .get(id)
            .unwrap()
            .asset_usage
    }

    #[test]
    fn meshes_are_held_back_while_every_camera_is_path_traced_and_sent_when_one_rasterises() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Mesh>()
            .init_resource::<HoldBackRasterMeshes>()
            .init_resource::<HeldMeshes>()
            .init_resource::<Modified>()
            .insert_resource(PathTracerStats::default())
            .add_systems(
                PostUpdate,
                (hold_back_meshes.after(AssetEventSystems), count_modified),
            );
        let camera = app
            .world_mut()
            .spawn((Camera3d::default(), PathTraced::default()))
            .id();
        // The handles are kept: an asset without one is dropped.
        let a_handle = app
            .world_mut()
            .resource_mut::<Assets<Mesh>>()
            .add(triangle());
        let a = a_handle.id();
        let only_render_handle = app
            .world_mut()
            .resource_mut::<Assets<Mesh>>()
            .add(triangle_for(RenderAssetUsages::RENDER_WORLD));
        let only_render = only_render_handle.id();
        app.update();
        // Held back in the frame it was added, untracked: nothing takes it for a changed mesh.
        assert_eq!(usage(&app, a), RenderAssetUsages::MAIN_WORLD);
        assert_eq!(usage(&app, only_render), RenderAssetUsages::RENDER_WORLD);
        assert_eq!(
            app.world()
                .resource::<PathTracerStats>()
                .figures()
                .meshes_held_back,
            1
        );
        // A rasterising camera: sent, with its usage back.
        app.world_mut().entity_mut(camera).remove::<PathTraced>();
        app.update();
        assert_eq!(usage(&app, a), RenderAssetUsages::all());
        assert_eq!(app.world().resource::<HeldMeshes>().send, vec![a]);
        let b_handle = app
            .world_mut()
            .resource_mut::<Assets<Mesh>>()
            .add(triangle());
        let b = b_handle.id();
        app.update();
        assert_eq!(usage(&app, b), RenderAssetUsages::all());
        assert_eq!(
            app.world()
                .resource::<PathTracerStats>()
                .figures()
                .meshes_held_back,
            0
        );
        // Path traced again: every mesh held back and dropped from the render world.
        app.world_mut()
            .entity_mut(camera)
            .insert(PathTraced::default());
        app.update();
        let state = app.world().resource::<HeldMeshes>();
        let mut dropped = state.drop.clone();
        dropped.sort();
        let mut both = vec![a, b];
        both.sort();
        assert_eq!(dropped, both);
        assert_eq!(
            (usage(&app, a), usage(&app, b)),
            (RenderAssetUsages::MAIN_WORLD, RenderAssetUsages::MAIN_WORLD)
        );
        assert_eq!(app.world().resource::<Modified>().0, 0);
        // Opted out: nothing is held back.
        app.insert_resource(HoldBackRasterMeshes(false));
        app.update();
        assert_eq!(usage(&app, a), RenderAssetUsages::all());
    }
}
