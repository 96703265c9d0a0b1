//! `treelight render [SCENE] --out IMAGE.png|.exr --spp N [--width W --height H] [--sky FILE.hdr]
//! [--overwrite]`: the scene path traced without a window (Bevy renders into an image; no display is needed), from the
//! project's saved view or, for a scene file, framed from above as the editor frames it, with the
//! scene's exposure and tone curve. The samples count once the scene is loaded, its tree idle and
//! the path tracer's copy of it no longer changing (the scene's geometry reaching the GPU restarts
//! the accumulation, so every sample counted sees the whole scene); the image is saved when every
//! pixel has `spp` samples, written atomically, with a progress bar on the terminal meanwhile.

use crate::cli::RenderArgs;
use crate::editor::core::view::OrbitCamera;
use crate::editor::viewport::camera::{
    apply_orbit, follow_document, look_through, no_camera_named,
};
use crate::editor::viewport::look::{apply_look, environment_to_tracer};
use crate::editor::viewport::map_transforms::map_transforms_to_tracer;
use bevy::app::ScheduleRunnerPlugin;
use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::render::render_resource::{PipelineCache, TextureFormat};
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::render::{Render, RenderApp, RenderSystems};
use bevy::window::ExitCondition;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use treelight_document::DocumentPlugin;
use treelight_document::app::{
    SceneLoading, fail_on_errors, run_schedules_on_one_thread, task_pools,
};
use treelight_document::default_scene::open_default_scene;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::{EditRequests, apply_edit_requests};
use treelight_document::scene::environment::SceneEnvironment;
use treelight_document::values::camera::SceneCamera;
use treelight_render::{PathTraced, PathTracedEnvironment, PathTracerStats, PreparedEnvironment};

/// Whether `out` is a file `treelight render` can write: a `.png` or `.exr` in an existing folder,
/// not already there unless `overwrite`.
pub fn check_output(args: &RenderArgs) -> Result<(), String> {
    let out = &args.out;
    check_image_path(out, &["png", "exr"])?;
    if let Some(sky) = &args.sky {
        if !treelight_document::scene::environment::is_environment_file(sky) {
            return Err(format!(
                "{}: a sky panorama must be a .hdr or .exr file",
                sky.display()
            ));
        }
        if !sky.exists() {
            return Err(format!("{}: no such file", sky.display()));
        }
        if !sky.is_file() {
            return Err(format!("{}: not a regular file", sky.display()));
        }
    }
    // A link, dangling or not, counts as a file there: without --overwrite nothing is written
    // through it (checked again when the image is written).
    match std::fs::symlink_metadata(out) {
        Ok(m) if !args.overwrite => {
            let what = if m.file_type().is_symlink() {
                "a link is there"
            } else {
                "the file exists"
            };
            return Err(format!(
                "{}: {what} (--overwrite replaces it)",
                out.display()
            ));
        }
        _ => {}
    }
    Ok(())
}

/// Whether a render can be written to `out`: a file of one of the `formats` (extensions) in a
/// folder that exists (both renders ask this; what to do about an existing file is each one's own).
pub fn check_image_path(out: &Path, formats: &[&str]) -> Result<(), String> {
    if !out
        .extension()
        .is_some_and(|e| formats.iter().any(|f| e.eq_ignore_ascii_case(f)))
    {
        let names: Vec<String> = formats.iter().map(|f| format!(".{f}")).collect();
        return Err(format!(
            "{}: the image must be a {} file",
            out.display(),
            names.join(" or ")
        ));
    }
    let folder = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_owned(),
        _ => PathBuf::from("."),
    };
    if !folder.is_dir() {
        return Err(format!(
            "{}: the folder {} does not exist",
            out.display(),
            folder.display()
        ));
    }
    Ok(())
}

/// When a render's image may be captured: the picture is finished (every pixel has its samples and
/// the denoiser's last run has ended), and every pipeline has been compiled two frames in a row
/// (the render world runs a frame behind). Both renders use it.
#[derive(Default)]
pub struct CaptureGate {
    /// Frames in a row with every pipeline compiled.
    compiled: u32,
}

impl CaptureGate {
    /// Called once a frame: whether the image may be captured now, the picture `finished`
    /// ([`PathTracerStats::finished`]).
    pub fn open(&mut self, finished: bool, ready: &PipelinesReady) -> bool {
        self.compiled = if ready.is_ready() {
            self.compiled + 1
        } else {
            0
        };
        finished && self.compiled >= 2
    }
}

