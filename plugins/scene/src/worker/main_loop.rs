//! The background worker that owns the write side of the global tree. Commands arrive over a
//! channel; bBVHs are built in parallel outside the lock, and the lock is held only to graft them.

use crate::types::mesh::{GeometryCopy, MeshPositions};
use crate::types::shading::MeshShading;
use crate::types::tree::{SceneStats, SceneTree};
use crate::worker::chunks::MeshChunks;
use crate::worker::refine::Refiner;
use bevy::asset::AssetId;
use bevy::log::warn;
use bevy::mesh::Mesh;
use bevy::prelude::Entity;
use rayon::prelude::*;
use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::sync::{Arc, Mutex, RwLock};
use std::time::{Duration, Instant};
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{GroupId, IdleUpdates, IdleWork, PreparedGroup};

/// What the main thread asks of the worker.
pub(crate) enum Command {
    /// A new or edited mesh as the main thread copied it (arrays, not yet triangles): the worker
    /// makes its triangles, and it becomes an [`Command::Upsert`].
    Copied {
        entity: Entity,
        mesh: AssetId<Mesh>,
        name: String,
        copy: Box<GeometryCopy>,
        transform: Affine3A,
        eye: Option<Vec3>,
        sent: Instant,
    },
    /// A new or edited mesh (object-space triangles) under a transform.
    Upsert(NewMesh),
    /// An entity whose mesh asset the tree already holds for another entity: it shares those
    /// triangles under its own transform (one instance node, no copy).
    Instance {
        entity: Entity,
        mesh: AssetId<Mesh>,
        name: String,
        transform: Affine3A,
        sent: Instant,
    },
    /// A moved entity.
    Move { entity: Entity, transform: Affine3A },
    /// A despawned or hidden entity, or one whose mesh was removed.
    Remove { entity: Entity },
    /// Panic, as a bug in the worker would: how tests check that the app survives one.
    Crash,
}

/// What an [`Command::Upsert`] carries.
pub(crate) struct NewMesh {
    entity: Entity,
    mesh: AssetId<Mesh>,
    name: String,
    /// Its positions and triangles, taken when its group is built.
    positions: MeshPositions,
    shading: Arc<MeshShading>,
    transform: Affine3A,
    /// The camera's position when it was sent: a mesh inserted in chunks starts nearest it.
    eye: Option<Vec3>,
    sent: Instant,
}

impl Command {
    /// A copied mesh made into triangles (the rest as they are).
    fn with_triangles(self) -> Command {
        match self {
            Command::Copied {
                entity,
                mesh,
                name,
                copy,
                transform,
                eye,
                sent,
            } => {
                let (positions, shading) = copy.finish_positions();
                Command::Upsert(NewMesh {
                    entity,
                    mesh,
                    name,
                    positions,
                    shading: Arc::new(shading),
                    transform,
                    eye,
                    sent,
                })
            }
            c => c,
        }
    }

    /// Whether the command brings geometry to the tree: a new or edited mesh, or an entity sharing
    /// one the tree holds.
    pub(crate) fn brings_geometry(&self) -> bool {
        matches!(
            self,
            Command::Copied { .. } | Command::Upsert(_) | Command::Instance { .. }
        )
    }

    /// The new triangles the command brings to the tree (0 for all but new or edited meshes).
    pub(crate) fn new_triangles(&self) -> usize {
        match self {
            Command::Copied { copy, .. } => copy.triangles(),
            Command::Upsert(m) => m.positions.len(),
            _ => 0,
        }
    }

    fn entity(&self) -> Entity {
        match self {
            Command::Upsert(m) => m.entity,
            Command::Copied { entity, .. }
            | Command::Instance { entity, .. }
            | Command::Move { entity, .. }
            | Command::Remove { entity } => *entity,
            Command::Crash => Entity::PLACEHOLDER,
        }
    }
}

