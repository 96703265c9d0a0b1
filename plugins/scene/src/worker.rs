//! The background worker that owns the write side of the global tree. Commands arrive over a
//! channel; bBVHs are built in parallel outside the lock, and the lock is held only to graft them.

use crate::{SceneStats, SceneTree, TriangleShading};
use bevy::log::warn;
use bevy::prelude::Entity;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex, RwLock};
use std::time::{Duration, Instant};
use treelight_bvh::glam::Affine3A;
use treelight_bvh::{PostPass, PreparedGroup, Triangle};

/// What the main thread asks of the worker.
pub(crate) enum Command {
    /// A new or edited mesh (object-space triangles) under a transform.
    Upsert {
        entity: Entity,
        name: String,
        triangles: Arc<Vec<Triangle>>,
        shading: Arc<TriangleShading>,
        transform: Affine3A,
        sent: Instant,
    },
    /// A moved entity.
    Move { entity: Entity, transform: Affine3A },
    /// A despawned or hidden entity, or one whose mesh was removed.
    Remove { entity: Entity },
}

impl Command {
    fn entity(&self) -> Entity {
        match self {
            Command::Upsert { entity, .. }
            | Command::Move { entity, .. }
            | Command::Remove { entity } => *entity,
        }
    }
}

/// State shared between the worker and the main world.
pub(crate) struct Shared {
    pub tree: RwLock<SceneTree>,
    pub stats: Mutex<SceneStats>,
    pub version: AtomicU64,
    pub pending: AtomicUsize,
}

/// Worker settings.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WorkerConfig {
    pub bake_after: Duration,
    pub idle_tick: Duration,
}

