//! Idle refinement, the engine's [`Refinement`]: a still, baked mesh's bBVH built again by
//! full-sweep SAH on a thread of its own, and swapped in for the binned one the edit inserted.
//! Edits stay fast (they insert binned trees at once); the tree improves once the user pauses, and
//! the worker keeps answering commands meanwhile.

use crate::types::tree::SceneTree;
use bevy::prelude::Entity;
use std::collections::{HashMap, HashSet, VecDeque};
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::time::Instant;
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{BvhError, GroupId, PreparedGroup, Refinement};

/// A build to make: the group it improves on, its object triangles and transform.
type Job = (GroupId, (Vec<Vec3>, Vec<[u32; 3]>), Affine3A);
/// A build made.
type Built = (GroupId, Result<PreparedGroup, BvhError>);

/// The worker's side of the refinement thread.
pub(crate) struct Refiner {
    jobs: Sender<Job>,
    built: Receiver<Built>,
    /// Baked groups that may be refined, oldest first.
    queue: VecDeque<GroupId>,
    /// The group being rebuilt and its entity; `stale` once the entity was edited meanwhile.
    in_flight: Option<(Entity, GroupId)>,
    stale: bool,
    /// Groups that are refinements: never refined again.
    refined: HashSet<GroupId>,
    /// The last edit, and how long after it the next rebuild may start: rebuilds wait for the
    /// user to pause, so they never take the cores from a stream of edits or an import.
    last_edit: Instant,
    quiet: std::time::Duration,
    /// Rebuilds swapped in since the global updates last ran for them.
    swapped: bool,
}

impl Refiner {
    /// Starts the refinement thread at `nice` steps below the app's threads; rebuilds start once
    /// no edit came for `quiet`.
    /// A panic in a rebuild stops the thread and is written to `failure`; the tree keeps its
    /// binned builds.
    pub(crate) fn start(
        nice: i32,
        quiet: std::time::Duration,
        failure: std::sync::Arc<std::sync::Mutex<Option<String>>>,
    ) -> Self {
        let (jobs, job_rx) = channel::<Job>();
        let (built_tx, built) = channel::<Built>();
        let spawned = std::thread::Builder::new()
            .name("treelight-bvh-refine".into())
            .spawn(move || {
                crate::types::priority::lower_current_thread(nice);
                for (g, world, transform) in job_rx {
                    let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        Refinement::build(world.0, world.1, transform)
                    }));
                    let p = match built {
                        Ok(p) => p,
                        Err(payload) => {
                            let why = crate::types::panics::panic_message(&*payload);
                            bevy::log::error!("background refinement stopped: {why}");
                            *failure.lock().unwrap_or_else(|p| p.into_inner()) = Some(why);
                            return;
                        }
                    };
                    if built_tx.send((g, p)).is_err() {
                        return;
                    }
                }
            });
        if spawned.is_err() {
            bevy::log::warn!("no refinement thread: the tree keeps its binned builds");
        }
        Self {
            jobs,
            built,
            queue: VecDeque::new(),
            in_flight: None,
            stale: false,
            refined: HashSet::new(),
            last_edit: Instant::now(),
            quiet,
            swapped: false,
        }
    }

    /// `g` was baked (inserted baked, or baked once still): a candidate.
    pub(crate) fn offer(&mut self, g: GroupId) {
        if !self.refined.contains(&g) {
            self.queue.push_back(g);
        }
    }

    /// An edit reached `e`: a rebuild of it in flight no longer matches its triangles.
    pub(crate) fn touched(&mut self, e: Entity) {
        self.last_edit = Instant::now();
        if self.in_flight.is_some_and(|(x, _)| x == e) {
            self.stale = true;
        }
    }

    /// Whether `g` can be swapped: the only group of its entity, baked, not moving, its triangles
    /// not shared with another entity, and big enough. Returns its entity.
    fn candidate(
        tree: &SceneTree,
        last_move: &HashMap<Entity, Instant>,
        g: GroupId,
    ) -> Option<Entity> {
        let e = *tree.group_entity.get(&g)?;
        let alone = tree.groups_of(e) == [g]
            && !last_move.contains_key(&e)
            && tree.bvh.is_group_whole(g) == Ok(false)
            && Refinement::is_worth(tree.bvh.group_triangles(g).ok()?.len());
        let shared = tree
            .entity_mesh
            .get(&e)
            .and_then(|m| tree.mesh_entities.get(m))
            .is_some_and(|list| list.len() > 1);
        (alone && !shared).then_some(e)
    }

    /// With nothing in flight, sends the next candidate to the thread (its triangles copied out
    /// under the caller's lock).
    pub(crate) fn start_next(&mut self, tree: &SceneTree, last_move: &HashMap<Entity, Instant>) {
        if self.in_flight.is_some() || !self.is_quiet() {
            return;
        }
        // Refinements of groups that are gone leave the set, which stays bounded by the live ones.
        if self.refined.len() > tree.group_entity.len() {
            self.refined.retain(|g| tree.group_entity.contains_key(g));
        }
        while let Some(g) = self.queue.pop_front() {
            let Some(e) = Self::candidate(tree, last_move, g) else {
                continue;
            };
            let (Ok(world), Ok(transform)) =
                (tree.bvh.group_world_indexed(g), tree.bvh.group_transform(g))
            else {
                continue;
            };
            if self.jobs.send((g, world, transform)).is_ok() {
                self.in_flight = Some((e, g));
                self.stale = false;
            }
            return;
        }
    }

    /// Whether a rebuild is in flight or candidates wait (now or once the edits pause).
    pub(crate) fn has_work_ahead(&self) -> bool {
        self.in_flight.is_some() || !self.queue.is_empty()
    }

    /// Whether a rebuild is in flight, or candidates wait and the edits have paused.
    pub(crate) fn has_work(&self) -> bool {
        self.in_flight.is_some() || (!self.queue.is_empty() && self.is_quiet())
    }

    fn is_quiet(&self) -> bool {
        self.last_edit.elapsed() >= self.quiet
    }

    /// Swaps in a finished rebuild if its group is still as it was sent; returns whether the tree
    /// changed.
    pub(crate) fn finish(
        &mut self,
        tree: &mut SceneTree,
        last_move: &HashMap<Entity, Instant>,
    ) -> bool {
        let (g, built) = match self.built.try_recv() {
            Ok(b) => b,
            Err(TryRecvError::Empty) => return false,
            Err(TryRecvError::Disconnected) => {
                self.in_flight = None;
                return false;
            }
        };
        let sent = self.in_flight.take();
        let Ok(p) = built else {
            return false;
        };
        let Some(e) = Self::candidate(tree, last_move, g) else {
            return false;
        };
        if self.stale || sent != Some((e, g)) {
            return false;
        }
        // Same triangle order, so the shading fits; the same triangles, so no hit changes.
        let Ok(new) = tree.bvh.keeping_geometry(|bvh| bvh.swap_group(g, p)) else {
            return false;
        };
        tree.replace_group(e, g, new);
        self.refined.insert(new);
        self.swapped = true;
        true
    }

    /// Whether the rebuilds swapped in are due their global updates: once no more are coming (a
    /// round of updates after each would sweep the whole tree once per mesh).
    pub(crate) fn updates_due(&mut self) -> bool {
        let due = self.swapped && !self.has_work();
        if due {
            self.swapped = false;
        }
        due
    }
}