/// State shared between the worker and the main world.
pub(crate) struct Shared {
    pub tree: RwLock<SceneTree>,
    pub stats: Mutex<SceneStats>,
    pub version: AtomicU64,
    pub pending: AtomicUsize,
    /// Of the pending commands, those bringing geometry ([`Command::brings_geometry`]).
    pub incoming: AtomicUsize,
    /// The new triangles those bring ([`Command::new_triangles`]): what the tree will grow by.
    pub incoming_triangles: AtomicUsize,
    /// Set by the app each frame: meshes are being copied out of the world for the worker (an
    /// import streams in). Idle work waits meanwhile: bakes, rebuilds and update steps would take
    /// the cores the new meshes' builds need, and each rebuild swapped in re-lays a group a
    /// renderer must upload again, slowing the frames that copy the rest.
    pub filling: AtomicBool,
    /// Set by the worker while it has work of its own ahead (moved meshes to bake, update steps,
    /// rebuilds, a cost to publish): an app that rests between frames keeps drawing meanwhile.
    pub active: AtomicBool,
    /// Why the worker stopped, once it has (it panicked).
    pub failure: Mutex<Option<String>>,
    /// Why background refinement stopped, once it has; the tree keeps its binned builds.
    pub refine_failure: Arc<Mutex<Option<String>>>,
}

/// Worker settings.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WorkerConfig {
    pub bake_after: Duration,
    pub idle_tick: Duration,
    /// The preset's global updates after each edit.
    pub idle_updates: IdleUpdates,
    /// Meshes larger than this enter the tree in spatial chunks.
    pub chunks: treelight_bvh::PieceRule,
    /// Nice steps below the app's threads ([`crate::types::priority::lower_current_thread`]).
    pub nice: i32,
}

/// New triangles one batch takes at most, beyond its first command. A large import's meshes
/// arrive faster than the tree takes them; a batch of all of them would publish nothing until every
/// one was in, so the first are published within a fraction of a second and the rest follow.
const BATCH_TRIANGLES: usize = 1 << 19;

/// The budget of a batch into a tree that is empty: the first triangles of a fill are on screen
/// after a build of a few meshes, not of a full batch's, which on a busy machine takes a second.
const FIRST_BATCH_TRIANGLES: usize = 1 << 16;

/// New triangles the next batch may take when the tree holds `in_tree`: as many again, between
/// [`FIRST_BATCH_TRIANGLES`] and [`BATCH_TRIANGLES`], so batches double while a fill starts.
fn batch_budget(in_tree: usize) -> usize {
    in_tree.clamp(FIRST_BATCH_TRIANGLES, BATCH_TRIANGLES)
}

/// `first` and the commands after it in `queue`, in order, while their new triangles stay within
/// `budget`; the rest stay queued for the next batch.
fn take_batch(first: Command, queue: &mut VecDeque<Command>, budget: usize) -> Vec<Command> {
    let mut triangles = first.new_triangles();
    let mut batch = vec![first];
    while let Some(next) = queue.front() {
        let n = next.new_triangles();
        if n > 0 && triangles + n > budget {
            break;
        }
        triangles += n;
        batch.extend(queue.pop_front());
    }
    batch
}

/// Keeps only the last word on each entity, in first-mention order. A move after an upsert or an
/// instance edits its transform; a removal supersedes everything. Then new meshes come first,
/// instances second and the rest after, so an instance finds the triangles it shares even when the
/// entity that brought them arrives, or leaves, in the same batch.
fn coalesce(batch: Vec<Command>) -> Vec<Command> {
    let mut order: Vec<Entity> = Vec::new();
    let mut last: HashMap<Entity, Command> = HashMap::new();
    for c in batch {
        let e = c.entity();
        let merged = match (last.remove(&e), c) {
            (Some(Command::Upsert(m)), Command::Move { transform, .. }) => {
                Command::Upsert(NewMesh { transform, ..m })
            }
            (
                Some(Command::Instance {
                    entity,
                    mesh,
                    name,
                    sent,
                    ..
                }),
                Command::Move { transform, .. },
            ) => Command::Instance {
                entity,
                mesh,
                name,
                transform,
                sent,
            },
            (None, c) => {
                order.push(e);
                c
            }
            (Some(_), c) => c,
        };
        last.insert(e, merged);
    }
    let mut out: Vec<Command> = order.into_iter().filter_map(|e| last.remove(&e)).collect();
    // Stable: within each kind the order of first mention stays.
    out.sort_by_key(|c| match c {
        Command::Upsert(_) => 0,
        Command::Instance { .. } => 1,
        _ => 2,
    });
    out
}

