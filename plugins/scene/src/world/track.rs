//! The main thread's systems: this frame's world changes turned into worker commands, meshes
//! copied out of the world within a budget, and the worker's figures published.

use crate::types::mesh::{GeometryCopy, MeshSkip};
use crate::worker::main_loop::Command;
use crate::world::scene_bvh::{COPY_CHUNK, Follower, MeshCopy, SceneBvh};
use bevy::asset::AssetEvent;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::InheritedVisibility;
use bevy::prelude::*;
use std::collections::HashSet;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

type MeshEntity<'a> = (
    Entity,
    &'a Mesh3d,
    &'a GlobalTransform,
    Option<&'a InheritedVisibility>,
    Option<&'a Name>,
);

/// Keeps a mesh entity out of the scene BVH, and so out of ray picking and every renderer that
/// traces the tree: an app's own helpers (gizmo handles, icons, drag ghosts, thumbnails) carry it.
/// Adding it to a traced entity removes the entity from the tree; removing it puts the entity back.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Component, Default)]
pub struct NotTraced;

/// Turns this frame's world changes into worker commands.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub(crate) fn track_world(
    mut scene: ResMut<SceneBvh>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut asset_events: MessageReader<AssetEvent<Mesh>>,
    changed_mesh: Query<
        MeshEntity,
        (
            Or<(Changed<Mesh3d>, Changed<InheritedVisibility>)>,
            Without<NotTraced>,
        ),
    >,
    moved: Query<
        (Entity, &GlobalTransform),
        (Changed<GlobalTransform>, With<Mesh3d>, Without<NotTraced>),
    >,
    all: Query<MeshEntity, Without<NotTraced>>,
    bounds: Query<(&GlobalTransform, Option<&Aabb>)>,
    cameras: Query<(&Camera, &GlobalTransform), With<Camera3d>>,
    opted_out: Query<Entity, Added<NotTraced>>,
    mut opted_in: RemovedComponents<NotTraced>,
    mut removed: RemovedComponents<Mesh3d>,
    time: Option<Res<Time<Real>>>,
) {
    let scene = &mut *scene;
    scene.last_frame = time.map_or(Duration::ZERO, |t| t.delta());
    let mut sent_now: HashSet<Entity> = HashSet::new();
    for e in removed.read().chain(opted_out.iter()) {
        for list in scene.waiting.values_mut() {
            list.retain(|&w| w != e);
        }
        scene.degenerate.remove(&e);
        scene.drop_copy(e);
        scene.untrace(e);
        sent_now.insert(e);
    }
    // Meshes that finished loading, for entities that were waiting on them.
    let mut ready: Vec<Entity> = Vec::new();
    for ev in asset_events.read() {
        if let AssetEvent::Added { id } | AssetEvent::LoadedWithDependencies { id } = ev
            && let Some(list) = scene.waiting.remove(id)
        {
            ready.extend(list);
        }
        if let AssetEvent::Modified { id } = ev {
            // Every entity of the mesh is sent again this frame (`Changed<Mesh3d>`): none of them
            // may share the old triangles.
            scene.sent_mesh.retain(|_, m| m != id);
            scene.mesh_senders.remove(id);
            scene.parking.modified(*id, &mut meshes);
        }
        if let AssetEvent::Removed { id } = ev {
            scene.parking.removed(*id);
        }
        if let AssetEvent::Modified { id }
        | AssetEvent::Removed { id }
        | AssetEvent::Unused { id } = ev
        {
            // Geometry handed over for an older version, or for a mesh no one shows any more.
            scene.prepared.remove(id);
        }
    }
    for item in &changed_mesh {
        upsert(scene, &mut meshes, &mut sent_now, item);
    }
    // Entities that dropped the marker this frame are traced again (if they still have a mesh).
    ready.extend(opted_in.read());
    for e in ready {
        if let Ok(item) = all.get(e)
            && !sent_now.contains(&e)
        {
            upsert(scene, &mut meshes, &mut sent_now, item);
        }
    }
    // Entities whose leader's copy stopped: each becomes a leader or follows another.
    for e in std::mem::take(&mut scene.orphans) {
        if let Ok(item) = all.get(e) {
            upsert(scene, &mut meshes, &mut sent_now, item);
        }
    }
    for (e, gt) in &moved {
        // Into or out of a transform no group can take: traced again from scratch (or not).
        if scene.degenerate.contains(&e) == treelight_bvh::is_traceable_transform(&gt.affine()) {
            if !sent_now.contains(&e)
                && let Ok(item) = all.get(e)
            {
                upsert(scene, &mut meshes, &mut sent_now, item);
            }
            continue;
        }
        if let Some(job) = scene.copying.get_mut(&e) {
            // Not with the worker yet: it will get the latest transform with the triangles.
            job.transform = gt.affine();
        } else if let Some(f) = scene.followers.get_mut(&e) {
            f.transform = gt.affine();
        } else if !sent_now.contains(&e) && scene.traced.contains(&e) {
            scene.send(Command::Move {
                entity: e,
                transform: gt.affine(),
            });
        }
    }
    // Meshes nearest the (first active 3D) camera are copied, and so traced, first: a big
    // assembly fills the preview in from the front.
    scene.eye = cameras
        .iter()
        .filter(|(c, _)| c.is_active)
        .min_by_key(|(c, _)| c.order)
        .map(|(_, gt)| gt.translation());
    if scene.copying.len() > 1
        && let Some(eye) = scene.eye
    {
        let mut order: Vec<(f32, Entity)> = scene
            .copying
            .keys()
            .map(|&e| {
                let centre = bounds.get(e).map_or(Vec3::ZERO, |(gt, aabb)| {
                    gt.transform_point(aabb.map_or(Vec3::ZERO, |b| Vec3::from(b.center)))
                });
                (centre.distance_squared(eye), e)
            })
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        scene.copy_order = order.into_iter().map(|(_, e)| e).collect();
    } else {
        scene.copy_order = scene.copying.keys().copied().collect();
    }
    copy_meshes(scene, &meshes);
}

