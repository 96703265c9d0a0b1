//! The editor's scene without a window or a renderer: objects and their ids, the command path and
//! its history, imports, projects and the scene BVH. `treelight FILE [--commands EDITS.ron] --save
//! OUT.treelight` runs on it where there is no display, and tests and benchmarks build on it.

use crate::edit::{EditHistory, EditRequests, apply_edit_requests};
use crate::files::{FileUi, ProjectRequests, RecentProjects};
use crate::notice::Notices;
use crate::project::ProjectState;
use crate::scene_id::SceneIndex;
use crate::selection::Selection;
use bevy::asset::AssetPlugin;
use bevy::camera::visibility::VisibilityPlugin;
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use treelight_scene::{SceneBvhConfig, SceneBvhPlugin};

/// Assets, transforms, visibility, the scene BVH (under `config`), ids, the history, imports and
/// projects; `Update` runs imports, project requests and edit requests, in that order.
pub fn headless_app(config: SceneBvhConfig) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins.set(crate::task_pools()),
        AssetPlugin::default(),
        MeshPlugin,
        TransformPlugin,
        VisibilityPlugin,
        SceneBvhPlugin { config },
        crate::import::ImportPlugin,
        crate::import_jobs::ImportJobsPlugin,
    ))
    .init_asset::<StandardMaterial>()
    .init_asset::<Image>()
    .init_resource::<SceneIndex>()
    .init_resource::<EditHistory>()
    .init_resource::<EditRequests>()
    .init_resource::<Selection>()
    .init_resource::<Notices>()
    .init_resource::<ProjectState>()
    .init_resource::<ProjectRequests>()
    .init_resource::<FileUi>()
    .init_resource::<RecentProjects>()
    .init_resource::<crate::project_open::OpeningProjects>()
    .add_systems(
        Update,
        (
            crate::files::apply_project_requests,
            crate::project_open::finish_opening,
            apply_edit_requests,
        )
            .chain(),
    );
    crate::run_schedules_on_one_thread(&mut app);
    app
}

/// `treelight [FILE] [--commands EDITS.ron] --save OUT` without a window: opens or imports FILE
/// (the default scene without one), applies the commands once the tree is idle, saves and exits.
pub fn save_app(cli: &crate::cli::Cli, script: Option<crate::script::ScriptedEdits>) -> App {
    let mut app = headless_app(SceneBvhConfig::default());
    app.add_plugins(bevy::log::LogPlugin::default());
    match &cli.scene {
        Some(path) => crate::import::open_at_start(app.world_mut(), path),
        None => {
            app.add_systems(Startup, crate::default_scene::open_default_scene);
        }
    }
    if let Some(script) = script {
        app.insert_resource(script).add_systems(
            Update,
            crate::script::run_scripted_edits.before(apply_edit_requests),
        );
    }
    if let Some(path) = &cli.save {
        app.insert_resource(crate::files::SaveWhenSettled::new(path.clone()))
            .add_systems(
                Update,
                crate::files::save_when_settled.after(apply_edit_requests),
            );
    }
    // A file that cannot be opened ends the run with its error, instead of saving an empty scene.
    app.add_systems(Last, fail_on_errors);
    app
}

/// Ends a headless run with a failure when a notice reports an error (a file that would not open).
fn fail_on_errors(notices: Res<Notices>, mut exit: MessageWriter<AppExit>) {
    if notices.has_errors() {
        exit.write(AppExit::error());
    }
}
