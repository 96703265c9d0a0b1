//! Watching the scene's background threads: a scene BVH worker or refinement thread that crashed
//! is reported once as a notice and stays in the status bar; imports waiting for the tree stop
//! waiting. The scene stays editable (the tree no longer follows it until the editor restarts).

use bevy::prelude::*;
use treelight_document::import::jobs::TracingImports;
use treelight_document::scene::notice::Notices;
use treelight_scene::SceneBvh;

/// What has gone wrong with the scene's background threads, for the status bar.
#[derive(Resource, Debug, Default, Clone, PartialEq)]
pub struct WorkerHealth {
    /// Why the scene BVH worker stopped, once it has.
    pub worker: Option<String>,
    /// Why background refinement stopped, once it has.
    pub refinement: Option<String>,
}

impl WorkerHealth {
    /// One line for the status bar, when something stopped.
    pub fn status(&self) -> Option<String> {
        match (&self.worker, &self.refinement) {
            (Some(_), _) => {
                Some("BVH worker stopped: the traced view no longer follows edits".into())
            }
            (None, Some(_)) => Some("BVH refinement stopped".into()),
            _ => None,
        }
    }
}

/// Notices a crash of the worker or the refinement thread, once each.
pub fn watch_workers(world: &mut World) {
    let Some(scene) = world.get_resource::<SceneBvh>() else {
        return;
    };
    let (worker, refinement) = (scene.worker_failure(), scene.refinement_failure());
    let mut health = world.resource_mut::<WorkerHealth>();
    let new_worker = worker.is_some() && health.worker.is_none();
    let new_refinement = refinement.is_some() && health.refinement.is_none();
    if !new_worker && !new_refinement {
        return;
    }
    health.worker = worker.clone();
    health.refinement = refinement.clone();
    if let (true, Some(why)) = (new_worker, worker) {
        // Imports waiting to be traced will never be: they stop waiting, their objects stay.
        let stranded: Vec<String> =
            std::mem::take(&mut world.resource_mut::<TracingImports>().jobs)
                .into_iter()
                .map(|j| j.file.display().to_string())
                .collect();
        let mut text = format!(
            "The scene BVH worker crashed ({why}); this is a bug in Treelight. The scene stays \
             editable and can be saved, but the traced view no longer follows edits: save and \
             restart the editor."
        );
        if !stranded.is_empty() {
            text.push_str(&format!(" Not traced: {}.", stranded.join(", ")));
        }
        world.resource_mut::<Notices>().error(text);
    }
    if let (true, Some(why)) = (new_refinement, refinement) {
        world.resource_mut::<Notices>().warn(format!(
            "background BVH refinement crashed ({why}); the tree keeps its first builds"
        ));
    }
}

/// Registers [`WorkerHealth`] and its watch.
pub struct WorkerWatchPlugin;

impl Plugin for WorkerWatchPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<WorkerHealth>()
            .add_systems(Update, watch_workers);
    }
}
