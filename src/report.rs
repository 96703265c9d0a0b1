//! `--state PATH`: keeps a RON file up to date with what a script or a test driving the editor
//! needs to know: whether the scene has loaded and its BVH is idle, the objects (ids, names,
//! parents, transforms, where each is on screen), the selection, the history's position, the gizmo's
//! handles on screen and the frame count. Written every frame through a temporary file and a
//! rename, so a reader never sees half of it.

use crate::editor::core::view::OrbitCamera;

use crate::editor::core::gizmo_settings::GizmoSettings;
use crate::editor::core::selection::Selection;
use crate::editor::viewport::camera::world_bounds;
use crate::editor::viewport::gizmo::Handle;
use bevy::camera::primitives::Aabb;
use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use treelight_document::edit::history::EditHistory;
use treelight_document::values::object::SceneId;
use treelight_document::values::object::SceneObject;
use treelight_scene::SceneBvh;

/// One scene object in the report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectReport {
    /// Its stable id.
    pub id: SceneId,
    /// Its name.
    pub name: String,
    /// Its parent's id.
    pub parent: Option<SceneId>,
    /// Whether it has a mesh.
    pub mesh: bool,
    /// Whether it is shown.
    pub visible: bool,
    /// Local transform: translation, rotation (x, y, z, w), scale.
    pub local: treelight_document::edit::command::TransformValue,
    /// World position of its origin.
    pub world_translation: [f32; 3],
    /// Its world-space box's centre on screen (window coordinates, logical pixels), if in front.
    pub screen: Option<[f32; 2]>,
    /// Its light's values, for a light.
    #[serde(default)]
    pub light: Option<treelight_document::values::light::LightValue>,
}

/// One gizmo handle on screen.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HandleReport {
    /// Which handle: "axis 0", "plane 2", "ring 1", "scale 0", "scale uniform".
    pub handle: String,
    /// Its shape on screen (window coordinates).
    pub points: Vec<[f32; 2]>,
}

