//! The resource apps read: the tree as the worker last published it, its figures, picking, and
//! what the main thread has sent the worker and is still copying.

use crate::types::config::SceneBvhConfig;
use crate::types::hit::{SceneHit, cast_on_filtered};
use crate::types::mesh::GeometryCopy;
use crate::types::tree::{SceneChanges, SceneStats, SceneTree};
use crate::worker::main_loop::{Command, Shared};
use crate::world::parking::Parking;
use bevy::math::Ray3d;
use bevy::prelude::*;
use std::collections::{HashMap, HashSet};
use std::sync::atomic::Ordering;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, RwLockReadGuard};
use std::time::{Duration, Instant};
use treelight_bvh::GroupId;

/// The global BVH of the world's meshes, kept in sync by `SceneBvhPlugin`.
#[derive(Resource)]
pub struct SceneBvh {
    pub(crate) shared: Arc<Shared>,
    sender: Mutex<Sender<Command>>,
    pub(crate) version: u64,
    pub(crate) stats: SceneStats,
    /// Entities whose mesh asset has not loaded yet, by asset.
    pub(crate) waiting: HashMap<AssetId<Mesh>, Vec<Entity>>,
    /// Entities sent to the worker (so moves and removals of others are not sent).
    pub(crate) traced: HashSet<Entity>,
    /// Mesh entities placed by a transform no group can take (scaled to zero, as exporters hide
    /// nodes): not traced, and never the one whose copy of a mesh others share, until they move
    /// to a transform that can be traced.
    pub(crate) degenerate: HashSet<Entity>,
    /// Meshes being copied out of the world, a budget's worth per frame.
    pub(crate) copying: HashMap<Entity, MeshCopy>,
    /// The mesh whose triangles the worker has (or will have) for each entity, and how many
    /// entities sent each mesh: a further entity of that mesh shares them instead of copying.
    pub(crate) sent_mesh: HashMap<Entity, AssetId<Mesh>>,
    pub(crate) mesh_senders: HashMap<AssetId<Mesh>, usize>,
    /// Entities waiting for another entity's copy of the same mesh, with their latest transform.
    pub(crate) followers: HashMap<Entity, Follower>,
    /// Followers whose leader stopped copying: looked at again at the end of the frame.
    pub(crate) orphans: Vec<Entity>,
    /// This frame's order of the copies: nearest the camera first.
    pub(crate) copy_order: Vec<Entity>,
    /// Where the first active 3D camera is this frame: the worker inserts a huge mesh's chunks
    /// nearest it first.
    pub(crate) eye: Option<Vec3>,
    pub(crate) budget: Duration,
    /// [`SceneBvhConfig::main_thread_share`].
    pub(crate) share: f32,
    /// How long the last frame took.
    pub(crate) last_frame: Duration,
    /// Geometry made off the main thread for mesh assets ([`SceneBvh::prepare`]), taken by the
    /// first entity of each that is traced.
    pub(crate) prepared: HashMap<AssetId<Mesh>, GeometryCopy>,
    /// Meshes sent to the worker as handed over, with no copy.
    pub(crate) handed_over: u64,
    /// [`SceneBvhConfig::release_traced_meshes`](crate::types::config::SceneBvhConfig::release_traced_meshes).
    pub(crate) release: bool,
    /// Meshes sent to the worker this frame whose vertex data is to be freed.
    pub(crate) to_release: Vec<AssetId<Mesh>>,
    /// Meshes whose vertex data was freed.
    pub(crate) released: u64,
    /// Meshes kept compressed while nothing reads them
    /// ([`SceneBvhConfig::park_meshes`](crate::types::config::SceneBvhConfig::park_meshes)).
    pub(crate) parking: Parking,
}

/// An entity whose mesh is being copied for another: it is sent as an instance once that copy is.
pub(crate) struct Follower {
    pub(crate) mesh: AssetId<Mesh>,
    pub(crate) name: String,
    pub(crate) transform: bevy::math::Affine3A,
    pub(crate) started: Instant,
}

/// A mesh entity whose triangles are being copied for the worker.
pub(crate) struct MeshCopy {
    pub(crate) mesh: AssetId<Mesh>,
    pub(crate) name: String,
    pub(crate) transform: bevy::math::Affine3A,
    pub(crate) started: Instant,
    pub(crate) copy: GeometryCopy,
    /// Whether `copy` was handed over whole ([`SceneBvh::prepare`]) and is still taken to be the
    /// asset's (cleared when its sizes are not).
    pub(crate) handed_over: bool,
}

