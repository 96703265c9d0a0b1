//! The document as an app without a window or a renderer: `treelight FILE [--commands EDITS.ron]
//! --save OUT.treelight` runs on it where there is no display, and tests and benchmarks build on
//! it. Also the task pools and the schedule executor the editor shares with it.

use crate::project::requests::SaveWhenSettled;
use crate::project::script::ScriptedEdits;
use crate::scene::notice::Notices;
use bevy::asset::AssetPlugin;
use bevy::camera::visibility::VisibilityPlugin;
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use std::path::{Path, PathBuf};
use treelight_scene::{SceneBvhConfig, SceneBvhPlugin};

/// Whether the scene has settled: no import or sky panorama being read or spawned, every
/// import's meshes in the tree, no project opening, and the scene BVH idle (what the state report
/// and a windowless render wait for; they add that a renderer's copy is current).
#[derive(bevy::ecs::system::SystemParam)]
pub struct SceneLoading<'w> {
    pending: Res<'w, crate::import::parse::PendingImports>,
    parsed: Res<'w, crate::import::parse::ParsedImports>,
    tracing: Res<'w, crate::import::jobs::TracingImports>,
    opening: Res<'w, crate::project::open::OpeningProjects>,
    scene: Res<'w, treelight_scene::SceneBvh>,
    environment: Res<'w, crate::scene::environment::LoadedEnvironment>,
}

impl SceneLoading<'_> {
    /// Nothing is loading and the tree is idle.
    pub fn settled(&self) -> bool {
        self.pending.0.is_empty()
            && self.parsed.0.is_empty()
            && self.tracing.jobs.is_empty()
            && self.tracing.awaiting.is_empty()
            && !self.opening.busy()
            && self.scene.is_idle()
            && !self.environment.loading()
    }

    /// The scene tree's version now: a renderer's copy is current when it holds this one.
    pub fn scene_version(&self) -> u64 {
        self.scene.version()
    }

    /// The scene plugin's state.
    pub fn scene(&self) -> &treelight_scene::SceneBvh {
        &self.scene
    }
}

use crate::files::job::BACKGROUND_NICE;

/// Bevy's task pools as the editor wants them: the async compute pool (parsing imports, making
/// thumbnails) runs below the frame's priority, as the scene worker does, so that on a machine with
/// few cores an import never takes the cores the frame's systems wait for.
pub fn task_pools() -> TaskPoolPlugin {
    let mut options = TaskPoolOptions::default();
    options.async_compute.on_thread_spawn = Some(std::sync::Arc::new(|| {
        treelight_scene::priority::lower_current_thread(BACKGROUND_NICE)
    }));
    TaskPoolPlugin {
        task_pool_options: options,
    }
}

/// Runs the main world's schedules on the thread that updates the app. The main-world systems take
/// a fraction of a millisecond; spread over the compute pool, every hand-off between threads is a
/// wake-up, and while the scene worker or an import holds the cores each wake-up can wait for a
/// core until the scheduler's next tick. Sub-apps (the renderer) keep their executors.
pub fn run_schedules_on_one_thread(app: &mut App) {
    let mut schedules = app
        .world_mut()
        .resource_mut::<bevy::ecs::schedule::Schedules>();
    for (_, schedule) in schedules.iter_mut() {
        schedule.set_executor(bevy::ecs::schedule::SingleThreadedExecutor::new());
    }
}

/// Assets, transforms, visibility, the scene BVH (under `config`) and the document
/// ([`DocumentPlugin`]).
pub fn headless_app(config: SceneBvhConfig) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins.set(task_pools()),
        AssetPlugin::default(),
        MeshPlugin,
        TransformPlugin,
        VisibilityPlugin,
        SceneBvhPlugin { config },
        DocumentPlugin,
    ))
    .init_asset::<StandardMaterial>()
    .init_asset::<Image>();
    run_schedules_on_one_thread(&mut app);
    app
}

/// `treelight [FILE] [--commands EDITS.ron] --save OUT` without a window: opens or imports `scene`
/// (the default scene without one), applies the commands once the tree is idle, saves to `save`
/// and exits.
pub fn save_app(scene: Option<&Path>, save: Option<PathBuf>, script: Option<ScriptedEdits>) -> App {
    let mut app = headless_app(SceneBvhConfig::default());
    app.add_plugins(bevy::log::LogPlugin::default());
    match scene {
        Some(path) => crate::app::open_at_start(app.world_mut(), path),
        None => {
            app.add_systems(Startup, crate::default_scene::open_default_scene);
        }
    }
    if let Some(script) = script {
        app.insert_resource(script);
    }
    if let Some(path) = save {
        app.insert_resource(SaveWhenSettled::new(path));
    }
    // A file that cannot be opened ends the run with its error, instead of saving an empty scene.
    app.add_systems(Last, fail_on_errors);
    app
}

/// Ends a headless run with a failure when a notice reports an error (a file that would not open).
pub fn fail_on_errors(notices: Res<Notices>, mut exit: MessageWriter<AppExit>) {
    if notices.has_errors() {
        exit.write(AppExit::error());
    }
}

/// Opens the file named at start: a project is opened in place of the scene, any other scene file
/// imported into it.
pub fn open_at_start(world: &mut World, path: &Path) {
    // The recovery copies to offer are those of the scene named, known now, not once it opened.
    if let Some(mut auto) = world.get_resource_mut::<crate::project::autosave::Autosave>() {
        auto.look_for_start(Some(path));
    }
    if crate::files::file_kind::is_project_file(path) {
        world
            .resource_mut::<crate::project::requests::ProjectRequests>()
            .0
            .push(crate::project::requests::ProjectRequest::Open(
                path.to_owned(),
            ));
    } else {
        world
            .resource_mut::<crate::import::parse::PendingImports>()
            .start(path.to_owned());
    }
}

/// The document: ids, the history and its requests, imports, project requests and background
/// opening, notices and the messages for the shell. `Update` applies project requests, finishes
/// opening projects, runs a waiting script and applies edit requests, in that order; then
/// `--save`'s save, once the scene has settled.
pub struct DocumentPlugin;

impl Plugin for DocumentPlugin {
    fn build(&self, app: &mut App) {
        use crate::edit::history::apply_edit_requests;
        use crate::project::{open, requests, script};
        app.add_plugins((crate::edit::EditPlugin, crate::import::ImportPlugin))
            .add_message::<crate::scene::outbox::DocumentEvent>()
            .init_resource::<crate::scene::outbox::DocumentView>()
            .init_resource::<crate::values::look::SceneLook>()
            .init_resource::<crate::values::map_transforms::MaterialMapTransforms>()
            .init_resource::<crate::scene::environment::SceneEnvironment>()
            .init_resource::<crate::scene::environment::LoadedEnvironment>()
            .init_resource::<crate::scene::notice::Notices>()
            .init_resource::<crate::scene::spawn::DefaultSun>()
            .init_resource::<crate::project::format::ProjectState>()
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
                    crate::scene::environment::load_environment.after(apply_edit_requests),
                    crate::scene::notice::expire_notices,
                    crate::values::map_transforms::forget_removed,
                ),
            );
    }
}