/// The whole report.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EditorState {
    /// Frames rendered so far.
    pub frame: u64,
    /// No import in progress and the scene BVH idle.
    pub settled: bool,
    /// The scene's objects, by id.
    pub objects: Vec<ObjectReport>,
    /// The selection's ids, the active one last.
    pub selection: Vec<SceneId>,
    /// Steps applied and steps in the history.
    pub history: (usize, usize),
    /// The gizmo's handles, when something is selected.
    pub gizmo: Vec<HandleReport>,
    /// The gizmo's mode, as the toolbar names it.
    pub gizmo_mode: String,
    /// The viewport's rectangle in the window: x, y, width, height (logical pixels).
    pub viewport: [f32; 4],
    /// Named widgets (the palette's tiles) and their rectangles, as the viewport's.
    #[serde(default)]
    pub widgets: Vec<(String, [f32; 4])>,
    /// The open project's file, if it has one.
    #[serde(default)]
    pub project: Option<PathBuf>,
    /// Whether there are unsaved changes.
    #[serde(default)]
    pub dirty: bool,
    /// The window's title.
    #[serde(default)]
    pub title: String,
    /// The file dialog open, if any: "builtin" or "native", then what it is for; or "replace" and
    /// the file Save As asks about replacing; or "large import" and the file whose import waits for
    /// an answer.
    #[serde(default)]
    pub dialog: Option<String>,
    /// This frame's main-world schedules, `First` to `Last` (everything but rendering and this
    /// report), in milliseconds of wall time on the main thread.
    #[serde(default)]
    pub main_ms: f32,
    /// Of that, the editor's UI systems (panels, menus, the viewport's input and overlay).
    #[serde(default)]
    pub ui_ms: f32,
    /// The viewport's path tracer: whether it denoises, its resolution scale and the samples per
    /// pixel at which it stops.
    #[serde(default)]
    pub quality: (bool, f32, u32),
    /// How the viewport is drawn: "Raster" or the path tracer's view.
    #[serde(default)]
    pub view: String,
    /// The notices shown, oldest first.
    #[serde(default)]
    pub notices: Vec<String>,
    /// Samples every pixel of the viewport's path-traced view has (0 when not traced).
    #[serde(default)]
    pub samples: u32,
    /// Where the editor's memory is.
    #[serde(default)]
    pub memory: MemoryReport,
    /// Frames per second, smoothed (what the status bar shows).
    #[serde(default)]
    pub fps: f64,
    /// Mouse button, wheel and key messages the app has read so far: a driver waits for its own
    /// to be counted before it looks for their effect.
    #[serde(default)]
    pub inputs: u64,
    /// Whether this frame asked for no other: the editor waits for input or its next alarm
    /// (`editor::core::rest`). A driver waiting for frames after its input stops waiting then.
    #[serde(default)]
    pub at_rest: bool,
    /// What kept the editor drawing when it last was busy (the sources of work, by name).
    #[serde(default)]
    pub last_busy: Vec<String>,
    /// The document's exposure and tone curve.
    #[serde(default)]
    pub look: treelight_document::values::look::SceneLook,
    /// What the viewport camera has of it: its EV100 and Bevy's tonemapper, by name.
    #[serde(default)]
    pub camera_look: Option<(f32, String)>,
    /// The viewport camera's position and the direction it looks, world space.
    #[serde(default)]
    pub camera_pose: Option<([f32; 3], [f32; 3])>,
    /// The document's sky panorama, and whether it is ready in the path tracer (read, and converted
    /// for the views).
    #[serde(default)]
    pub environment: (
        treelight_document::scene::environment::SceneEnvironment,
        bool,
    ),
    /// Whether the viewport's path-traced samples (`samples`) show a sky panorama rather than the
    /// flat sky colour: a driver that changes the sky waits for this to follow.
    #[serde(default)]
    pub traced_panorama: bool,
    /// The viewport's path tracer in its latest frame: pixel samples traced, and what one costs
    /// (nanoseconds) as its frame budget estimates it, from GPU timestamps or frame intervals.
    #[serde(default)]
    pub trace: Option<(u64, Option<f64>)>,
    /// Whether that frame traced triangles (the path tracer's copy of the tree was not empty): the
    /// first such frame after an import into an empty scene is its first traced picture on screen,
    /// a coarse preview while the tree fills.
    #[serde(default)]
    pub traced_geometry: bool,
    /// Whether the viewport's denoiser owes its picture passes (a run part way or due, its
    /// pipeline compiling, the tree filling: `treelight_render::TraceFigures::denoising`): the
    /// picture at `samples` changes again when they are made.
    #[serde(default)]
    pub denoising: bool,
    /// The denoiser's pass the viewport's latest frame made, of how many its run makes.
    #[serde(default)]
    pub denoise_pass: Option<(u32, u32)>,
    /// The trace kernel the view waits for while it is compiled away from its queue, "whole"
    /// or "split" ([`treelight_render::PathTracerFigures::preparing_kernel`]).
    #[serde(default)]
    pub preparing_kernel: Option<String>,
    /// The recovery copies offered, newest first, while the offer is shown.
    #[serde(default)]
    pub recovery_offer: Vec<PathBuf>,
}

/// Mouse button, wheel and key messages read so far.
#[derive(Resource, Debug, Default)]
pub struct InputCount(pub u64);

/// Counts this frame's mouse button, wheel and key messages (in `PreUpdate`, after Bevy's
/// input).
pub fn count_inputs(
    mut count: ResMut<InputCount>,
    mut buttons: MessageReader<bevy::input::mouse::MouseButtonInput>,
    mut wheel: MessageReader<bevy::input::mouse::MouseWheel>,
    mut keys: MessageReader<bevy::input::keyboard::KeyboardInput>,
) {
    count.0 += (buttons.read().count() + wheel.read().count() + keys.read().count()) as u64;
}