/// The render in progress.
#[derive(Resource)]
struct RenderJob {
    out: PathBuf,
    /// How the image is written: a new file, or (`--overwrite`) over whatever is there.
    write: ImageWrite,
    spp: u32,
    target: Handle<Image>,
    progress: ProgressBar,
    /// The upload total last seen, and for how many frames in a row it has not changed.
    uploaded: (u64, u32),
    /// The scene has loaded and the path tracer's copy of it stopped changing.
    settled: bool,
    /// When the image may be captured.
    gate: CaptureGate,
    /// The screenshot was asked for.
    captured: bool,
    /// How far the trace's rate has been measured.
    rate: RateClock,
    /// The image's size in pixels.
    pixels: u64,
    /// The scene camera to render through, by name.
    camera: Option<String>,
    /// What the command line changes of the scene's sky panorama, put on it once the scene has
    /// settled (a project's own sky is read by then).
    sky: Option<SkyArgs>,
}

/// The trace's rate, from the first samples seen (the pipelines are compiled by then) to the last.
enum RateClock {
    /// No sample yet.
    Waiting,
    /// Since when, and how many samples each pixel had then.
    Since(Instant, u32),
    /// Reported.
    Done,
}

/// `--sky`, `--sky-rotation` and `--sky-intensity`.
struct SkyArgs {
    image: Option<PathBuf>,
    rotation_degrees: Option<f32>,
    intensity: Option<f32>,
}

impl SkyArgs {
    fn from(args: &RenderArgs) -> Option<Self> {
        let sky = Self {
            // Absolute, as the panorama is read wherever the project is.
            image: args
                .sky
                .as_ref()
                .map(|p| std::path::absolute(p).unwrap_or_else(|_| p.clone())),
            rotation_degrees: args.sky_rotation,
            intensity: args.sky_intensity,
        };
        (sky.image.is_some() || sky.rotation_degrees.is_some() || sky.intensity.is_some())
            .then_some(sky)
    }

    /// The scene's sky with what the command line changes of it.
    fn applied_to(&self, scene: &SceneEnvironment) -> SceneEnvironment {
        SceneEnvironment {
            image: self.image.clone().or_else(|| scene.image.clone()),
            rotation_degrees: self.rotation_degrees.unwrap_or(scene.rotation_degrees),
            intensity: self.intensity.unwrap_or(scene.intensity),
            shown: scene.shown,
        }
    }
}

/// Whether the render world's pipeline cache has no pipeline waiting to be compiled (written each
/// frame by the render world, read in the main world): until the tonemapper's pipeline for an
/// image's format is ready, the image holds no picture.
#[derive(Resource, Clone, Default)]
pub struct PipelinesReady(Arc<AtomicBool>);

impl PipelinesReady {
    /// Whether no pipeline waited to be compiled in the render world's last frame.
    pub fn is_ready(&self) -> bool {
        self.0.load(Ordering::Acquire)
    }
}

/// Keeps [`PipelinesReady`] in the main world. Add after Bevy's render plugin.
pub struct PipelineWatchPlugin;

impl Plugin for PipelineWatchPlugin {
    fn build(&self, app: &mut App) {
        let ready = PipelinesReady::default();
        app.insert_resource(ready.clone());
        if let Some(render) = app.get_sub_app_mut(RenderApp) {
            render
                .insert_resource(ready)
                .add_systems(Render, watch_pipelines.in_set(RenderSystems::Cleanup));
        }
    }
}

fn watch_pipelines(cache: Res<PipelineCache>, ready: Res<PipelinesReady>) {
    ready.0.store(
        cache.waiting_pipelines().next().is_none(),
        Ordering::Release,
    );
}

/// Frames in a row without an upload before the samples count.
const STILL_FRAMES: u32 = 3;

/// Marks the camera that renders the image.
#[derive(Component)]
struct RenderCamera;