/// Copies meshes out of the world until the frame's budget is spent (at least one chunk), and sends
/// the complete ones to the worker.
fn copy_meshes(scene: &mut SceneBvh, meshes: &Assets<Mesh>) {
    if scene.copying.is_empty() {
        return;
    }
    let share = scene.last_frame.mul_f32(scene.share.clamp(0.0, 1.0));
    let deadline = Instant::now() + scene.budget.max(share);
    let order = std::mem::take(&mut scene.copy_order);
    // Meshes handed over whole go to the worker at once, nearest first, whatever the budget; one
    // whose sizes are not its asset's is copied as any other (the copy starts over).
    let mut finished: Vec<(Entity, Result<(), MeshSkip>)> = Vec::new();
    for &e in &order {
        if let Some(job) = scene.copying.get_mut(&e)
            && job.handed_over
        {
            if meshes
                .get(job.mesh)
                .is_some_and(|m| job.copy.is_whole_copy_of(m))
            {
                finished.push((e, Ok(())));
                scene.handed_over += 1;
            } else {
                job.handed_over = false;
            }
        }
    }
    'jobs: for &e in &order {
        let Some(job) = scene.copying.get_mut(&e) else {
            continue;
        };
        if job.handed_over {
            // Finished above.
            continue;
        }
        let copy = &mut job.copy;
        let Some(mesh) = meshes.get(job.mesh) else {
            // The asset went away; a new handle or a despawn will follow.
            finished.push((e, Err(MeshSkip::NoPositions)));
            continue;
        };
        loop {
            let before = copy.copied();
            match copy.copy(mesh, COPY_CHUNK) {
                Ok(true) => {
                    finished.push((e, Ok(())));
                    break;
                }
                // Its destination is still being made: the next mesh meanwhile.
                Ok(false) if copy.copied() == before => break,
                Ok(false) => {}
                Err(why) => {
                    finished.push((e, Err(why)));
                    break;
                }
            }
            if Instant::now() >= deadline {
                break 'jobs;
            }
        }
        if Instant::now() >= deadline {
            break;
        }
    }
    for (e, result) in finished {
        let Some(job) = scene.copying.remove(&e) else {
            continue;
        };
        let waiting = scene.followers_of(job.mesh);
        match result {
            Ok(()) => {
                scene.remember_mesh(e, job.mesh);
                if scene.release {
                    scene.to_release.push(job.mesh);
                } else {
                    scene.parking.consider(job.mesh);
                }
                scene.send(Command::Copied {
                    entity: e,
                    mesh: job.mesh,
                    name: job.name,
                    copy: Box::new(job.copy),
                    transform: job.transform,
                    eye: scene.eye,
                    sent: job.started,
                });
                for f in waiting {
                    if let Some(follower) = scene.followers.remove(&f) {
                        scene.send_instance(f, follower);
                    }
                }
            }
            Err(why) => {
                warn!("entity {e} ('{}') is not traced: {why}", job.name);
                scene.untrace(e);
                for f in waiting {
                    if let Some(follower) = scene.followers.remove(&f) {
                        warn!("entity {f} ('{}') is not traced: {why}", follower.name);
                        scene.untrace(f);
                    }
                }
            }
        }
    }
}

/// Frees the vertex data of the meshes sent to the worker this frame
/// ([`SceneBvhConfig::release_traced_meshes`]). Untracked: a freed mesh is not a changed one, so
/// nothing (this plugin included) takes it for new geometry.
pub(crate) fn release_traced_meshes(mut scene: ResMut<SceneBvh>, mut meshes: ResMut<Assets<Mesh>>) {
    let scene = &mut *scene;
    for id in scene.to_release.drain(..) {
        if let Some(mesh) = meshes.get_mut_untracked(id)
            && mesh.take_gpu_data().is_ok()
        {
            scene.released += 1;
        }
    }
}

