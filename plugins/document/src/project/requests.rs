//! What the File menu, the command line and the recovery offer ask of the project: new, open,
//! save, import, relink, quit; applied in order each frame. `--save PATH` waits for the scene to
//! settle, saves and exits.

use crate::import::parse::{ParsedImports, PendingImports};
use crate::project::autosave::Autosave;
use crate::project::capture::save_project;
use crate::project::format::ProjectState;
use crate::project::open::{OpenKind, OpeningProjects};
use crate::project::restore::{empty_scene, relink_source};
use crate::project::script::ScriptedEdits;
use crate::scene::notice::Notices;
use crate::scene::outbox::DocumentEvent;
use bevy::prelude::*;
use std::path::PathBuf;

/// What the user (or the command line) asked of the project this frame.
#[derive(Clone, Debug, PartialEq)]
pub enum ProjectRequest {
    /// An empty scene.
    New,
    /// Open a project.
    Open(PathBuf),
    /// Save the project here.
    Save(PathBuf),
    /// Import a scene file into the scene.
    Import(PathBuf),
    /// Close the editor.
    Quit,
    /// Open a recovery copy: the scene it holds, unsaved, belonging to the project it was made for
    /// (the one it lies beside; none for an unsaved scene's copy).
    OpenRecovery(PathBuf),
    /// The user chose to drop the unsaved changes (before New or Open): their recovery copies go.
    DiscardChanges,
    /// Point a missing source at another file.
    Relink {
        /// The source as the project names it (resolved).
        from: PathBuf,
        /// The file to use instead.
        to: PathBuf,
    },
    /// Tell the user that something failed (a dialog that crashed).
    Report(String),
}

/// The frame's project requests, applied by [`apply_project_requests`].
#[derive(Resource, Default, Debug)]
pub struct ProjectRequests(pub Vec<ProjectRequest>);

/// Applies the frame's project requests.
pub fn apply_project_requests(world: &mut World) {
    let requests = std::mem::take(&mut world.resource_mut::<ProjectRequests>().0);
    for request in requests {
        match request {
            ProjectRequest::New => new_scene(world),
            ProjectRequest::Open(path) => world
                .resource_mut::<OpeningProjects>()
                .start(path, OpenKind::Project),
            ProjectRequest::Save(path) => save(world, path),
            ProjectRequest::Import(path) => world.resource_mut::<PendingImports>().start(path),
            ProjectRequest::OpenRecovery(path) => {
                // Whose work it is follows from where the copy lies, never from the scene open
                // now: an unsaved scene's copy saved with Ctrl+S must not land on a project.
                let owner = crate::project::recovery::owner_of_copy(&path);
                if let Some(mut auto) = world.get_resource_mut::<Autosave>() {
                    auto.answered(&path);
                }
                world
                    .resource_mut::<OpeningProjects>()
                    .start(path, OpenKind::Recovery { owner });
            }
            ProjectRequest::Report(e) => world.resource_mut::<Notices>().error(e),
            ProjectRequest::DiscardChanges => {
                if let Some(mut auto) = world.get_resource_mut::<Autosave>() {
                    auto.remove_copy();
                }
            }
            ProjectRequest::Quit => {
                // Quitting with unsaved changes means the user chose to discard them: their
                // recovery copy goes too, or the next start would offer them back.
                if let Some(mut auto) = world.get_resource_mut::<Autosave>() {
                    auto.remove_copy();
                }
                world.write_message(AppExit::Success);
            }
            ProjectRequest::Relink { from, to } => relink(world, from, to),
        }
    }
}

fn save(world: &mut World, path: PathBuf) {
    match save_project(world, &path) {
        Ok(unsaved) => {
            let mut notices = world.resource_mut::<Notices>();
            notices.info(format!("saved {}", path.display()));
            if !unsaved.is_empty() {
                notices.warn(format!(
                    "{}: not saved, their geometry has no source file: {}",
                    path.display(),
                    unsaved.join(", ")
                ));
            }
            world.write_message(DocumentEvent::Saved(path));
        }
        Err(e) => {
            world.resource_mut::<Notices>().error(e.to_string());
            world.write_message(DocumentEvent::SaveFailed(path));
        }
    }
}

fn relink(world: &mut World, from: PathBuf, to: PathBuf) {
    match relink_source(world, &from, &to) {
        Ok(report) => {
            let mut notices = world.resource_mut::<Notices>();
            notices.info(format!(
                "{} now stands for {}",
                to.display(),
                from.display()
            ));
            if report.missing_nodes > 0 {
                notices.warn(format!(
                    "{}: {} objects name nodes it does not have ({}); they stay in the project",
                    to.display(),
                    report.missing_nodes,
                    report.missing_names.join(", ")
                ));
            }
        }
        Err(e) => world.resource_mut::<Notices>().error(e.to_string()),
    }
}

/// An empty scene with a fresh history, not saved anywhere.
fn new_scene(world: &mut World) {
    empty_scene(world);
    world.insert_resource(ProjectState::default());
}

/// `--save PATH`: saves the project once the scene has settled and the scripted commands are in,
/// then exits (unless told to keep running, as for `--frames`).
#[derive(Resource, Debug)]
pub struct SaveWhenSettled {
    /// Where.
    pub path: PathBuf,
    /// Whether the app exits once it has saved.
    pub exit: bool,
    settled: u32,
}

impl SaveWhenSettled {
    /// A save to `path`, then exit.
    pub fn new(path: PathBuf) -> Self {
        Self {
            path,
            exit: true,
            settled: 0,
        }
    }
}

/// Saves for `--save` once nothing is loading and no script waits.
pub fn save_when_settled(world: &mut World) {
    let loading = !world.resource::<PendingImports>().0.is_empty()
        || !world.resource::<ParsedImports>().0.is_empty()
        || world.resource::<OpeningProjects>().busy()
        || world
            .get_resource::<ScriptedEdits>()
            .is_some_and(|s| s.commands.is_some());
    let Some(mut save) = world.get_resource_mut::<SaveWhenSettled>() else {
        return;
    };
    save.settled = if loading { 0 } else { save.settled + 1 };
    if save.settled < 3 {
        return;
    }
    let (path, exit) = (save.path.clone(), save.exit);
    world.remove_resource::<SaveWhenSettled>();
    // A scene whose script could not run is not what was asked to be saved.
    let not_applied = world
        .get_resource::<ScriptedEdits>()
        .and_then(|s| s.failed.clone());
    if let Some(why) = not_applied {
        error!("{}: not saved: {why}", path.display());
        world.write_message(AppExit::error());
        return;
    }
    let code = match save_project(world, &path) {
        Ok(unsaved) => {
            info!("saved {}", path.display());
            if !unsaved.is_empty() {
                warn!("{}: not saved: {}", path.display(), unsaved.join(", "));
            }
            AppExit::Success
        }
        Err(e) => {
            error!("{e}");
            AppExit::error()
        }
    };
    if exit {
        world.write_message(code);
    }
}