/// The editor's memory by owner, bytes: what each part holds by its own count, next to what the
/// process has resident (the rest is Bevy, wgpu, the UI, the allocator's slack).
#[derive(Serialize, Deserialize, Debug, Default, Clone, PartialEq)]
pub struct MemoryReport {
    /// The process's resident set (on a software adapter, its GPU buffers too).
    pub resident: u64,
    /// Bevy's mesh assets in the main world: vertex attributes and indices.
    pub mesh_assets: u64,
    /// How many mesh assets there are.
    #[serde(default)]
    pub mesh_count: u64,
    /// Mesh assets parked: their vertices compressed while only the tree reads them.
    #[serde(default)]
    pub meshes_parked: u64,
    /// The parked meshes' compressed bytes.
    #[serde(default)]
    pub parked_bytes: u64,
    /// The scene BVH's arrays on its worker.
    pub tree: u64,
    /// The BVH groups' normals and texture coordinates (the path tracer's shading source).
    pub shading: u64,
    /// The path tracer's scene buffers.
    pub scene_buffers: u64,
    /// The path tracer's map of which tree nodes own a node record, and where.
    #[serde(default)]
    pub record_layout: u64,
    /// The device allocator's memory blocks (every buffer and texture, and upload staging), where
    /// the backend reports them; 0 where not.
    #[serde(default)]
    pub gpu_reserved: u64,
    /// Triangles in the tree.
    pub triangles: u64,
    /// Meshes the scene's worker has rebuilt in idle time so far (a better tree for a still mesh).
    #[serde(default)]
    pub meshes_rebuilt: u64,
    /// Mesh assets kept out of the render world (nothing rasterises them while the view is path
    /// traced).
    #[serde(default)]
    pub meshes_held_back: u64,
    /// The most bytes one frame wrote to the path tracer's scene buffers so far (that frame's
    /// writes were all in memory at once).
    #[serde(default)]
    pub largest_upload: u64,
}

/// Bytes of a mesh's vertex attributes and indices still in the main world.
fn mesh_bytes(mesh: &Mesh) -> u64 {
    let attributes: usize = mesh
        .try_attributes()
        .map(|a| a.map(|(_, v)| v.get_bytes().len()).sum())
        .unwrap_or(0);
    let indices = match mesh.try_indices_option() {
        Ok(Some(bevy::mesh::Indices::U16(i))) => i.len() * 2,
        Ok(Some(bevy::mesh::Indices::U32(i))) => i.len() * 4,
        _ => 0,
    };
    (attributes + indices) as u64
}

/// The memory report now.
fn memory_report(
    meshes: &Assets<Mesh>,
    scene: &SceneBvh,
    tracer: &treelight_render::PathTracerStats,
) -> MemoryReport {
    let stats = scene.stats();
    let (parked, parked_bytes) = scene.parked_figures();
    MemoryReport {
        resident: crate::editor::core::resident::resident_bytes().unwrap_or(0),
        mesh_assets: meshes.iter().map(|(_, m)| mesh_bytes(m)).sum(),
        mesh_count: meshes.len() as u64,
        meshes_parked: parked as u64,
        parked_bytes: parked_bytes as u64,
        tree: stats.tree_bytes as u64,
        shading: stats.shading_bytes as u64,
        scene_buffers: tracer.figures().scene_buffer_bytes,
        record_layout: tracer.figures().record_layout_bytes,
        gpu_reserved: tracer.figures().gpu_reserved_bytes.unwrap_or(0),
        triangles: u64::from(stats.triangles),
        meshes_rebuilt: stats.meshes_refined,
        meshes_held_back: tracer.figures().meshes_held_back as u64,
        largest_upload: tracer.figures().largest_upload_bytes,
    }
}

/// Times the main world's frame and the editor's UI for the report.
#[derive(Resource, Debug, Default)]
pub struct MainThreadClock {
    frame_start: Option<std::time::Instant>,
    ui_start: Option<std::time::Instant>,
    main: std::time::Duration,
    ui: std::time::Duration,
}

/// Starts timing the frame (in `First`).
pub fn start_frame_clock(mut clock: ResMut<MainThreadClock>) {
    clock.frame_start = Some(std::time::Instant::now());
    clock.ui = std::time::Duration::ZERO;
}

/// Stops timing the frame (in `Last`, before the report).
pub fn stop_frame_clock(mut clock: ResMut<MainThreadClock>) {
    if let Some(t) = clock.frame_start.take() {
        clock.main = t.elapsed();
    }
}

/// Starts timing the editor's UI.
pub fn start_ui_clock(mut clock: ResMut<MainThreadClock>) {
    clock.ui_start = Some(std::time::Instant::now());
}

/// Stops timing the editor's UI.
pub fn stop_ui_clock(mut clock: ResMut<MainThreadClock>) {
    if let Some(t) = clock.ui_start.take() {
        clock.ui += t.elapsed();
    }
}