/// The worker's loop: commands into the tree on the calling thread (at the fill's priority), the
/// work between them on `background` (at the worker's lower one), where there is such a pool.
pub(crate) fn run(
    shared: Arc<Shared>,
    rx: Receiver<Command>,
    config: WorkerConfig,
    background: Option<&rayon::ThreadPool>,
) {
    let in_background = |work: &mut (dyn FnMut() + Send)| match background {
        Some(pool) => pool.install(work),
        None => work(),
    };
    let mut last_move: HashMap<Entity, Instant> = HashMap::new();
    let mut idle = IdleWork::default();
    let mut clock = CostClock::default();
    // Started from the background thread, the refiner's thread takes its priority from there.
    let mut refiner = None;
    in_background(&mut || {
        refiner = Some(Refiner::start(
            config.nice,
            config.bake_after,
            shared.refine_failure.clone(),
        ));
    });
    let mut refiner = refiner.expect("the refiner was started");
    // Commands received but left for a later batch, oldest first.
    let mut queued: VecDeque<Command> = VecDeque::new();
    loop {
        let filling = shared.filling.load(Ordering::Acquire);
        // With update steps to do, only look for commands; otherwise sleep until one comes.
        let first = if let Some(c) = queued.pop_front() {
            Some(c)
        } else if idle.is_pending() && !filling {
            match rx.try_recv() {
                Ok(c) => Some(c),
                Err(TryRecvError::Empty) => None,
                Err(TryRecvError::Disconnected) => return,
            }
        } else if shared.active.load(Ordering::Acquire) || filling {
            match rx.recv_timeout(config.idle_tick) {
                Ok(c) => Some(c),
                Err(RecvTimeoutError::Timeout) => None,
                Err(RecvTimeoutError::Disconnected) => return,
            }
        } else {
            // Nothing ahead: sleep until a command comes, waking no one.
            match rx.recv() {
                Ok(c) => Some(c),
                Err(_) => return,
            }
        };
        let Some(first) = first else {
            if filling {
                continue;
            }
            in_background(&mut || {
                idle_work(
                    &shared,
                    &mut last_move,
                    config,
                    &mut idle,
                    &mut clock,
                    &mut refiner,
                );
            });
            let ahead = !last_move.is_empty()
                || idle.is_pending()
                || refiner.has_work_ahead()
                || clock.stale;
            if !ahead {
                trim_at_rest(&shared);
            }
            shared.active.store(ahead, Ordering::Release);
            continue;
        };
        // A command brings work (its bake, its updates) and leaves the worker active.
        shared.active.store(true, Ordering::Release);
        queued.extend(rx.try_iter());
        // Only this thread writes the tree: the read waits for no one.
        let in_tree = shared
            .tree
            .read()
            .map_or(0, |t| t.bvh.triangle_count() as usize);
        let batch = take_batch(first, &mut queued, batch_budget(in_tree));
        if batch.iter().any(|c| matches!(c, Command::Crash)) {
            // As a bug mid-edit would: while holding the tree, which is left poisoned.
            let _tree = shared.tree.write();
            panic!("the scene worker was asked to crash");
        }
        let received = batch.len();
        let incoming = batch.iter().filter(|c| c.brings_geometry()).count();
        let incoming_triangles: usize = batch.iter().map(Command::new_triangles).sum();
        // Copied meshes become triangles here, in parallel, rather than on the main thread.
        let batch: Vec<Command> = batch.into_par_iter().map(Command::with_triangles).collect();
        for c in &batch {
            refiner.touched(c.entity());
        }
        let (chunked, mut commands): (Vec<Command>, Vec<Command>) =
            coalesce(batch).into_iter().partition(
                |c| matches!(c, Command::Upsert(m) if config.chunks.cuts(m.positions.len())),
            );
        let started = Instant::now();
        // Huge meshes first, a chunk at a time, each published as soon as it is in (they are new
        // meshes, which the instances of this batch may share, like any other upsert).
        let mut inserted_tris = 0usize;
        let mut latest_sent: Option<Instant> = None;
        for c in chunked {
            if let Command::Upsert(huge) = c {
                last_move.remove(&huge.entity);
                let sent = huge.sent;
                inserted_tris += insert_in_chunks(&shared, &mut clock, received, config, huge);
                latest_sent = Some(latest_sent.map_or(sent, |l: Instant| l.max(sent)));
            }
        }
        // The expensive part, in parallel and without the lock: world transforms and bBVH builds.
        let prepared = prepare_groups(&mut commands);
        {
            let mut guard = shared.tree.write().unwrap_or_else(|p| p.into_inner());
            let tree = &mut *guard;
            let mut edit = Edit {
                last_move: &mut last_move,
                refiner: &mut refiner,
                inserted_tris: &mut inserted_tris,
                latest_sent: &mut latest_sent,
            };
            for (c, p) in commands.into_iter().zip(prepared) {
                edit.apply(tree, c, p);
            }
            idle.after_edit(&config.idle_updates, &tree.bvh);
        }
        // Ready: readers see the new tree from here on.
        let latency = latest_sent.map(|sent| sent.elapsed());
        let elapsed = started.elapsed();
        shared.version.fetch_add(1, Ordering::Release);
        shared.incoming.fetch_sub(incoming, Ordering::AcqRel);
        shared
            .incoming_triangles
            .fetch_sub(incoming_triangles, Ordering::AcqRel);
        publish_stats(&shared, &mut clock, InFlight::Done(received), |s| {
            if inserted_tris > 0 {
                s.insertion_mtris_per_s =
                    inserted_tris as f64 / elapsed.as_secs_f64().max(1e-9) / 1e6;
            }
            if let Some(latency) = latency {
                s.last_latency = latency;
            }
        });
    }
}

