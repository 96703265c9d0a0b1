//! Treelight's document core: the edited scene without a window, egui or a renderer. Objects and
//! their stable ids ([`object`]), commands and their history ([`edit`]), imports ([`import`]),
//! projects with autosave, scripts and `info` ([`project`]), the placement rule ([`placement`])
//! and the default scene. What an editor must answer (select what an edit made, frame an import,
//! restore a project's view) leaves as [`outbox::DocumentEvent`] messages; the core never reaches
//! into whoever shows it.

#![warn(missing_docs)]

pub mod app;
pub mod atomic_file;
pub mod camera;
pub mod contain;
pub mod default_scene;
pub mod edit;
pub mod environment;
pub mod folders;
pub mod hierarchy;
pub mod import;
pub mod job;
pub mod light;
pub mod look;
pub mod map_transforms;
pub mod notice;
pub mod object;
pub mod outbox;
pub mod own_file;
pub mod placement;
pub mod primitive;
pub mod project;

use bevy::prelude::*;

/// The document: ids, the history and its requests, imports, project requests and background
/// opening, notices and the messages for the shell. `Update` applies project requests, finishes
/// opening projects, runs a waiting script and applies edit requests, in that order; then
/// `--save`'s save, once the scene has settled.
pub struct DocumentPlugin;

impl Plugin for DocumentPlugin {
    fn build(&self, app: &mut App) {
        use edit::history::apply_edit_requests;
        use project::{open, requests, script};
        app.add_plugins((edit::EditPlugin, import::ImportPlugin))
            .add_message::<outbox::DocumentEvent>()
            .init_resource::<outbox::DocumentView>()
            .init_resource::<look::SceneLook>()
            .init_resource::<map_transforms::MaterialMapTransforms>()
            .init_resource::<environment::SceneEnvironment>()
            .init_resource::<environment::LoadedEnvironment>()
            .init_resource::<notice::Notices>()
            .init_resource::<project::format::ProjectState>()
            .init_resource::<requests::ProjectRequests>()
            .init_resource::<open::OpeningProjects>()
            .add_systems(
                Update,
                (
                    (
                        requests::apply_project_requests,
                        open::finish_opening,
                        script::run_scripted_edits.run_if(resource_exists::<script::ScriptedEdits>),
                        apply_edit_requests,
                    )
                        .chain(),
                    requests::save_when_settled.after(apply_edit_requests),
                    environment::load_environment.after(apply_edit_requests),
                    notice::expire_notices,
                    map_transforms::forget_removed,
                ),
            );
    }
}

/// Whether `path` names a project (`.treelight`) rather than a scene file to import.
pub fn is_project_file(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("treelight"))
}