/// Array elements (vertex attributes or indices) copied between looks at the clock: memory copies of
/// a few tens of microseconds.
pub(crate) const COPY_CHUNK: usize = 16 * 1024;

impl SceneBvh {
    /// The resource for a worker just started (`start_worker`), nothing sent to it yet.
    pub(crate) fn new(
        shared: Arc<Shared>,
        commands: Sender<Command>,
        config: &SceneBvhConfig,
    ) -> Self {
        Self {
            shared,
            sender: Mutex::new(commands),
            version: 0,
            stats: SceneStats::default(),
            waiting: HashMap::new(),
            traced: HashSet::new(),
            degenerate: HashSet::new(),
            copying: HashMap::new(),
            sent_mesh: HashMap::new(),
            mesh_senders: HashMap::new(),
            followers: HashMap::new(),
            orphans: Vec::new(),
            copy_order: Vec::new(),
            eye: None,
            budget: config.main_thread_budget,
            share: config.main_thread_share,
            last_frame: Duration::ZERO,
            prepared: HashMap::new(),
            handed_over: 0,
            release: config.release_traced_meshes,
            to_release: Vec::new(),
            released: 0,
            parking: Parking::new(config.park_meshes),
        }
    }

    /// Hands over a whole copy of `mesh`'s arrays ([`GeometryCopy::whole`]), made elsewhere from
    /// the same asset (an importer can make it on its own thread as it makes the asset): the first
    /// entity showing `mesh` that is traced sends it to the worker in the frame it is seen,
    /// instead of copying the asset out of the world a budget's worth a frame. A large import
    /// then fills the tree at the worker's pace, not the frame rate's. Taken once (further
    /// entities of the mesh share its triangles); dropped when the asset is modified or removed
    /// first, and replaced by a copy of the asset when its sizes are not the asset's. While every
    /// entity of the asset is hidden it waits here, until one is shown or the asset is dropped.
    pub fn prepare(&mut self, mesh: AssetId<Mesh>, copy: GeometryCopy) {
        self.prepared.insert(mesh, copy);
    }

    /// How many meshes were sent to the worker as [`SceneBvh::prepare`] handed them over, with
    /// no copy out of the world.
    pub fn meshes_handed_over(&self) -> u64 {
        self.handed_over
    }

    /// How many mesh assets had their vertex data freed once traced
    /// ([`SceneBvhConfig::release_traced_meshes`](
    /// crate::types::config::SceneBvhConfig::release_traced_meshes)).
    pub fn meshes_released(&self) -> u64 {
        self.released
    }

    /// Puts `mesh`'s vertex data back into its asset if it is parked
    /// ([`SceneBvhConfig::park_meshes`](crate::types::config::SceneBvhConfig::park_meshes)), for
    /// a reader of its vertices. Untracked: nothing takes the asset for changed. It is parked again
    /// once [`SceneBvh::park_mesh_later`] names it and nothing uses it.
    pub fn restore_parked_mesh(&mut self, mesh: AssetId<Mesh>, meshes: &mut Assets<Mesh>) {
        self.parking.restore(mesh, meshes);
    }

    /// Puts every parked mesh's vertex data back (a camera rasterises them again).
    pub fn restore_parked_meshes(&mut self, meshes: &mut Assets<Mesh>) {
        self.parking.restore_all(meshes);
    }

    /// Looks at `mesh` for parking at the end of this frame's systems: parked if parking is on,
    /// only the main world keeps it, the worker is not waiting for its vertices and it is not
    /// parked yet. Meshes the worker takes in are looked at without this; a renderer calls it when
    /// it stops drawing a mesh.
    pub fn park_mesh_later(&mut self, mesh: AssetId<Mesh>) {
        self.parking.consider(mesh);
    }

    /// Whether `mesh`'s vertex data is parked.
    pub fn is_parked(&self, mesh: AssetId<Mesh>) -> bool {
        self.parking.is_parked(mesh)
    }

    /// Triangles of a parked mesh (its asset has no vertex data to count them in while parked).
    pub fn parked_triangles(&self, mesh: AssetId<Mesh>) -> Option<usize> {
        self.parking.triangles(mesh)
    }

    /// How many meshes are parked, and the bytes their compressed data takes.
    pub fn parked_figures(&self) -> (usize, usize) {
        self.parking.figures()
    }

    /// Version of the tree, raised by every change the worker applies.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Figures about the tree as of this frame.
    pub fn stats(&self) -> SceneStats {
        self.stats
    }