/// Where the report goes.
#[derive(Resource, Debug, Clone)]
pub struct StateReport {
    /// The file.
    pub path: PathBuf,
    frame: u64,
}

impl StateReport {
    /// A report written to `path`.
    pub fn new(path: PathBuf) -> Self {
        Self { path, frame: 0 }
    }
}

fn handle_name(h: Handle) -> String {
    match h {
        Handle::Axis(i) => format!("axis {i}"),
        Handle::Plane(i) => format!("plane {i}"),
        Handle::Ring(i) => format!("ring {i}"),
        Handle::ScaleAxis(i) => format!("scale {i}"),
        Handle::ScaleUniform => "scale uniform".into(),
    }
}

/// What the report reads of each scene object.
#[derive(bevy::ecs::query::QueryData)]
pub struct ReportItem {
    /// The object.
    pub entity: Entity,
    /// Its stable id.
    pub id: &'static SceneId,
    /// Its name, if it has one.
    pub name: Option<&'static Name>,
    /// Its local transform.
    pub transform: &'static Transform,
    /// Its world transform.
    pub global: &'static GlobalTransform,
    /// Whether it shows a mesh.
    pub mesh: Has<Mesh3d>,
    /// Whether it is shown.
    pub visibility: Option<&'static Visibility>,
    /// Its parent.
    pub parent: Option<&'static ChildOf>,
    /// Its light components.
    pub light: treelight_document::values::light::LightParts,
}

/// What the report reads of the scene's objects and the view that shows them.
#[derive(bevy::ecs::system::SystemParam)]
pub struct SceneParams<'w, 's> {
    objects: Query<'w, 's, ReportItem, With<SceneObject>>,
    boxes: Query<'w, 's, (&'static Aabb, &'static GlobalTransform)>,
    children: Query<'w, 's, &'static Children>,
    cameras: Query<'w, 's, (&'static Camera, &'static GlobalTransform), With<OrbitCamera>>,
    camera_ids: Query<'w, 's, Entity, With<OrbitCamera>>,
    loading: treelight_document::app::SceneLoading<'w>,
    scene: Res<'w, SceneBvh>,
    meshes: Res<'w, Assets<Mesh>>,
}

/// What the report reads of the editor's own state: selection, history, gizmo, files, dialogs.
#[derive(bevy::ecs::system::SystemParam)]
pub struct EditorParams<'w, 's> {
    selection: Res<'w, Selection>,
    history: Res<'w, EditHistory>,
    gizmo: Res<'w, GizmoSettings>,
    widgets: Res<'w, crate::editor::core::widget_rects::WidgetRects>,
    project: Res<'w, treelight_document::project::format::ProjectState>,
    window: Query<'w, 's, &'static Window, With<bevy::window::PrimaryWindow>>,
    files: Res<'w, crate::editor::files::file_menu::FileUi>,
    autosave: Option<Res<'w, treelight_document::project::autosave::Autosave>>,
    questions: Res<'w, treelight_document::import::ask::ImportQuestions>,
    notices: Res<'w, treelight_document::scene::notice::Notices>,
    clock: Option<Res<'w, MainThreadClock>>,
    diagnostics: Res<'w, bevy::diagnostic::DiagnosticsStore>,
    inputs: Res<'w, InputCount>,
    activity: Option<Res<'w, crate::editor::core::rest::Activity>>,
}

/// What the report reads of the view's rendering: the path tracer, the render mode, the look and
/// the sky.
#[derive(bevy::ecs::system::SystemParam)]
pub struct RenderParams<'w, 's> {
    tracer: Res<'w, treelight_render::PathTracerStats>,
    render: Res<'w, crate::editor::core::viewport_render::ViewportRender>,
    look: Res<'w, treelight_document::values::look::SceneLook>,
    environment: Res<'w, treelight_document::scene::environment::SceneEnvironment>,
    loaded: Res<'w, treelight_document::scene::environment::LoadedEnvironment>,
    traced: Res<'w, treelight_render::PathTracedEnvironment>,
    prepared: Res<'w, treelight_render::PreparedEnvironment>,
    lens: Query<
        'w,
        's,
        (
            &'static bevy::camera::Exposure,
            &'static bevy::core_pipeline::tonemapping::Tonemapping,
        ),
        With<OrbitCamera>,
    >,
}