/// The app `treelight render` runs: Bevy's renderer without a window, the scene BVH, the path
/// tracer and the document, a camera rendering into an image.
pub fn render_app(args: &RenderArgs) -> App {
    let mut app = App::new();
    app.add_plugins(
        DefaultPlugins
            .set(task_pools())
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                close_when_requested: false,
                ..default()
            })
            .disable::<bevy::winit::WinitPlugin>(),
    )
    .add_plugins((
        ScheduleRunnerPlugin::run_loop(Duration::ZERO),
        treelight_scene::SceneBvhPlugin {
            config: treelight_scene::SceneBvhConfig {
                // A render never edits nor rasterises: each mesh is held once, in the tree.
                release_traced_meshes: true,
                ..default()
            },
        },
        treelight_render::PathTracerPlugin,
        DocumentPlugin,
    ));
    run_schedules_on_one_thread(&mut app);
    crate::insert_kernel_record(&mut app);
    // What the parse and the fill free (the meshes' vertex data among it) goes back to the
    // system before the upload's buffers come, as in the editor.
    app.add_plugins((PipelineWatchPlugin, crate::heap_trim::HeapTrimPlugin));
    // An EXR holds the exposed radiance itself: a float target, and no tone curve or dither.
    let linear = is_exr(&args.out);
    let format = if linear {
        TextureFormat::Rgba16Float
    } else {
        TextureFormat::Rgba8UnormSrgb
    };
    let mut target = Image::new_target_texture(args.width, args.height, format, None);
    target.asset_usage = bevy::asset::RenderAssetUsages::default();
    let target = app.world_mut().resource_mut::<Assets<Image>>().add(target);
    let tracer = PathTraced {
        // The whole image every frame, one sample at a time, up to the count asked for.
        frame_budget_ms: 0.0,
        samples_per_frame: 1,
        max_samples: args.spp,
        denoise: args.denoise == crate::cli::Switch::On,
        // A still image: only its own samples.
        temporal: false,
        seed: args.seed,
        max_bounces: args.bounces,
        indirect_clamp: args.indirect_clamp,
        ..default()
    };
    app.insert_resource(treelight_document::scene::spawn::DefaultSun(
        args.default_sun == crate::cli::Switch::On,
    ));
    if let Some(kib) = args.upload_round {
        app.insert_resource(treelight_render::UploadRound(u64::from(kib) << 10));
    }
    let progress = ProgressBar::new(u64::from(args.spp)).with_style(
        ProgressStyle::with_template(
            "{msg:>12} [{bar:40}] {pos}/{len} samples per pixel, {elapsed}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    progress.set_message("loading");
    app.insert_resource(RenderJob {
        out: args.out.clone(),
        write: if args.overwrite {
            ImageWrite::Replace
        } else {
            ImageWrite::New
        },
        spp: args.spp,
        target: target.clone(),
        progress,
        uploaded: (0, 0),
        settled: false,
        gate: CaptureGate::default(),
        captured: false,
        rate: RateClock::Waiting,
        pixels: u64::from(args.width) * u64::from(args.height),
        camera: args.camera.clone(),
        sky: SkyArgs::from(args),
    });
    let orbit = OrbitCamera::default();
    app.world_mut().spawn((
        Name::new("Render camera"),
        RenderCamera,
        Camera3d::default(),
        // Traced: multisampling would add a target of four samples a pixel and smooth nothing.
        Msaa::Off,
        RenderTarget::Image(target.into()),
        tracer,
        orbit.transform(),
        orbit,
    ));
    match &args.scene {
        Some(path) => treelight_document::app::open_at_start(app.world_mut(), path),
        None => {
            app.add_systems(Startup, open_default_scene);
        }
    }
    app.add_systems(
        Update,
        (
            follow_document.after(apply_edit_requests),
            apply_orbit.after(follow_document),
            apply_look,
            sky_to_render_camera,
            environment_to_tracer,
            map_transforms_to_tracer,
            follow_samples.after(apply_orbit),
        ),
    )
    .add_systems(Last, fail_on_errors);
    if linear {
        app.add_systems(Update, keep_linear.after(apply_look));
    }
    app
}

/// The document's sky on the render camera's path tracer.
fn sky_to_render_camera(
    look: Res<treelight_document::values::look::SceneLook>,
    mut cameras: Query<&mut PathTraced, With<RenderCamera>>,
) {
    if look.is_changed() {
        for mut traced in &mut cameras {
            traced.sky = look.sky_radiance();
        }
    }
}

/// The render camera, and the scene's cameras it may look through (`--camera`).
#[derive(bevy::ecs::system::SystemParam)]
struct RenderView<'w, 's> {
    camera: Single<'w, 's, Entity, With<RenderCamera>>,
    pose: Single<'w, 's, (&'static mut OrbitCamera, &'static mut Projection), With<RenderCamera>>,
    scene_cameras: Query<
        'w,
        's,
        (
            &'static Name,
            &'static GlobalTransform,
            &'static SceneCamera,
        ),
    >,
}

/// The scene's sky panorama: the document's, the path tracer's and whether its conversion is
/// ready; the requests that change it; and whether the render world's pipelines are.
#[derive(bevy::ecs::system::SystemParam)]
struct SkyAndPipelines<'w> {
    pipelines: Res<'w, PipelinesReady>,
    scene: Res<'w, SceneEnvironment>,
    tracer: Res<'w, PathTracedEnvironment>,
    prepared: Res<'w, PreparedEnvironment>,
    requests: ResMut<'w, EditRequests>,
}