/// Parks the meshes looked at this frame ([`SceneBvhConfig::park_meshes`](
/// crate::types::config::SceneBvhConfig::park_meshes)) that nothing reads, within the frame's
/// budget for main-thread work (at least one).
pub(crate) fn park_meshes(mut scene: ResMut<SceneBvh>, mut meshes: ResMut<Assets<Mesh>>) {
    let scene = &mut *scene;
    let share = scene.last_frame.mul_f32(scene.share.clamp(0.0, 1.0));
    let deadline = Instant::now() + scene.budget.max(share);
    let copying: HashSet<AssetId<Mesh>> = scene.copying.values().map(|job| job.mesh).collect();
    let (prepared, waiting) = (&scene.prepared, &scene.waiting);
    let in_use =
        |id| copying.contains(&id) || prepared.contains_key(&id) || waiting.contains_key(&id);
    scene.parking.park(&mut meshes, in_use, deadline);
}

/// Sends a mesh entity's current triangles, or a removal if it is hidden or untraceable, or parks it
/// until its asset loads.
fn upsert(
    scene: &mut SceneBvh,
    meshes: &mut Assets<Mesh>,
    sent_now: &mut HashSet<Entity>,
    (e, m, gt, vis, name): MeshEntity,
) {
    // The worker already holds `e`'s triangles of this very asset (a modified asset is no longer
    // in `sent_mesh`) and it stays shown: nothing to send. Bevy marks `Mesh3d` changed whenever
    // the entity's material or its asset changes, which leaves the geometry as it was; sent again,
    // a mesh whose vertices were released could not be traced any more, and any other would be
    // copied and rebuilt for nothing. A move in the same frame goes as a move.
    if scene.sent_mesh.get(&e) == Some(&m.0.id())
        && scene.traced.contains(&e)
        && vis.is_none_or(|v| v.get())
        && treelight_bvh::is_traceable_transform(&gt.affine())
    {
        return;
    }
    sent_now.insert(e);
    scene.drop_copy(e);
    scene.followers.remove(&e);
    // Whatever the worker holds of `e` is replaced (or removed) by what follows.
    scene.forget_mesh(e);
    if vis.is_some_and(|v| !v.get()) {
        scene.untrace(e);
        return;
    }
    // Never traced, and so never the holder of a mesh another entity would share.
    if !treelight_bvh::is_traceable_transform(&gt.affine()) {
        scene.untrace(e);
        scene.degenerate.insert(e);
        return;
    }
    scene.degenerate.remove(&e);
    let label = name.map_or_else(|| format!("{e}"), |n| n.as_str().to_owned());
    if !meshes.contains(&m.0) {
        scene.waiting.entry(m.0.id()).or_default().push(e);
        return;
    }
    let follower = Follower {
        mesh: m.0.id(),
        name: label.clone(),
        transform: gt.affine(),
        started: Instant::now(),
    };
    if scene.mesh_senders.contains_key(&follower.mesh) {
        // Another entity of this mesh is traced: share its triangles.
        scene.send_instance(e, follower);
        return;
    }
    if scene.copying.values().any(|job| job.mesh == follower.mesh) {
        // Another entity's copy of this mesh is under way: wait for it rather than copy twice.
        scene.traced.insert(e);
        scene.followers.insert(e, follower);
        return;
    }
    let prepared = scene.prepared.remove(&follower.mesh);
    let handed_over = prepared.is_some();
    // Its vertices are read from here on (a prepared copy's mesh was never parked).
    scene.parking.restore(follower.mesh, meshes);
    let Some(mesh) = meshes.get(&m.0) else {
        return;
    };
    match prepared.map_or_else(|| GeometryCopy::new(mesh), Ok) {
        Ok(copy) => {
            // Traced from now on: a removal must reach the worker even if the copy never finishes.
            scene.traced.insert(e);
            scene.copying.insert(
                e,
                MeshCopy {
                    mesh: m.0.id(),
                    name: label,
                    transform: gt.affine(),
                    started: Instant::now(),
                    copy,
                    handed_over,
                },
            );
        }
        Err(why) => {
            warn!("entity {e} ('{label}') is not traced: {why}");
            scene.untrace(e);
        }
    }
}

/// Copies the worker's figures into the resource.
pub(crate) fn publish(mut scene: ResMut<SceneBvh>) {
    // The worker holds its idle work while meshes are still being copied to it.
    scene
        .shared
        .filling
        .store(scene.is_copying(), Ordering::Release);
    let version = scene.shared.version.load(Ordering::Acquire);
    let mut stats = *scene.shared.stats.lock().unwrap_or_else(|p| p.into_inner());
    stats.pending =
        scene.shared.pending.load(Ordering::Acquire) + scene.copying.len() + scene.followers.len();
    if scene.version != version || scene.stats != stats {
        scene.version = version;
        scene.stats = stats;
    }
}