/// The viewport camera's samples and latest trace, from one copy of the figures.
#[derive(Default)]
struct ViewSamples {
    samples: u32,
    trace: Option<treelight_render::TraceFigures>,
}

/// Writes the report for this frame.
pub fn write_state_report(
    mut report: ResMut<StateReport>,
    scene: SceneParams,
    editor: EditorParams,
    rendered: RenderParams,
) {
    report.frame += 1;
    let camera = scene.cameras.single().ok();
    let view_samples: ViewSamples = scene.camera_ids.single().map_or_else(
        |_| ViewSamples::default(),
        |c| {
            let figures = rendered.tracer.figures();
            ViewSamples {
                samples: figures.samples.get(&c).copied().unwrap_or(0),
                trace: figures.traces.get(&c).copied(),
            }
        },
    );
    let state = editor_state(&report, &scene, &editor, &rendered, camera, view_samples);
    let text = match ron::ser::to_string_pretty(&state, ron::ser::PrettyConfig::default()) {
        Ok(t) => t,
        Err(e) => {
            error!("state report: {e}");
            return;
        }
    };
    let tmp = report.path.with_extension("tmp");
    let written = std::fs::write(&tmp, text).and_then(|()| std::fs::rename(&tmp, &report.path));
    if let Err(e) = written {
        error!(
            "{}: cannot write the state report: {e}",
            report.path.display()
        );
    }
}

/// The parent of object `e` that is a scene object too.
fn scene_parent(scene: &SceneParams, e: Entity) -> Option<Entity> {
    scene
        .objects
        .get(e)
        .ok()
        .and_then(|o| o.parent)
        .map(|c| c.parent())
        .filter(|p| scene.objects.contains(*p))
}

/// Every scene object, by id.
fn object_reports(
    scene: &SceneParams,
    camera: Option<(&Camera, &GlobalTransform)>,
) -> Vec<ObjectReport> {
    let mut list: Vec<ObjectReport> = scene
        .objects
        .iter()
        .map(|o| {
            let (e, gt) = (o.entity, o.global);
            let centre = world_bounds(e, &scene.boxes, &scene.children)
                .map_or(gt.translation(), |(a, b)| (a + b) * 0.5);
            ObjectReport {
                id: *o.id,
                name: o.name.map_or(String::new(), |n| n.as_str().to_owned()),
                parent: scene_parent(scene, e)
                    .and_then(|p| scene.objects.get(p).ok())
                    .map(|p| *p.id),
                mesh: o.mesh,
                visible: o.visibility != Some(&Visibility::Hidden),
                local: (*o.transform).into(),
                world_translation: gt.translation().to_array(),
                screen: camera
                    .and_then(|(c, cg)| c.world_to_viewport(cg, centre).ok())
                    .map(|p| p.to_array()),
                light: treelight_document::values::light::LightValue::of_parts(o.light),
            }
        })
        .collect();
    list.sort_by_key(|o| o.id);
    list
}

/// The gizmo's handles on screen, where the selection shows one.
fn gizmo_handles(
    scene: &SceneParams,
    editor: &EditorParams,
    camera: Option<(&Camera, &GlobalTransform)>,
) -> Vec<HandleReport> {
    let Some(view) = camera else {
        return Vec::new();
    };
    let (targets, active) = crate::editor::viewport::panel::drag_targets(
        &editor.selection,
        |e| {
            scene
                .objects
                .get(e)
                .ok()
                .map(|o| (*o.id, o.global.affine()))
        },
        |e| scene_parent(scene, e),
    );
    let gizmo = &*editor.gizmo;
    crate::editor::viewport::panel::gizmo_frame(&targets, active, gizmo, &view).map_or_else(
        Vec::new,
        |frame| {
            frame
                .handles(gizmo.mode, &view)
                .into_iter()
                .map(|(h, points)| HandleReport {
                    handle: handle_name(h),
                    points: points.iter().map(|p| p.to_array()).collect(),
                })
                .collect()
        },
    )
}