/// Each upsert's group built, in parallel and without the lock (world transforms and bBVH
/// builds), its positions taken into it; `None` for other commands and for a mesh that cannot be
/// traced (said why).
fn prepare_groups(commands: &mut [Command]) -> Vec<Option<PreparedGroup>> {
    commands
        .par_iter_mut()
        .map(|c| {
            let Command::Upsert(NewMesh {
                name,
                positions,
                transform,
                entity,
                ..
            }) = c
            else {
                return None;
            };
            let MeshPositions { vertices, corners } = std::mem::take(positions);
            PreparedGroup::build_indexed(vertices, corners, *transform, false)
                .inspect_err(|e| warn!("entity {entity} ('{name}') is not traced: {e}"))
                .ok()
        })
        .collect()
}

/// What applying a batch's commands to the tree updates beside it.
struct Edit<'a> {
    last_move: &'a mut HashMap<Entity, Instant>,
    refiner: &'a mut Refiner,
    inserted_tris: &'a mut usize,
    /// When the latest command of the batch that brought geometry was sent.
    latest_sent: &'a mut Option<Instant>,
}

impl Edit<'_> {
    fn sent(&mut self, sent: Instant) {
        *self.latest_sent = Some(self.latest_sent.map_or(sent, |l: Instant| l.max(sent)));
    }

    /// Applies one command to `tree`, under the write lock; `prepared` is an upsert's group.
    fn apply(&mut self, tree: &mut SceneTree, c: Command, prepared: Option<PreparedGroup>) {
        match c {
            // Made into an upsert on arrival; a crash never gets this far.
            Command::Copied { .. } | Command::Crash => {}
            Command::Remove { entity } => {
                tree.remove_entity(entity);
                self.last_move.remove(&entity);
            }
            Command::Upsert(NewMesh {
                entity,
                mesh,
                sent,
                shading,
                ..
            }) => {
                // A mesh that failed to build keeps its previous version, if any.
                if let Some(p) = prepared {
                    *self.inserted_tris += p.len();
                    tree.remove_entity(entity);
                    match tree.bvh.insert_prepared(p) {
                        Ok(g) => {
                            tree.bind(entity, g, shading, mesh);
                            tree.supersede(entity, mesh);
                            self.refiner.offer(g);
                        }
                        Err(e) => warn!("entity {entity} is not traced: {e}"),
                    }
                    self.last_move.remove(&entity);
                }
                self.sent(sent);
            }
            Command::Instance {
                entity,
                mesh,
                name,
                transform,
                sent,
            } => {
                self.last_move.remove(&entity);
                match tree.share(entity, mesh, transform) {
                    Ok(()) => {}
                    Err(treelight_bvh::BvhError::UnknownGroup) => warn!(
                        "entity {entity} ('{name}') is not traced: no traced entity holds its mesh"
                    ),
                    Err(e) => warn!("entity {entity} ('{name}') is not traced: {e}"),
                }
                self.sent(sent);
            }
            Command::Move { entity, transform } => {
                if let Some(groups) = tree.entity_groups.get(&entity) {
                    // The chunks of one mesh move as one edit.
                    tree.bvh.batch(|bvh| {
                        for &g in groups {
                            if let Err(e) = bvh.set_group_transform(g, transform) {
                                warn!("entity {entity} cannot move in the tree: {e}");
                            }
                        }
                    });
                    self.last_move.insert(entity, Instant::now());
                }
            }
        }
    }
}