/// Waits for the scene to settle and the path tracer's copy of it to stop changing; then shows the
/// samples traced so far, and once every pixel has its samples, asks for the image. A scene the
/// adapter cannot trace ends the run with its reason.
fn follow_samples(
    mut commands: Commands,
    mut job: ResMut<RenderJob>,
    stats: Res<PathTracerStats>,
    loading: SceneLoading,
    mut view: RenderView,
    mut sky: SkyAndPipelines,
    mut exit: MessageWriter<AppExit>,
) {
    if job.captured {
        return;
    }
    if let Some(why) = stats.trace_off() {
        job.progress.abandon_with_message("failed");
        error!("{}: cannot path trace the scene: {why}", job.out.display());
        exit.write(AppExit::error());
        return;
    }
    if !job.settled {
        let settled = loading.settled();
        let figures = stats.figures();
        let (last, still) = job.uploaded;
        job.uploaded = if figures.total_upload_bytes == last {
            (last, still + 1)
        } else {
            (figures.total_upload_bytes, 0)
        };
        // The sky panorama, once read, is converted for the tracer on a thread of its own.
        let sky_ready = sky.prepared.ready_for(&sky.tracer);
        if !sky_ready {
            job.uploaded.1 = 0;
        }
        // The same rule as the editor's state report: the tree holds the whole scene and the
        // GPU copy is the tree's latest.
        let current = figures.uploaded_version >= loading.scene_version();
        if !(settled
            && current
            && sky_ready
            && figures.scene_ready
            && job.uploaded.1 >= STILL_FRAMES)
        {
            return;
        }
        if let Some(wanted) = job.sky.take() {
            let environment = wanted.applied_to(&sky.scene);
            if environment != *sky.scene {
                sky.requests
                    .apply(EditCommand::SetEnvironment { environment });
                // The panorama is read and converted before the samples count, as a project's.
                job.uploaded.1 = 0;
                return;
            }
        }
        if let Some(name) = job.camera.take() {
            let Some((_, at, camera)) = view.scene_cameras.iter().find(|c| c.0.as_str() == name)
            else {
                job.progress.abandon_with_message("failed");
                error!(
                    "{}: {}",
                    job.out.display(),
                    no_camera_named(&name, view.scene_cameras.iter().map(|c| c.0.as_str()))
                );
                exit.write(AppExit::error());
                return;
            };
            let (o, p) = &mut *view.pose;
            look_through(o, p, at, camera);
            // The view changed, restarting the accumulation a frame or two from now: wait as for
            // the last upload, so the samples counted are all through the camera.
            job.uploaded.1 = 0;
            return;
        }
        // The last geometry that reached the GPU restarted the accumulation: every sample counted
        // from here on saw the whole scene (a later change of it starts the count again).
        job.settled = true;
        info!(
            "the scene is on the GPU: {:.1} MiB of records in {} frames, the largest {:.1} MiB, \
             {} rounds handed over before their frame's end; {} meshes' vertex data freed once \
             in the tree",
            figures.total_upload_bytes as f64 / 1048576.0,
            figures.uploads,
            figures.largest_upload_bytes as f64 / 1048576.0,
            figures.upload_rounds,
            loading.scene().meshes_released(),
        );
    }
    let samples = stats.samples(*view.camera);
    match job.rate {
        RateClock::Waiting if samples > 0 => job.rate = RateClock::Since(Instant::now(), samples),
        RateClock::Since(since, first) if samples >= job.spp => {
            let seconds = since.elapsed().as_secs_f64();
            let traced = u64::from(job.spp.saturating_sub(first)) * job.pixels;
            if traced > 0 {
                info!(
                    "traced {traced} samples in {seconds:.3} s: {:.2} million samples a second",
                    traced as f64 / seconds / 1e6
                );
            }
            job.rate = RateClock::Done;
        }
        _ => {}
    }
    job.progress.set_message("tracing");
    job.progress.set_position(u64::from(samples.min(job.spp)));
    let finished = stats.finished(*view.camera, job.spp);
    if !job.gate.open(finished, &sky.pipelines) {
        return;
    }
    job.captured = true;
    job.progress.set_message("saving");
    commands
        .spawn(Screenshot::image(job.target.clone()))
        .observe(save_image);
}

