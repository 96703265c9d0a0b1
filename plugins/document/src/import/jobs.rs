//! Imports in flight, from parsing until the scene BVH holds every mesh: what the status bar's
//! progress shows, and cancelling one, which leaves nothing behind and no history step.

use crate::edit::history::EditHistory;
use crate::import::parse::{ParsedImports, PendingImports};
use crate::scene::notice::Notices;
use crate::values::object::{SceneId, SceneIndex};
use bevy::prelude::*;
use std::path::PathBuf;
use std::time::Instant;
use treelight_scene::SceneBvh;

/// An import whose objects are in the scene while the tree takes in its meshes (nearest the
/// camera first).
#[derive(Clone, Debug)]
pub struct TracingImport {
    /// The file.
    pub file: PathBuf,
    /// Its root object.
    pub root: SceneId,
    /// The history's position just after its step: it can be cancelled while that is the head.
    pub step: usize,
    /// Its mesh objects and their triangle counts.
    pub meshes: Vec<(Entity, u64)>,
    /// Triangles of its meshes the tree holds, as of the last look.
    pub traced: u64,
    /// When its file was asked for.
    pub started: Instant,
}

impl TracingImport {
    /// Triangles in all its meshes.
    pub fn total(&self) -> u64 {
        self.meshes.iter().map(|m| m.1).sum()
    }

    /// The part of its triangles the tree holds, 0 to 1.
    pub fn fraction(&self) -> f32 {
        let total = self.total();
        if total == 0 {
            1.0
        } else {
            self.traced as f32 / total as f32
        }
    }
}

/// Imports past parsing, until the tree holds all of them.
#[derive(Resource, Default)]
pub struct TracingImports {
    /// In the order they were opened.
    pub jobs: Vec<TracingImport>,
    /// Imports whose command was asked for and whose root (by the id it will have) is not yet in
    /// the scene, with their file.
    pub(crate) awaiting: Vec<(SceneId, PathBuf, Instant)>,
}

impl TracingImports {
    /// Whether no import is being traced or awaited.
    pub fn is_empty(&self) -> bool {
        self.jobs.is_empty() && self.awaiting.is_empty()
    }
}

/// What the status bar's Cancel buttons (and tests) ask: stop importing these files.
#[derive(Resource, Default)]
pub struct CancelImports(pub Vec<PathBuf>);

/// A mesh's triangles; 0 for one whose vertex data is not in the main world (an app that frees
/// it once traced, `SceneBvhConfig::release_traced_meshes`).
fn triangles_of(mesh: &Mesh) -> u64 {
    let corners = match mesh.try_indices_option() {
        Ok(Some(indices)) => indices.len(),
        Ok(None) => mesh
            .try_attribute(Mesh::ATTRIBUTE_POSITION)
            .map_or(0, |p| p.len()),
        Err(_) => 0,
    };
    (corners / 3) as u64
}

/// Mesh objects under `root` (itself included) with their triangle counts.
fn meshes_under(world: &World, root: Entity) -> Vec<(Entity, u64)> {
    let meshes = world.resource::<Assets<Mesh>>();
    let scene = world.get_resource::<SceneBvh>();
    let mut out = Vec::new();
    let mut stack = vec![root];
    while let Some(e) = stack.pop() {
        if let Some(m) = world.get::<Mesh3d>(e) {
            // A parked mesh (shared with an earlier import) counts as its parked data says.
            let parked = scene.and_then(|s| s.parked_triangles(m.0.id()));
            let tris =
                parked.map_or_else(|| meshes.get(&m.0).map_or(0, triangles_of), |t| t as u64);
            out.push((e, tris));
        }
        if let Some(children) = world.get::<Children>(e) {
            stack.extend(children.iter());
        }
    }
    out
}

/// Picks up each requested import once its step is in the history, and follows the tree taking
/// in its meshes until it holds all of them.
pub fn follow_imports(world: &mut World) {
    let mut jobs = std::mem::take(&mut *world.resource_mut::<TracingImports>());
    if !jobs.awaiting.is_empty() {
        let head = world.resource::<EditHistory>().head();
        jobs.awaiting.retain(|(root, file, started)| {
            let Some(e) = world.resource::<SceneIndex>().entity(*root) else {
                // An import the history refused never appears: not waited for past a while.
                return started.elapsed().as_secs() < 30;
            };
            jobs.jobs.push(TracingImport {
                file: file.clone(),
                root: *root,
                step: head,
                meshes: meshes_under(world, e),
                traced: 0,
                started: *started,
            });
            false
        });
    }
    if !jobs.jobs.is_empty() {
        let index = world.resource::<SceneIndex>();
        let alive: Vec<bool> = jobs
            .jobs
            .iter()
            .map(|j| index.entity(j.root).is_some())
            .collect();
        let mut finished = Vec::new();
        if let Some(tree) = world.resource::<SceneBvh>().try_read() {
            for (k, job) in jobs.jobs.iter_mut().enumerate() {
                // A huge mesh enters in chunks: its share grows with each one.
                job.traced = job
                    .meshes
                    .iter()
                    .map(|&(e, n)| {
                        let groups = tree.groups_of(e);
                        let in_tree: u64 = groups
                            .iter()
                            .filter_map(|&g| tree.bvh.shared_triangles(g).ok())
                            .map(|t| t.len() as u64)
                            .sum();
                        n.min(in_tree)
                    })
                    .sum();
                if !alive[k] || job.traced >= job.total() {
                    finished.push(k);
                }
            }
        }
        for k in finished.into_iter().rev() {
            let job = jobs.jobs.remove(k);
            if alive[k] {
                world.resource_mut::<Notices>().info(format!(
                    "{} is in the tree ({} triangles, {:.1} s)",
                    job.file.display(),
                    job.total(),
                    job.started.elapsed().as_secs_f32()
                ));
            }
        }
    }
    *world.resource_mut::<TracingImports>() = jobs;
}

/// Stops the imports asked for: a file still being parsed is dropped; one whose objects are in the
/// scene is taken back with its step, as if never opened (while nothing was edited after it).
pub fn cancel_imports(world: &mut World) {
    let files = std::mem::take(&mut world.resource_mut::<CancelImports>().0);
    for file in files {
        let mut pending = world.resource_mut::<PendingImports>();
        let before = pending.0.len();
        pending.0.retain(|p| p.path != file);
        let parsing = pending.0.len() != before;
        let mut jobs = world.resource_mut::<TracingImports>();
        let awaited: Vec<SceneId> = jobs
            .awaiting
            .iter()
            .filter(|(_, p, _)| *p == file)
            .map(|(root, _, _)| *root)
            .collect();
        jobs.awaiting.retain(|(_, p, _)| *p != file);
        let job = jobs
            .jobs
            .iter()
            .position(|j| j.file == file)
            .map(|k| jobs.jobs.remove(k));
        let mut parsed = world.resource_mut::<ParsedImports>();
        for root in awaited {
            parsed.0.remove(&root);
        }
        let message = match job {
            Some(job) if world.resource::<EditHistory>().head() == job.step => {
                world.resource_scope(|world, mut history: Mut<EditHistory>| {
                    history.cancel_last(world);
                });
                format!("import of {} cancelled", file.display())
            }
            Some(job) => {
                // Later edits build on it: taking it back is Undo's job.
                world.resource_mut::<TracingImports>().jobs.push(job);
                format!(
                    "{} was edited after it was opened: use Undo to take it back",
                    file.display()
                )
            }
            None if parsing => format!("import of {} cancelled", file.display()),
            None => continue,
        };
        world.resource_mut::<Notices>().info(message);
    }
}