/// Inserts a huge mesh as spatial chunks, each a group of its entity, nearest the camera first.
/// Each chunk is built outside the lock and published when it is in, so renderers and picking see
/// the front of the mesh while the rest is built. The entity's previous version stays until the last
/// chunk is in. Returns the triangles inserted.
fn insert_in_chunks(
    shared: &Shared,
    clock: &mut CostClock,
    in_flight: usize,
    config: WorkerConfig,
    huge: NewMesh,
) -> usize {
    let NewMesh {
        entity,
        mesh,
        name,
        positions,
        shading,
        transform,
        eye,
        ..
    } = huge;
    let chunks = match MeshChunks::cut(positions, shading, config.chunks, &transform, eye) {
        Ok(chunks) => chunks,
        Err(e) => {
            // Nothing of it went in: the previous version, if any, stays.
            warn!("entity {entity} ('{name}') is not traced: {e}");
            return 0;
        }
    };
    let old: Vec<GroupId> = shared
        .tree
        .read()
        .unwrap_or_else(|p| p.into_inner())
        .groups_of(entity)
        .to_vec();
    let mut made: Vec<GroupId> = Vec::with_capacity(chunks.len());
    let mut inserted = 0usize;
    for k in 0..chunks.len() {
        // Kept whole and never baked (`MeshChunks::build`).
        let built = chunks.build(k, transform);
        let shading = chunks.shading(k);
        let mut guard = shared.tree.write().unwrap_or_else(|p| p.into_inner());
        let tree = &mut *guard;
        match built.and_then(|p| {
            let n = p.len();
            Ok((tree.bvh.insert_prepared(p)?, n))
        }) {
            Ok((g, n)) => {
                tree.bind(entity, g, Arc::new(shading), mesh);
                made.push(g);
                inserted += n;
            }
            Err(e) => {
                // The whole mesh or nothing: what came in goes, the previous version stays.
                warn!("entity {entity} ('{name}') is not traced: {e}");
                tree.remove_groups(entity, &made);
                return inserted;
            }
        }
        drop(guard);
        shared.version.fetch_add(1, Ordering::Release);
        publish_stats(shared, clock, InFlight::Finishing(in_flight), |_| {});
    }
    let mut tree = shared.tree.write().unwrap_or_else(|p| p.into_inner());
    tree.remove_groups(entity, &old);
    tree.supersede(entity, mesh);
    inserted
}

/// Between commands: bake groups that stopped moving, then one short step of global updates (the
/// post-pass in slices, so the write lock is held for milliseconds, not for a pass over the tree).
fn idle_work(
    shared: &Shared,
    last_move: &mut HashMap<Entity, Instant>,
    config: WorkerConfig,
    idle: &mut IdleWork,
    clock: &mut CostClock,
    refiner: &mut Refiner,
) {
    let still: Vec<Entity> = last_move
        .iter()
        .filter(|(_, t)| t.elapsed() >= config.bake_after)
        .map(|(e, _)| *e)
        .collect();
    if still.is_empty() && !idle.is_pending() && !refiner.has_work() {
        if clock.stale {
            // The last edits were published without their cost; it is due by now.
            publish_stats(shared, clock, InFlight::Finishing(0), |_| {});
        }
        return;
    }
    let baked = !still.is_empty();
    let (moves, refined) = {
        let mut guard = shared.tree.write().unwrap_or_else(|p| p.into_inner());
        let tree = &mut *guard;
        for e in still {
            last_move.remove(&e);
            // The update batch a bake triggers covers the whole mesh, too long to hold the tree
            // in one piece for a big one: the idle steps sweep the tree instead, in slices.
            let groups = tree.entity_groups.get(&e).map_or(&[][..], Vec::as_slice);
            if groups.len() > 1 {
                // A mesh in chunks stays instances (see insert_in_chunks).
                continue;
            }
            // World-space copies of the same triangles: a re-laying, not an edit (a renderer
            // keeps its accumulated image).
            tree.bvh.keeping_geometry(|bvh| {
                bvh.without_updates(|bvh| {
                    for &g in groups {
                        match bvh.bake_group(g) {
                            Ok(()) => refiner.offer(g),
                            Err(err) => warn!("entity {e} could not be baked: {err}"),
                        }
                    }
                })
            });
        }
        // A full-sweep rebuild finished off the lock goes in. Rebuilds start only while no
        // updates run, so the two never hold two cores at once (the frame keeps one), and the
        // updates follow the last rebuild of a series.
        let refined = refiner.finish(tree, last_move);
        if !idle.is_pending() {
            refiner.start_next(tree, last_move);
        }
        if baked || refiner.updates_due() {
            idle.after_edit(&config.idle_updates, &tree.bvh);
        }
        (idle.step(&config.idle_updates, &mut tree.bvh), refined)
    };
    if baked || refined || moves > 0 {
        shared.version.fetch_add(1, Ordering::Release);
        publish_stats(shared, clock, InFlight::Finishing(0), |s| {
            s.meshes_refined += u64::from(refined);
        });
    }
}