    /// Why the worker stopped, if it has (a panic, with its message): the tree then no longer
    /// follows the world, and [`SceneBvh::is_idle`] stays false.
    pub fn worker_failure(&self) -> Option<String> {
        self.shared
            .failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// Why background refinement stopped, if it has (a panic); the tree keeps its first builds.
    pub fn refinement_failure(&self) -> Option<String> {
        self.shared
            .refine_failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// Makes the worker panic, as a bug in it would: how an app's tests check that it survives
    /// and reports one.
    #[doc(hidden)]
    pub fn crash_worker_for_tests(&self) {
        // A pending command like any other: the scene is not idle while it is on its way.
        self.send(Command::Crash);
    }

    /// Whether new geometry is on its way into the tree: meshes being copied out of the world, or
    /// sent to the worker (new or edited meshes, further entities sharing one) and not yet in.
    /// Moves and removals do not count. While an import streams in this holds for seconds, and
    /// each frame's new triangles change what a renderer shows anyway.
    pub fn is_filling(&self) -> bool {
        self.worker_failure().is_none()
            && (self.is_copying() || self.shared.incoming.load(Ordering::Acquire) > 0)
    }

    /// New triangles on their way into the tree: meshes being copied out of the world, and those
    /// sent to the worker and not yet in. What the tree is about to grow by, so that a renderer
    /// can size its buffers once for a whole import instead of growing them step by step (each
    /// step holding the old and the new buffer at once).
    pub fn incoming_triangles(&self) -> usize {
        let copying: usize = self.copying.values().map(|j| j.copy.triangles()).sum();
        copying + self.shared.incoming_triangles.load(Ordering::Acquire)
    }

    /// Whether meshes are still being copied out of the world, or entities sharing one wait for
    /// it: geometry the worker has not been sent yet.
    pub(crate) fn is_copying(&self) -> bool {
        !self.copying.is_empty() || !self.followers.is_empty()
    }

    /// Whether every change sent so far has been applied (never, once the worker has stopped).
    pub fn is_idle(&self) -> bool {
        !self.is_copying()
            && self.shared.pending.load(Ordering::Acquire) == 0
            && self.worker_failure().is_none()
    }

    /// Whether the worker has nothing left to do until the next change: every change applied
    /// ([`SceneBvh::is_idle`]) and no work of its own ahead (moved meshes to bake, update steps,
    /// rebuilds), and no mesh waiting to be parked on the main thread. An app that draws only
    /// when something changes (Bevy's reactive `WinitSettings`) keeps drawing while this is false:
    /// the tree still changes, and [`SceneBvh::version`] with it.
    pub fn is_resting(&self) -> bool {
        self.is_idle()
            && !self.shared.active.load(Ordering::Acquire)
            && !self.parking.has_candidates()
    }

    /// Read access to the tree, unless the worker is writing to it right now (the main thread never
    /// waits: try again next frame), or has stopped: a worker that panicked may have left the
    /// tree half written, so it is published no more (picking and renderers see nothing new).
    pub fn try_read(&self) -> Option<RwLockReadGuard<'_, SceneTree>> {
        if self.worker_failure().is_some() {
            return None;
        }
        self.shared.tree.try_read().ok()
    }

    /// Read access, waiting for the worker if it is writing (for tests and tools, not for frames),
    /// even to a tree a stopped worker left.
    pub fn read_blocking(&self) -> RwLockReadGuard<'_, SceneTree> {
        self.shared.tree.read().unwrap_or_else(|p| p.into_inner())
    }