/// The dialog or question waiting for the user, if any.
fn waiting_dialog(editor: &EditorParams) -> Option<String> {
    let files = &editor.files;
    match (&files.dialog, &files.native, &files.replace) {
        (Some(d), _, _) => Some(format!("builtin {:?}", d.purpose)),
        (_, Some(d), _) => Some(format!("native {:?}", d.purpose)),
        (_, _, Some(p)) => Some(format!("replace {}", p.display())),
        _ if files.overwrite_changed.is_some() => files
            .overwrite_changed
            .as_ref()
            .map(|p| format!("changed on disk {}", p.display())),
        _ => editor
            .questions
            .waiting
            .first()
            .map(|h| format!("large import {}", h.path.display())),
    }
}

/// The whole report of this frame.
fn editor_state(
    report: &StateReport,
    scene: &SceneParams,
    editor: &EditorParams,
    rendered: &RenderParams,
    camera: Option<(&Camera, &GlobalTransform)>,
    view_samples: ViewSamples,
) -> EditorState {
    let (render, tracer) = (&rendered.render, &rendered.tracer);
    let clock = editor.clock.as_ref();
    EditorState {
        frame: report.frame,
        // Settled once the tree holds the whole scene and the path tracer's copy is current
        // (nothing to copy while the view is rasterised or the scene is too large to trace).
        settled: render.draws_settled_scene(&scene.loading, tracer),
        objects: object_reports(scene, camera),
        selection: editor
            .selection
            .entities()
            .iter()
            .filter_map(|e| scene.objects.get(*e).ok().map(|o| *o.id))
            .collect(),
        history: (editor.history.head(), editor.history.labels().len()),
        gizmo: gizmo_handles(scene, editor, camera),
        gizmo_mode: editor.gizmo.mode.label().to_owned(),
        viewport: camera
            .and_then(|(c, _)| c.logical_viewport_rect())
            .map_or([0.0; 4], |r| [r.min.x, r.min.y, r.width(), r.height()]),
        widgets: editor.widgets.0.clone(),
        project: editor.project.path.clone(),
        dirty: editor.history.is_dirty(),
        title: editor
            .window
            .single()
            .map_or(String::new(), |w| w.title.clone()),
        dialog: waiting_dialog(editor),
        main_ms: clock.map_or(0.0, |c| c.main.as_secs_f32() * 1e3),
        ui_ms: clock.map_or(0.0, |c| c.ui.as_secs_f32() * 1e3),
        quality: (
            render.settings.denoise,
            render.settings.resolution_scale,
            render.settings.max_samples,
        ),
        view: crate::editor::core::viewport_render::ViewportRender::label(render.traced).to_owned(),
        notices: editor.notices.0.iter().map(|n| n.text.clone()).collect(),
        samples: view_samples.samples,
        traced_panorama: view_samples.trace.is_some_and(|t| t.panorama),
        trace: view_samples
            .trace
            .map(|t| (t.traced_per_frame, t.cost.map(|(ns, _)| ns))),
        traced_geometry: view_samples.trace.is_some_and(|t| t.geometry),
        denoising: view_samples.trace.is_some_and(|t| t.denoising),
        denoise_pass: view_samples.trace.and_then(|t| t.denoise_pass),
        preparing_kernel: tracer
            .preparing_kernel()
            .map(|k| if k.split { "split" } else { "whole" }.to_owned()),
        memory: memory_report(&scene.meshes, &scene.scene, tracer),
        fps: editor
            .diagnostics
            .get(&bevy::diagnostic::FrameTimeDiagnosticsPlugin::FPS)
            .and_then(|d| d.smoothed())
            .unwrap_or(0.0),
        inputs: editor.inputs.0,
        at_rest: editor.activity.as_ref().is_some_and(|a| a.at_rest),
        last_busy: editor.activity.as_ref().map_or_else(Vec::new, |a| {
            a.last_busy.iter().map(|s| (*s).to_owned()).collect()
        }),
        look: *rendered.look,
        camera_look: rendered
            .lens
            .single()
            .ok()
            .map(|(e, t)| (e.ev100, format!("{t:?}"))),
        camera_pose: camera
            .map(|(_, g)| (g.translation().to_array(), g.forward().as_vec3().to_array())),
        recovery_offer: editor
            .autosave
            .as_ref()
            .map(|a| a.offer.iter().map(|c| c.path.clone()).collect())
            .unwrap_or_default(),
        environment: (
            rendered.environment.clone(),
            rendered.loaded.image.is_some()
                && rendered.traced.image.is_some()
                && rendered.prepared.ready_for(&rendered.traced),
        ),
    }
}