/// The least spare room worth giving back: a mebibyte, and an eighth of what the tree holds (a
/// tree that grows by doubling in small steps is not trimmed after every one).
const TRIM_MIN_BYTES: usize = 1 << 20;

/// Going to sleep: gives back the room the tree's arrays kept for growth and the tables its passes
/// sized by the whole tree (after a fill of millions of triangles, hundreds of megabytes), so a
/// scene at rest holds what it uses, and says so in the published figures. The next edit grows
/// what it needs again.
fn trim_at_rest(shared: &Shared) {
    let (spare, held) = shared.tree.read().map_or((0, 0), |t| {
        (t.bvh.spare_bytes(), t.bvh.memory_bytes().total())
    });
    if spare < TRIM_MIN_BYTES || spare * 8 < held {
        return;
    }
    let Ok(mut tree) = shared.tree.write() else {
        return;
    };
    tree.bvh.trim();
    let memory = tree.memory_bytes();
    drop(tree);
    let mut s = shared.stats.lock().unwrap_or_else(|p| p.into_inner());
    (s.tree_bytes, s.shading_bytes) = memory;
}

/// When the SAH cost was last computed. The cost is O(n) (milliseconds on a million triangles), and
/// edits, moves and update steps arrive many times a second, so it is refreshed at most four times a
/// second, and never while further commands wait for the worker.
#[derive(Default)]
pub(crate) struct CostClock {
    at: Option<Instant>,
    /// When the last pass was given up for a command: not tried again for as long.
    given_up: Option<Instant>,
    /// The tree changed since the published cost was computed.
    stale: bool,
}

/// What the caller of [`publish_stats`] is doing with the pending commands.
#[derive(Clone, Copy)]
enum InFlight {
    /// Still finishing this many of them (any more are waiting).
    Finishing(usize),
    /// Done with this many: they leave `pending` as soon as the counts are out, before the cost
    /// pass, so whoever waits for the edit does not wait for the cost too.
    Done(usize),
}

