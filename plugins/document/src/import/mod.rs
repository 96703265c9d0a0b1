//! Opening scene files (command line, drag and drop, the Assets panel): parsed on a background
//! task by `treelight_import` ([`parse`]), handed to the history as an import command
//! ([`finish`]), spawned as scene objects (`crate::scene::spawn`) and followed until the tree
//! holds them ([`jobs`]). Errors become notices; nothing already in the scene is touched by a failed import.

pub mod ask;
pub mod finish;
pub mod jobs;
pub mod parse;

use bevy::prelude::*;

/// Imports as a plugin: the files being parsed, the scenes parsed and waiting for their command,
/// the catalog of what each file held, the system that hands parsed files to the history and
/// those that follow and cancel imports. Drops on a window are the shell's.
pub struct ImportPlugin;

impl Plugin for ImportPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<parse::PendingImports>()
            .init_resource::<parse::ParsedImports>()
            .init_resource::<crate::scene::spawn::SourceCatalog>()
            .init_resource::<crate::scene::share::SharedAssets>()
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
