//! Treelight, the editor: a Bevy scene editor whose viewport is a live path-traced preview.
//! The binary `treelight` parses the command line and runs [`build_app`].

pub mod asset_library;
pub mod atomic_file;
pub mod autosave;
pub mod camera;
pub mod capture;
pub mod cli;
pub mod contain;
pub mod crash_report;
pub mod default_scene;
pub mod edit;
pub mod files;
pub mod folders;
pub mod gizmo;
pub mod headless;
pub mod import;
pub mod import_jobs;
pub mod info;
pub mod key_chords;
pub mod keymap;
pub mod notice;
pub mod placement;
pub mod project;
pub mod project_open;
pub mod render_mode;
pub mod report;
pub mod samples;
pub mod scene_id;
pub mod script;
pub mod selection;
pub mod settings;
pub mod system_errors;
pub mod ui;
pub mod viewport;
pub mod worker_watch;
pub mod x11_pointer;

use bevy::camera::visibility::RenderLayers;
use bevy::camera::{CameraOutputMode, ClearColorConfig};
use bevy::diagnostic::FrameTimeDiagnosticsPlugin;
use bevy::prelude::*;
use bevy::render::render_resource::BlendState;
use bevy_egui::{EguiGlobalSettings, EguiPlugin, PrimaryEguiContext};

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

/// Runs the main world's schedules on the thread that updates the app. The editor's main-world
/// systems take a fraction of a millisecond; spread over the compute pool, every hand-off between
/// threads is a wake-up, and while the scene worker or an import holds the cores each wake-up can
/// wait for a core until the scheduler's next tick. Sub-apps (the renderer) keep their executors.
pub fn run_schedules_on_one_thread(app: &mut App) {
    let mut schedules = app
        .world_mut()
        .resource_mut::<bevy::ecs::schedule::Schedules>();
    for (_, schedule) in schedules.iter_mut() {
        schedule.set_executor(bevy::ecs::schedule::SingleThreadedExecutor::new());
    }
}

/// The shortest time between frames (`--max-fps`), if capped.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCap(pub Option<std::time::Duration>);

/// Sleeps out the rest of the frame's share of time under `--max-fps`; input arriving meanwhile
/// waits for the next frame, as it does on a slow adapter.
fn cap_frame_rate(cap: Res<FrameCap>, mut last: Local<Option<std::time::Instant>>) {
    let Some(period) = cap.0 else {
        return;
    };
    if let Some(at) = *last {
        let spent = at.elapsed();
        if spent < period {
            std::thread::sleep(period - spent);
        }
    }
    *last = Some(std::time::Instant::now());
}

/// Nice steps below the frame at which the editor's background work runs.
const BACKGROUND_NICE: i32 = 10;

/// The editor as a Bevy app, configured from the command line; `script` holds the commands of
/// `--commands`, already read.
pub fn build_app(cli: &cli::Cli) -> App {
    build_app_with(cli, None)
}