    /// Read access, waiting for the worker if it is writing (a click's pick must see the tree);
    /// `None` once the worker has stopped ([`SceneBvh::try_read`]).
    pub fn read_waiting(&self) -> Option<RwLockReadGuard<'_, SceneTree>> {
        if self.worker_failure().is_some() {
            return None;
        }
        self.shared.tree.read().ok()
    }

    /// The nearest hit of `ray` on the latest tree, or `None` if nothing is hit (or the worker holds
    /// the tree this instant).
    pub fn cast_ray(&self, ray: Ray3d) -> Option<SceneHit> {
        self.cast_ray_filtered(ray, |_| true)
    }

    /// The nearest hit on an entity that `accept` takes; others are seen through.
    pub fn cast_ray_filtered(
        &self,
        ray: Ray3d,
        accept: impl FnMut(Entity) -> bool,
    ) -> Option<SceneHit> {
        cast_on_filtered(&*self.try_read()?, ray, accept)
    }

    /// For a renderer that mirrors the tree on the GPU: takes what changed since its last call and
    /// hands it over with read access to the tree, so the records it reads agree with the change set.
    /// `everything` marks the whole tree changed first (a renderer's first call, or one that lost
    /// its copy). Returns `None`, and takes nothing, when the worker holds the tree this instant.
    ///
    /// There is one change log: the scene has one GPU mirror.
    pub fn try_take_changes<R>(
        &self,
        everything: bool,
        f: impl FnOnce(&SceneTree, &SceneChanges) -> R,
    ) -> Option<R> {
        // A worker that panicked may have left the tree half written: nothing more is taken.
        if self.worker_failure().is_some() {
            return None;
        }
        let mut tree = self.shared.tree.try_write().ok()?;
        if everything {
            tree.bvh.mark_all_changed();
            let all: Vec<GroupId> = tree.group_entity.keys().copied().collect();
            tree.fresh_groups.extend(all);
        }
        let mut fresh: Vec<GroupId> = tree.fresh_groups.drain().collect();
        fresh.sort_unstable_by_key(|g| g.index());
        let mut relaid: Vec<(GroupId, GroupId)> = tree.relaid_groups.drain().collect();
        relaid.sort_unstable_by_key(|g| g.0.index());
        let changes = SceneChanges {
            bvh: tree.bvh.take_changes(),
            fresh_groups: fresh,
            relaid_groups: relaid,
            // The worker raises the version once it has let the tree go: read under the lock,
            // this is never ahead of what the tree holds.
            version: self.shared.version.load(Ordering::Acquire),
        };
        Some(f(&tree, &changes))
    }

    /// Stops tracing `e`: the worker removes what it has of it. Nothing is sent for an entity the
    /// worker never heard of.
    pub(crate) fn untrace(&mut self, e: Entity) {
        self.followers.remove(&e);
        self.forget_mesh(e);
        if self.traced.remove(&e) {
            self.send(Command::Remove { entity: e });
        }
    }

    /// `e`'s triangles are going away (a removal, or a new version on its way).
    pub(crate) fn forget_mesh(&mut self, e: Entity) {
        if let Some(m) = self.sent_mesh.remove(&e)
            && let Some(n) = self.mesh_senders.get_mut(&m)
        {
            *n -= 1;
            if *n == 0 {
                self.mesh_senders.remove(&m);
            }
        }
    }

    pub(crate) fn remember_mesh(&mut self, e: Entity, mesh: AssetId<Mesh>) {
        self.sent_mesh.insert(e, mesh);
        *self.mesh_senders.entry(mesh).or_default() += 1;
    }

    /// Stops `e`'s copy, if any; entities that waited for it are looked at again.
    pub(crate) fn drop_copy(&mut self, e: Entity) {
        if let Some(job) = self.copying.remove(&e) {
            for f in self.followers_of(job.mesh) {
                self.followers.remove(&f);
                self.orphans.push(f);
            }
        }
    }

    /// The entities waiting for a copy of `mesh`.
    pub(crate) fn followers_of(&self, mesh: AssetId<Mesh>) -> Vec<Entity> {
        self.followers
            .iter()
            .filter(|(_, f)| f.mesh == mesh)
            .map(|(&f, _)| f)
            .collect()
    }

    /// Sends `e` as an instance of `mesh`, whose triangles the worker holds for another entity.
    pub(crate) fn send_instance(&mut self, e: Entity, follower: Follower) {
        self.traced.insert(e);
        self.remember_mesh(e, follower.mesh);
        self.send(Command::Instance {
            entity: e,
            mesh: follower.mesh,
            name: follower.name,
            transform: follower.transform,
            sent: follower.started,
        });
    }

    pub(crate) fn send(&self, c: Command) {
        let incoming = c.brings_geometry();
        let triangles = c.new_triangles();
        self.shared.pending.fetch_add(1, Ordering::AcqRel);
        self.shared
            .incoming_triangles
            .fetch_add(triangles, Ordering::AcqRel);
        if incoming {
            self.shared.incoming.fetch_add(1, Ordering::AcqRel);
        }
        if self
            .sender
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .send(c)
            .is_err()
        {
            self.shared.pending.fetch_sub(1, Ordering::AcqRel);
            self.shared
                .incoming_triangles
                .fetch_sub(triangles, Ordering::AcqRel);
            if incoming {
                self.shared.incoming.fetch_sub(1, Ordering::AcqRel);
            }
            error!("the scene BVH worker has stopped");
        }
    }
}