/// Saves the captured image (atomically: a temporary file renamed over the target) and exits.
fn save_image(
    captured: On<ScreenshotCaptured>,
    job: Res<RenderJob>,
    mut exit: MessageWriter<AppExit>,
) {
    let saved = if is_exr(&job.out) {
        save_exr(&captured.image, &job.out, job.write)
    } else {
        save_png(&captured.image, &job.out, job.write)
    };
    match saved {
        Ok(()) => {
            job.progress.finish_with_message("saved");
            info!(
                "rendered {} at {} samples per pixel",
                job.out.display(),
                job.spp
            );
            exit.write(AppExit::Success);
        }
        Err(e) => {
            job.progress.abandon_with_message("failed");
            error!("{}: cannot save the image: {e}", job.out.display());
            exit.write(AppExit::error());
        }
    }
}

/// Whether `path` names an OpenEXR file.
fn is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// An EXR render's camera shows the exposed radiance as it is: no tone curve, no dither.
fn keep_linear(
    mut cameras: Query<
        (
            &mut bevy::core_pipeline::tonemapping::Tonemapping,
            &mut bevy::core_pipeline::tonemapping::DebandDither,
        ),
        With<RenderCamera>,
    >,
) {
    use bevy::core_pipeline::tonemapping::{DebandDither, Tonemapping};
    for (mut curve, mut dither) in &mut cameras {
        curve.set_if_neq(Tonemapping::None);
        dither.set_if_neq(DebandDither::Disabled);
    }
}

/// How an image is written to its file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageWrite {
    /// A new file: refused when anything is there, a link included, even one made meanwhile.
    New,
    /// Replacing a file the user named and agreed to replace (a link's destination is written,
    /// as named).
    Replace,
    /// Replacing a file under a name the editor chose itself: never through a link.
    ReplaceOwnName,
}

fn write_image(path: &Path, bytes: &[u8], how: ImageWrite) -> Result<(), String> {
    use treelight_document::files::{atomic_file, own_file};
    let written = match how {
        ImageWrite::New => own_file::write_new(path, bytes),
        ImageWrite::Replace => atomic_file::write_atomically(path, bytes),
        ImageWrite::ReplaceOwnName => own_file::write_own(path, bytes),
    };
    written.map_err(|e| match (how, e.kind()) {
        (ImageWrite::New, std::io::ErrorKind::AlreadyExists) => {
            format!("{e} (written meanwhile; nothing was replaced)")
        }
        _ => e.to_string(),
    })
}

/// Writes a captured float image to `path` as an RGB OpenEXR of linear floats, atomically.
pub fn save_exr(image: &Image, path: &Path, how: ImageWrite) -> Result<(), String> {
    let (w, h) = (image.width(), image.height());
    let mut rgb = image::Rgb32FImage::new(w, h);
    for (x, y, p) in rgb.enumerate_pixels_mut() {
        let c = image
            .get_color_at(x, y)
            .map_err(|e| e.to_string())?
            .to_linear();
        *p = image::Rgb([c.red, c.green, c.blue]);
    }
    let mut bytes = Vec::new();
    image::DynamicImage::ImageRgb32F(rgb)
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::OpenExr,
        )
        .map_err(|e| e.to_string())?;
    write_image(path, &bytes, how)
}

/// Writes a captured image to `path` as an RGB PNG, atomically (a temporary file renamed or
/// linked into place).
pub fn save_png(image: &Image, path: &Path, how: ImageWrite) -> Result<(), String> {
    let rgb = image
        .clone()
        .try_into_dynamic()
        .map_err(|e| e.to_string())?
        .to_rgb8();
    let mut bytes = Vec::new();
    rgb.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| e.to_string())?;
    write_image(path, &bytes, how)
}