/// [`build_app`] with the commands `--commands` named, read by the caller (so a bad file stops the
/// start with its error).
pub fn build_app_with(cli: &cli::Cli, script: Option<script::ScriptedEdits>) -> App {
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(task_pools()).set(WindowPlugin {
        primary_window: Some(Window {
            title: "Treelight".into(),
            resolution: bevy::window::WindowResolution::new(cli.width, cli.height),
            ..default()
        }),
        // Closing asks first when there are unsaved changes (files::close_requested).
        close_when_requested: false,
        ..default()
    }))
    .add_plugins((
        EguiPlugin::default(),
        FrameTimeDiagnosticsPlugin::default(),
        // The editor's policy: edits traced at once, the tree improved in idle time.
        treelight_scene::SceneBvhPlugin {
            config: treelight_scene::SceneBvhConfig {
                preset: treelight_scene::Preset::Balanced,
                ..default()
            },
        },
        treelight_render::PathTracerPlugin,
    ))
    .add_plugins((
        key_chords::KeyChordsPlugin,
        import::ImportPlugin,
        edit::EditPlugin,
        selection::SelectionPlugin,
        gizmo::GizmoPlugin,
        camera::CameraPlugin,
        ui::UiPlugin,
        settings::SettingsPlugin,
        files::FilesPlugin,
        autosave::AutosavePlugin,
        import_jobs::ImportJobsPlugin,
        asset_library::AssetLibraryPlugin,
        worker_watch::WorkerWatchPlugin,
        crash_report::CrashReportPlugin,
    ))
    // Errors of systems and commands are reported, not fatal (`system_errors`).
    .set_error_handler(system_errors::report_error)
    .add_systems(Last, system_errors::show_system_errors)
    .insert_resource(ClearColor(Color::srgb(0.08, 0.08, 0.1)))
    .insert_resource(FrameCap(
        cli.max_fps
            .filter(|f| f.is_finite() && *f > 0.0)
            .map(|f| std::time::Duration::from_secs_f32(1.0 / f)),
    ))
    .add_systems(Last, cap_frame_rate)
    .init_resource::<notice::Notices>()
    .init_resource::<project::ProjectState>()
    .insert_resource(render_mode::ViewportRender {
        traced: cli.view.debug_view(),
        settings: treelight_render::PathTraced {
            frame_budget_ms: if cli.frame_budget.is_finite() {
                cli.frame_budget.max(0.0)
            } else {
                0.0
            },
            ..default()
        },
    })
    .add_systems(Startup, (setup_cameras, render_mode::adapt_to_adapter))
    .add_systems(
        Update,
        (
            import::import_dropped_files,
            notice::expire_notices,
            render_mode::apply_viewport_render,
        ),
    );
    match &cli.scene {
        Some(path) => import::open_at_start(app.world_mut(), path),
        None => {
            app.add_systems(
                Startup,
                default_scene::open_default_scene.after(setup_cameras),
            );
        }
    }
    if let Some(path) = &cli.save {
        app.insert_resource(files::SaveWhenSettled::new(path.clone()));
    }
    if let Some(script) = script {
        app.insert_resource(script)
            .add_systems(Update, script::run_scripted_edits);
    }
    if let Some(path) = &cli.state {
        app.insert_resource(report::StateReport::new(path.clone()))
            .init_resource::<report::MainThreadClock>()
            .add_systems(First, report::start_frame_clock)
            .add_systems(
                bevy_egui::EguiPrimaryContextPass,
                (
                    report::start_ui_clock.before(ui::editor_ui),
                    report::stop_ui_clock.after(ui::editor_ui),
                ),
            )
            .add_systems(
                Last,
                (report::stop_frame_clock, report::write_state_report).chain(),
            );
    }
    if cli.screenshot.is_some() || cli.frames.is_some() {
        app.insert_resource(capture::CaptureRequest {
            path: cli.screenshot.clone(),
            frames: cli.frames.unwrap_or(10).max(1),
            rendered: 0,
            requested: false,
        })
        .add_systems(Last, capture::count_frames_and_capture);
    }
    run_schedules_on_one_thread(&mut app);
    app
}

/// Whether `path` names a project (`.treelight`) rather than a scene file to import.
pub fn is_project_file(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("treelight"))
}

fn setup_cameras(mut commands: Commands, mut egui_settings: ResMut<EguiGlobalSettings>) {
    let orbit = camera::OrbitCamera::default();
    commands.spawn((
        Name::new("Editor camera"),
        Camera3d::default(),
        orbit.transform(),
        orbit,
    ));
    // egui gets its own camera drawn over the 3D view, so the 3D camera's viewport can shrink to the
    // viewport panel without clipping the panels.
    egui_settings.auto_create_primary_context = false;
    commands.spawn((
        Name::new("Editor UI camera"),
        // egui antialiases its own shapes; multisampling this camera would only add a copy of the
        // whole window each frame (Bevy's MSAA writeback of the 3D camera's output).
        Msaa::Off,
        PrimaryEguiContext,
        Camera2d,
        RenderLayers::none(),
        Camera {
            order: 1,
            output_mode: CameraOutputMode::Write {
                blend_state: Some(BlendState::ALPHA_BLENDING),
                clear_color: ClearColorConfig::None,
            },
            clear_color: ClearColorConfig::Custom(Color::NONE),
            ..default()
        },
    ));
}