/// Keeps only the last word on each entity, in first-mention order. A move after an upsert edits
/// the upsert's transform; a removal supersedes everything.
fn coalesce(batch: Vec<Command>) -> Vec<Command> {
    let mut order: Vec<Entity> = Vec::new();
    let mut last: HashMap<Entity, Command> = HashMap::new();
    for c in batch {
        let e = c.entity();
        let merged = match (last.remove(&e), c) {
            (
                Some(Command::Upsert {
                    entity,
                    name,
                    triangles,
                    shading,
                    sent,
                    ..
                }),
                Command::Move { transform, .. },
            ) => Command::Upsert {
                entity,
                name,
                triangles,
                shading,
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
    order.into_iter().filter_map(|e| last.remove(&e)).collect()
}

pub(crate) fn run(shared: Arc<Shared>, rx: Receiver<Command>, config: WorkerConfig) {
    let mut last_move: HashMap<Entity, Instant> = HashMap::new();
    let mut idle_rounds_left = 0u32;
    let mut clock = CostClock::default();
    loop {
        let first = match rx.recv_timeout(config.idle_tick) {
            Ok(c) => Some(c),
            Err(RecvTimeoutError::Timeout) => None,
            Err(RecvTimeoutError::Disconnected) => return,
        };
        let Some(first) = first else {
            idle_work(
                &shared,
                &mut last_move,
                config,
                &mut idle_rounds_left,
                &mut clock,
            );
            continue;
        };
        let mut batch = vec![first];
        batch.extend(rx.try_iter());
        let received = batch.len();
        let commands = coalesce(batch);
        let started = Instant::now();
        // The expensive part, in parallel and without the lock: world transforms and bBVH builds.
        let prepared: Vec<Option<PreparedGroup>> = commands
            .par_iter()
            .map(|c| match c {
                Command::Upsert {
                    name,
                    triangles,
                    transform,
                    entity,
                    ..
                } => match PreparedGroup::build(triangles.to_vec(), *transform, false) {
                    Ok(p) => Some(p),
                    Err(e) => {
                        warn!("entity {entity} ('{name}') is not traced: {e}");
                        None
                    }
                },
                _ => None,
            })
            .collect();
        let mut inserted_tris = 0usize;
        let mut latest_sent: Option<Instant> = None;
        {
            let mut guard = shared.tree.write().unwrap_or_else(|p| p.into_inner());
            let tree = &mut *guard;
            for (c, p) in commands.into_iter().zip(prepared) {
                match c {
                    Command::Remove { entity } => {
                        tree.remove_entity(entity);
                        last_move.remove(&entity);
                    }
                    Command::Upsert {
                        entity,
                        sent,
                        shading,
                        ..
                    } => {
                        // A mesh that failed to build keeps its previous version, if any.
                        if let Some(p) = p {
                            inserted_tris += p.len();
                            tree.remove_entity(entity);
                            match tree.bvh.insert_prepared(p) {
                                Ok(g) => tree.bind(entity, g, shading),
                                Err(e) => warn!("entity {entity} is not traced: {e}"),
                            }
                            last_move.remove(&entity);
                        }
                        latest_sent = Some(latest_sent.map_or(sent, |l: Instant| l.max(sent)));
                    }
                    Command::Move { entity, transform } => {
                        if let Some(&g) = tree.entity_group.get(&entity) {
                            if let Err(e) = tree.bvh.set_group_transform(g, transform) {
                                warn!("entity {entity} cannot move in the tree: {e}");
                            }
                            last_move.insert(entity, Instant::now());
                        }
                    }
                }
            }
        }
        idle_rounds_left = 4;
        let elapsed = started.elapsed();
        shared.version.fetch_add(1, Ordering::Release);
        publish_stats(&shared, &mut clock, |s| {
            if inserted_tris > 0 {
                s.insertion_mtris_per_s =
                    inserted_tris as f64 / elapsed.as_secs_f64().max(1e-9) / 1e6;
            }
            if let Some(sent) = latest_sent {
                s.last_latency = sent.elapsed();
            }
        });
        shared.pending.fetch_sub(received, Ordering::AcqRel);
    }
}

/// Between commands: bake groups that stopped moving, then spend a few rounds on global updates.
fn idle_work(
    shared: &Shared,
    last_move: &mut HashMap<Entity, Instant>,
    config: WorkerConfig,
    rounds_left: &mut u32,
    clock: &mut CostClock,
) {
    let still: Vec<Entity> = last_move
        .iter()
        .filter(|(_, t)| t.elapsed() >= config.bake_after)
        .map(|(e, _)| *e)
        .collect();
    if still.is_empty() && *rounds_left == 0 {
        return;
    }
    {
        let mut guard = shared.tree.write().unwrap_or_else(|p| p.into_inner());
        let tree = &mut *guard;
        for e in still {
            last_move.remove(&e);
            if let Some(&g) = tree.entity_group.get(&e)
                && let Err(err) = tree.bvh.bake_group(g)
            {
                warn!("entity {e} could not be baked: {err}");
            }
        }
        if *rounds_left > 0 {
            *rounds_left -= 1;
            tree.bvh.optimize(PostPass {
                max_rounds: 1,
                fraction: 0.05,
                min_relative_gain: 0.0,
            });
        }
    }
    shared.version.fetch_add(1, Ordering::Release);
    // Baking and update rounds change the cost without changing the triangle count.
    clock.0 = None;
    publish_stats(shared, clock, |_| {});
}

/// When the SAH cost was last computed, and at what triangle count. The cost is O(n), and moves arrive
/// every frame while a mesh is dragged, so it is refreshed when the triangle count changes or at most
/// four times a second.
#[derive(Default)]
pub(crate) struct CostClock(Option<(Instant, u32)>);

fn publish_stats(shared: &Shared, clock: &mut CostClock, edit: impl FnOnce(&mut SceneStats)) {
    let (triangles, nodes, cost) = {
        let tree = shared.tree.read().unwrap_or_else(|p| p.into_inner());
        let triangles = tree.bvh.triangle_count();
        let stale = clock
            .0
            .is_none_or(|(at, n)| n != triangles || at.elapsed() >= Duration::from_millis(250));
        (
            triangles,
            tree.bvh.inner_count(),
            stale.then(|| tree.bvh.sah_cost()),
        )
    };
    let mut s = shared.stats.lock().unwrap_or_else(|p| p.into_inner());
    s.triangles = triangles;
    s.inner_nodes = nodes;
    if let Some(cost) = cost {
        s.sah_cost = cost;
        clock.0 = Some((Instant::now(), triangles));
    }
    edit(&mut s);
}