/// Publishes the tree's figures.
fn publish_stats(
    shared: &Shared,
    clock: &mut CostClock,
    in_flight: InFlight,
    edit: impl FnOnce(&mut SceneStats),
) {
    let (InFlight::Finishing(count) | InFlight::Done(count)) = in_flight;
    let waiting = shared.pending.load(Ordering::Acquire) > count;
    let (triangles, nodes) = {
        let tree = shared.tree.read().unwrap_or_else(|p| p.into_inner());
        (tree.bvh.triangle_count(), tree.bvh.inner_count())
    };
    {
        let mut s = shared.stats.lock().unwrap_or_else(|p| p.into_inner());
        s.triangles = triangles;
        s.inner_nodes = nodes;
        edit(&mut s);
    }
    if let InFlight::Done(n) = in_flight {
        shared.pending.fetch_sub(n, Ordering::AcqRel);
    }
    // The counts are out; the cost, a pass over the tree, follows when it is due.
    let quarter = Duration::from_millis(250);
    // Never while commands of this batch are still being applied (between a huge mesh's
    // chunks): the cost follows once they are in.
    let finishing = matches!(in_flight, InFlight::Finishing(n) if n > 0);
    let due = !waiting
        && !finishing
        && clock.at.is_none_or(|at| at.elapsed() >= quarter)
        && clock.given_up.is_none_or(|at| at.elapsed() >= quarter);
    clock.stale = !due;
    if due {
        // A pass over the whole tree: given up as soon as a command comes, so that edits never
        // wait for it (it is due again next time).
        let (cost, memory) = {
            let tree = shared.tree.read().unwrap_or_else(|p| p.into_inner());
            let config = tree.bvh.config();
            // Those this caller is still finishing are not new.
            let ours = match in_flight {
                InFlight::Finishing(n) => n,
                InFlight::Done(_) => 0,
            };
            let cost = tree.bvh.sah_cost_unless(config.c_t, config.c_i, || {
                shared.pending.load(Ordering::Acquire) > ours
            });
            (cost, tree.memory_bytes())
        };
        let mut s = shared.stats.lock().unwrap_or_else(|p| p.into_inner());
        (s.tree_bytes, s.shading_bytes) = memory;
        match cost {
            Some(cost) => {
                s.sah_cost = cost;
                clock.at = Some(Instant::now());
            }
            None => {
                clock.stale = true;
                clock.given_up = Some(Instant::now());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(index: u32, triangles: usize) -> Command {
        Command::Upsert(NewMesh {
            entity: Entity::from_raw_u32(index).unwrap(),
            mesh: AssetId::default(),
            name: format!("mesh {index}"),
            positions: MeshPositions {
                vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
                corners: vec![[0, 1, 2]; triangles],
            },
            shading: Arc::new(MeshShading::default()),
            transform: Affine3A::IDENTITY,
            eye: None,
            sent: Instant::now(),
        })
    }

    fn moved(index: u32) -> Command {
        Command::Move {
            entity: Entity::from_raw_u32(index).unwrap(),
            transform: Affine3A::IDENTITY,
        }
    }

    fn entities(batch: &[Command]) -> Vec<u32> {
        batch.iter().map(|c| c.entity().index_u32()).collect()
    }

    #[test]
    fn a_batch_takes_new_meshes_in_order_up_to_its_budget() {
        let mut queue: VecDeque<Command> =
            [mesh(2, 40), moved(3), mesh(4, 30), mesh(5, 10), moved(6)].into();
        // 50 + 40 fit in 100, then the move, then 30 more would not: the rest waits, in order.
        let batch = take_batch(mesh(1, 50), &mut queue, 100);
        assert_eq!(entities(&batch), [1, 2, 3]);
        assert_eq!(entities(queue.make_contiguous()), [4, 5, 6]);
        let first = queue.pop_front().unwrap();
        let batch = take_batch(first, &mut queue, 100);
        assert_eq!(entities(&batch), [4, 5, 6]);
        assert!(queue.is_empty());
    }

    #[test]
    fn batches_start_small_and_double_with_the_tree() {
        assert_eq!(batch_budget(0), FIRST_BATCH_TRIANGLES);
        assert_eq!(batch_budget(100_000), 100_000);
        assert_eq!(batch_budget(10_000_000), BATCH_TRIANGLES);
        // A fill of 30k-triangle meshes: the first batch is two meshes, then the batches grow.
        let mut queue: VecDeque<Command> = (1..40).map(|i| mesh(i, 30_000)).collect();
        let (mut in_tree, mut sizes) = (0, Vec::new());
        while let Some(first) = queue.pop_front() {
            let batch = take_batch(first, &mut queue, batch_budget(in_tree));
            sizes.push(batch.len());
            in_tree += batch.len() * 30_000;
        }
        assert_eq!(sizes[..5], [2, 2, 4, 8, 16]);
    }

    #[test]
    fn a_first_mesh_over_the_budget_is_a_batch_of_its_own() {
        let mut queue: VecDeque<Command> = [mesh(2, 1), moved(1)].into();
        let batch = take_batch(mesh(1, 500), &mut queue, 100);
        assert_eq!(entities(&batch), [1]);
        assert_eq!(queue.len(), 2);
        // Commands that bring no triangles never wait behind the budget.
        let mut queue: VecDeque<Command> = [moved(2), moved(3)].into();
        let batch = take_batch(mesh(1, 500), &mut queue, 100);
        assert_eq!(entities(&batch), [1, 2, 3]);
    }
}
