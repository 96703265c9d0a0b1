//! Treelight, the editor: a Bevy scene editor whose viewport is a live path-traced preview.
//! The binary `treelight` parses the command line and runs [`build_app`].

#![warn(missing_docs)]

pub mod capture;
pub mod cli;
pub mod compare;
pub mod editor;
pub mod heap_trim;
pub mod render_errors;
pub mod render_file;
pub mod report;
pub mod system_errors;

use bevy::diagnostic::FrameTimeDiagnosticsPlugin;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::settings::{RenderCreation, WgpuLimits, WgpuSettings};
use bevy_egui::EguiPlugin;
use editor::core::viewport_render::ViewportRender;
use treelight_document::DocumentPlugin;
use treelight_document::app::{run_schedules_on_one_thread, task_pools};
use treelight_document::default_scene::open_default_scene;
use treelight_document::project::autosave::AutosavePlugin;
use treelight_document::project::requests::SaveWhenSettled;
use treelight_document::project::script::ScriptedEdits;

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

/// The editor as a Bevy app, configured from the command line; `script` holds the commands of
/// `--commands`, already read.
pub fn build_app(cli: &cli::Cli) -> App {
    build_app_with(cli, None)
}

/// [`build_app`] with the commands `--commands` named, read by the caller (so a bad file stops the
/// start with its error).
pub fn build_app_with(cli: &cli::Cli, script: Option<ScriptedEdits>) -> App {
    let mut app = App::new();
    // The path tracer's large buffers get memory of their own whatever the hint; smaller blocks
    // for the rest reserve less memory nothing uses (on a software adapter, the process's own).
    let mut wgpu = WgpuSettings {
        memory_hints: bevy::render::settings::MemoryHints::MemoryUsage,
        ..default()
    };
    if let Some(kib) = cli.gpu_binding_limit {
        // The other limits are capped at WebGPU's defaults, except the storage buffers a stage
        // binds: the adapter's own, which the path tracer's split records need.
        wgpu.constrained_limits = Some(WgpuLimits {
            max_storage_buffer_binding_size: u64::from(kib) << 10,
            max_storage_buffers_per_shader_stage: u32::MAX,
            ..default()
        });
    }
    let render = RenderPlugin {
        render_creation: RenderCreation::Automatic(Box::new(wgpu)),
        ..default()
    };
    app.add_plugins(
        DefaultPlugins
            .set(task_pools())
            .set(render)
            .set(WindowPlugin {
                primary_window: Some(Window {
                    title: "Treelight".into(),
                    resolution: bevy::window::WindowResolution::new(cli.width, cli.height),
                    ..default()
                }),
                // Closing asks first when there are unsaved changes (editor::files::file_menu).
                close_when_requested: false,
                ..default()
            }),
    )
    .add_plugins((
        EguiPlugin::default(),
        FrameTimeDiagnosticsPlugin::default(),
        // The editor's policy: edits traced at once, the tree improved in idle time; a mesh's
        // vertices compressed while only the tree is read (the raster view, showing a hidden
        // object and undoing a delete put them back first).
        treelight_scene::SceneBvhPlugin {
            config: treelight_scene::SceneBvhConfig {
                preset: treelight_scene::Preset::Balanced,
                park_meshes: true,
                ..default()
            },
        },
        treelight_render::PathTracerPlugin,
        DocumentPlugin,
        editor::EditorPlugin,
        heap_trim::HeapTrimPlugin,
    ))
    // Errors of systems and commands are reported, not fatal (`system_errors`).
    .set_error_handler(system_errors::report_error)
    // GPU errors are reported, not fatal (`render_errors`).
    .insert_resource(render_errors::handler())
    .add_systems(Last, system_errors::show_system_errors)
    .insert_resource(ClearColor(Color::srgb(0.08, 0.08, 0.1)))
    .insert_resource(FrameCap(
        cli.max_fps
            .filter(|f| f.is_finite() && *f > 0.0)
            .map(|f| std::time::Duration::from_secs_f32(1.0 / f)),
    ))
    .add_systems(Last, cap_frame_rate)
    // A run that ends by itself counts frames: they run on. Otherwise the editor draws only while
    // something changes (editor::core::rest).
    .insert_resource(if cli.frames.is_some() {
        bevy::winit::WinitSettings::continuous()
    } else {
        editor::core::rest::resting_loop()
    })
    .insert_resource(ViewportRender {
        traced: cli.view.debug_view(),
        settings: treelight_render::PathTraced {
            frame_budget_ms: if cli.frame_budget.is_finite() {
                cli.frame_budget.max(0.0)
            } else {
                0.0
            },
            max_samples: cli.samples,
            resolution_scale: cli.trace_scale.unwrap_or(1.0),
            ..default()
        },
        scale_chosen: cli.trace_scale.is_some(),
    });
    // A run that ends by itself (`--frames`: a screenshot, a scripted check) neither keeps recovery
    // copies (its scene is made again by running it again) nor offers the user's over what it
    // shows.
    if cli.frames.is_none() {
        app.add_plugins(AutosavePlugin);
    }
    insert_kernel_record(&mut app);
    match &cli.scene {
        Some(path) => treelight_document::app::open_at_start(app.world_mut(), path),
        None => {
            app.add_systems(
                Startup,
                open_default_scene.after(editor::viewport::camera::setup_cameras),
            );
        }
    }
    if let Some(name) = &cli.camera {
        app.insert_resource(editor::core::view::LookThrough::Named(name.clone()));
    }
    if let Some(kib) = cli.upload_round {
        app.insert_resource(treelight_render::UploadRound(u64::from(kib) << 10));
    }
    let capturing = cli.screenshot.is_some() || cli.frames.is_some();
    if let Some(path) = &cli.save {
        let mut save = SaveWhenSettled::new(path.clone());
        // With `--frames`, the frames are counted out first.
        save.exit = !capturing;
        app.insert_resource(save);
    }
    if let Some(script) = script {
        app.insert_resource(script);
    }
    if let Some(path) = &cli.state {
        add_state_report(&mut app, path.clone());
    }
    if capturing {
        app.insert_resource(capture::CaptureRequest {
            path: cli.screenshot.clone(),
            frames: cli.frames.unwrap_or(10).max(1),
            rendered: 0,
            requested: false,
        })
        .add_systems(Last, capture::count_frames_and_capture);
    }
    if let Some(render_app) = app.get_sub_app_mut(bevy::render::RenderApp) {
        // The raster view's vertex and index slabs grow by half again up to this size, then a new
        // one starts: the default (512 MiB) leaves a large scene's meshes a third of slack.
        render_app.insert_resource(bevy::render::mesh::allocator::MeshAllocatorSettings {
            slab_allocator_settings: bevy::render::slab_allocator::SlabAllocatorSettings {
                max_slab_size: 64 << 20,
                large_threshold: 32 << 20,
                ..default()
            },
            ..default()
        });
    }
    run_schedules_on_one_thread(&mut app);
    app
}

/// `--state PATH`: the report written every frame, and the clocks and counts it reads.
fn add_state_report(app: &mut App, path: std::path::PathBuf) {
    app.insert_resource(report::StateReport::new(path))
        .init_resource::<report::MainThreadClock>()
        .init_resource::<report::InputCount>()
        .add_systems(First, report::start_frame_clock)
        .add_systems(
            PreUpdate,
            report::count_inputs.after(bevy::input::InputSystems),
        )
        .add_systems(
            bevy_egui::EguiPrimaryContextPass,
            (
                report::start_ui_clock.before(editor::core::ui_order::EditorUi),
                report::stop_ui_clock.after(editor::core::ui_order::EditorUi),
            ),
        )
        .add_systems(
            Last,
            (report::stop_frame_clock, report::write_state_report)
                .chain()
                .after(editor::core::rest::RestDecision),
        );
}

/// Keeps the record of the path tracer's kernel warm-ups (a software adapter's) in the cache
/// folder, so starts after the first skip them.
pub fn insert_kernel_record(app: &mut App) {
    if let Some(dir) = treelight_document::files::folders::cache_dir() {
        app.insert_resource(treelight_render::KernelCompileRecord(dir.join("kernels")));
    }
}
