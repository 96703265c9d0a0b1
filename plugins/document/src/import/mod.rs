//! Opening scene files (command line, drag and drop, the Assets panel): parsed on a background
//! task by `treelight_import` ([`parse`]), handed to the history as an import command
//! ([`finish`]), spawned as scene objects ([`spawn`]) and followed until the tree holds them
//! ([`jobs`]). Errors become notices; nothing already in the scene is touched by a failed import.

pub mod ask;
pub mod convert;
pub mod finish;
pub mod jobs;
pub mod parse;
pub mod share;
pub mod spawn;

use bevy::prelude::*;
use std::path::Path;

/// Imports as a plugin: the files being parsed, the scenes parsed and waiting for their command,
/// the catalog of what each file held, the system that hands parsed files to the history and
/// those that follow and cancel imports. Drops on a window are the shell's.
pub struct ImportPlugin;

impl Plugin for ImportPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<parse::PendingImports>()
            .init_resource::<parse::ParsedImports>()
            .init_resource::<spawn::SourceCatalog>()
            .init_resource::<share::SharedAssets>()
            .init_resource::<jobs::TracingImports>()
            .init_resource::<jobs::CancelImports>()
            .init_resource::<ask::ImportQuestions>()
            .add_systems(
                Update,
                (
                    (finish::answer_import_questions, finish::finish_imports)
                        .chain()
                        .before(crate::edit::history::apply_edit_requests),
                    // Picked up first, so a cancel in the frame of its step still finds it.
                    (jobs::follow_imports, jobs::cancel_imports)
                        .chain()
                        .after(crate::edit::history::apply_edit_requests),
                ),
            );
    }
}

/// Opens the file named at start: a project is opened in place of the scene, any other scene file
/// imported into it.
pub fn open_at_start(world: &mut World, path: &Path) {
    // The recovery copies to offer are those of the scene named, known now, not once it opened.
    if let Some(mut auto) = world.get_resource_mut::<crate::project::autosave::Autosave>() {
        auto.look_for_start(Some(path));
    }
    if crate::is_project_file(path) {
        world
            .resource_mut::<crate::project::requests::ProjectRequests>()
            .0
            .push(crate::project::requests::ProjectRequest::Open(
                path.to_owned(),
            ));
    } else {
        world
            .resource_mut::<parse::PendingImports>()
            .start(path.to_owned());
    }
}
