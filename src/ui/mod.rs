//! The docked editor panels (viewport, outliner, inspector, history), the menu bar and the status
//! bar. Every change to the scene leaves as an [`EditRequest`]; the selection and the camera are
//! changed directly.

pub mod file_dialog;
pub mod inspector;
pub mod menus;
pub mod native_dialog;
pub mod outliner;
pub mod palette;

use crate::camera::{FrameRequest, OrbitCamera, world_bounds};
use crate::edit::shortcuts::EditClipboard;
use crate::edit::{EditCommand, EditHistory, EditRequest, EditRequests, LightKind, MaterialValue};
use crate::gizmo::{ActiveDrag, GizmoSettings};
use crate::notice::{Level, Notices};
use crate::placement::{box_corners, place_transform, surface_under, surface_under_excluding};
use crate::render_mode::ViewportRender;
use crate::scene_id::SceneId;
use crate::selection::{SceneObject, Selection};
use crate::viewport::{
    IconKind, ViewportActions, ViewportInteraction, ViewportPanel, ViewportScene,
};
use bevy::camera::Viewport;
use bevy::camera::primitives::Aabb;
use bevy::diagnostic::{DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_egui::{EguiContexts, EguiTextureHandle, egui};
use egui_dock::{DockArea, DockState, NodeIndex, Style, TabViewer};
use inspector::{InspectorState, MaterialView};
use menus::MenuAction;
use outliner::{OutlinerCache, OutlinerItem, OutlinerPanel, OutlinerState};
use treelight_render::PathTracerStats;
use treelight_scene::{SceneBvh, cast_on};

/// The panels that can be docked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum EditorTab {
    /// The 3D view.
    Viewport,
    /// The list of scene entities.
    Outliner,
    /// The selected entity's properties.
    Inspector,
    /// The edit history: every step, and a click goes back or forward to it.
    History,
    /// The built-in shapes, to drag onto the viewport.
    Assets,
}

impl EditorTab {
    /// Every panel.
    pub const ALL: [EditorTab; 5] = [
        EditorTab::Viewport,
        EditorTab::Outliner,
        EditorTab::Inspector,
        EditorTab::History,
        EditorTab::Assets,
    ];
}

/// The dock layout, kept between frames so the user's rearrangements persist.
#[derive(Resource)]
pub struct EditorDock(pub DockState<EditorTab>);

impl Default for EditorDock {
    fn default() -> Self {
        let mut state = DockState::new(vec![EditorTab::Viewport]);
        let tree = state.main_surface_mut();
        let [viewport, outliner] =
            tree.split_left(NodeIndex::root(), 0.2, vec![EditorTab::Outliner]);
        let [_, inspector] = tree.split_right(viewport, 0.75, vec![EditorTab::Inspector]);
        tree.split_below(inspector, 0.6, vec![EditorTab::History]);
        tree.split_below(outliner, 0.7, vec![EditorTab::Assets]);
        Self(state)
    }
}

/// Where named widgets (the palette's tiles) were laid out last frame: name and rectangle (x, y,
/// width, height, logical pixels), for the state report.
#[derive(Resource, Debug, Default, Clone)]
pub struct WidgetRects(pub Vec<(String, [f32; 4])>);

/// Where the viewport panel is, in physical pixels, for the 3D camera.
#[derive(Resource, Debug, Default, Clone, Copy, PartialEq)]
pub struct ViewportRect {
    /// Top-left corner.
    pub position: UVec2,
    /// Size; zero while the panel is hidden.
    pub size: UVec2,
}

struct EditorTabs<'a> {
    viewport: ViewportPanel<'a>,
    outliner: OutlinerPanel<'a>,
    inspected: Option<&'a mut InspectorState>,
    make_unique: &'a mut bool,
    /// The history's steps and how many are applied.
    history: (&'a [String], usize),
    /// A step the user clicked in the history panel.
    go_to: &'a mut Option<usize>,
    /// What the user clicked in the Assets panel.
    palette_click: &'a mut Option<palette::PaletteClick>,
    /// The Assets panel's folders and thumbnails.
    library: &'a crate::asset_library::AssetLibrary,
    /// The thumbnails as textures.
    textures: &'a mut palette::ThumbnailTextures,
    /// Where named widgets are this frame.
    named_rects: &'a mut Vec<(String, egui::Rect)>,
}

impl TabViewer for EditorTabs<'_> {
    type Tab = EditorTab;

    fn id(&mut self, tab: &mut EditorTab) -> egui::Id {
        egui::Id::new(("treelight-tab", *tab))
    }

    fn title(&mut self, tab: &mut EditorTab) -> egui::WidgetText {
        match tab {
            EditorTab::Viewport => "Viewport".into(),
            EditorTab::Outliner => "Outliner".into(),
            EditorTab::Inspector => "Inspector".into(),
            EditorTab::History => "History".into(),
            EditorTab::Assets => "Assets".into(),
        }
    }

    fn clear_background(&self, tab: &EditorTab) -> bool {
        // The 3D camera draws underneath the viewport panel.
        *tab != EditorTab::Viewport
    }

    fn closeable(&mut self, _tab: &mut EditorTab) -> bool {
        false
    }

    fn ui(&mut self, ui: &mut egui::Ui, tab: &mut EditorTab) {
        match tab {
            EditorTab::Viewport => self.viewport.ui(ui),
            EditorTab::Outliner => self.outliner.ui(ui),
            EditorTab::Inspector => {
                inspector::inspector_ui(ui, self.inspected.as_deref_mut(), self.make_unique)
            }
            EditorTab::History => self.history_ui(ui),
            EditorTab::Assets => {
                if let Some(click) =
                    palette::palette_ui(ui, self.named_rects, self.library, self.textures)
                {
                    *self.palette_click = Some(click);
                }
            }
        }
    }
}

impl EditorTabs<'_> {
    fn history_ui(&mut self, ui: &mut egui::Ui) {
        let (labels, head) = self.history;
        egui::ScrollArea::vertical()
            .auto_shrink([false; 2])
            .stick_to_bottom(true)
            .show(ui, |ui| {
                // Row 0 is the scene as opened; row i the scene after step i.
                if ui.selectable_label(head == 0, "Opened").clicked() && head != 0 {
                    *self.go_to = Some(0);
                }
                for (i, label) in labels.iter().enumerate() {
                    let text = egui::RichText::new(label);
                    let text = if i < head { text } else { text.weak() };
                    if ui.selectable_label(head == i + 1, text).clicked() && head != i + 1 {
                        *self.go_to = Some(i + 1);
                    }
                }
            });
    }
}

fn kind_of(mesh: bool, point: bool, directional: bool) -> &'static str {
    if mesh {
        "▣"
    } else if point {
        "💡"
    } else if directional {
        "☀"
    } else {
        "•"
    }
}

/// What the outliner, inspector and viewport read of each scene object.
#[derive(bevy::ecs::query::QueryData)]
pub struct ObjectItem {
    /// The object.
    pub entity: Entity,
    /// Its stable id.
    pub id: &'static SceneId,
    /// Its name.
    pub name: &'static Name,
    /// Its local transform.
    pub transform: &'static Transform,
    /// Its world transform.
    pub global: &'static GlobalTransform,
    /// Its mesh, if it shows one.
    pub mesh: Option<&'static Mesh3d>,
    /// Whether it is a point light.
    pub point_light: Has<PointLight>,
    /// Whether it is a directional light.
    pub directional_light: Has<DirectionalLight>,
    /// Whether it is shown.
    pub visibility: Option<&'static Visibility>,
    /// Its parent.
    pub parent: Option<&'static ChildOf>,
}

/// What the UI reads of the history and how it asks for edits.
#[derive(SystemParam)]
pub struct EditAccess<'w, 's> {
    history: Res<'w, EditHistory>,
    requests: ResMut<'w, EditRequests>,
    /// The widget whose drag or typing made the last request, to merge what it does next.
    gesture: Local<'s, Option<egui::Id>>,
    outliner: ResMut<'w, OutlinerState>,
    outliner_cache: ResMut<'w, OutlinerCache>,
    files: ResMut<'w, crate::files::FileUi>,
    project: Res<'w, crate::project::ProjectState>,
    project_requests: ResMut<'w, crate::files::ProjectRequests>,
    recent: Res<'w, crate::files::RecentProjects>,
    health: Res<'w, crate::worker_watch::WorkerHealth>,
    opening: ResMut<'w, crate::project_open::OpeningProjects>,
    chords: Res<'w, crate::key_chords::KeyChords>,
}

/// What the viewport reads of the scene and keeps of its own.
#[derive(SystemParam)]
pub struct ViewportAccess<'w, 's> {
    cameras: Query<'w, 's, (Entity, &'static Camera, &'static GlobalTransform), With<OrbitCamera>>,
    orbit: Query<'w, 's, &'static mut OrbitCamera>,
    boxes: Query<'w, 's, (&'static Aabb, &'static GlobalTransform)>,
    children: Query<'w, 's, &'static Children>,
    materials: Res<'w, Assets<StandardMaterial>>,
    images: Res<'w, Assets<Image>>,
    material_of: Query<'w, 's, &'static MeshMaterial3d<StandardMaterial>, With<SceneObject>>,
    gizmo: ResMut<'w, GizmoSettings>,
    drag: ResMut<'w, ActiveDrag>,
    interaction: ResMut<'w, ViewportInteraction>,
    frame_request: ResMut<'w, FrameRequest>,
    clipboard: ResMut<'w, EditClipboard>,
    widgets: ResMut<'w, WidgetRects>,
}

/// Draws the editor UI and turns what the user changed into edit requests.
#[allow(clippy::too_many_arguments)]
pub fn editor_ui(
    mut contexts: EguiContexts,
    mut dock: ResMut<EditorDock>,
    mut selection: ResMut<Selection>,
    mut viewport_rect: ResMut<ViewportRect>,
    objects: Query<ObjectItem, With<SceneObject>>,
    diagnostics: Res<DiagnosticsStore>,
    window: Single<&Window, With<PrimaryWindow>>,
    all_entities: Query<()>,
    mut notices: ResMut<Notices>,
    mut imports: crate::import_jobs::ImportAccess,
    scene: Res<SceneBvh>,
    mut render: ResMut<ViewportRender>,
    tracer: Res<PathTracerStats>,
    edits: EditAccess,
    view: ViewportAccess,
) -> Result {
    let EditAccess {
        history,
        mut requests,
        mut gesture,
        mut outliner,
        mut outliner_cache,
        mut files,
        project,
        mut project_requests,
        health,
        mut opening,
        chords,
        recent,
    } = edits;
    let ViewportAccess {
        cameras,
        mut orbit,
        boxes,
        children,
        materials,
        images,
        material_of,
        mut gizmo,
        mut drag,
        mut interaction,
        mut frame_request,
        mut clipboard,
        mut widgets,
    } = view;
    let ctx = contexts.ctx_mut()?.clone();
    let parent_of = |e: Entity| -> Option<Entity> {
        objects
            .get(e)
            .ok()
            .and_then(|o| o.parent)
            .map(|c| c.parent())
            .filter(|p| objects.contains(*p))
    };

    // The outliner's rows, made again only when the scene or the outliner's state changed.
    outliner.collapsed.retain(|e| objects.contains(*e));
    if outliner_cache.stale_for(&outliner) {
        let items: Vec<OutlinerItem> = objects
            .iter()
            .map(|o| OutlinerItem {
                entity: o.entity,
                id: *o.id,
                parent: parent_of(o.entity),
                name: o.name.as_str().to_owned(),
                kind: kind_of(o.mesh.is_some(), o.point_light, o.directional_light),
                visible: o.visibility != Some(&Visibility::Hidden),
            })
            .collect();
        outliner_cache.remake(items, &outliner);
    }
    let (items, rows) = (&outliner_cache.items, &outliner_cache.rows);

    // The inspector's copy of the active object.
    let original = selection.active().and_then(|e| {
        let o = objects.get(e).ok()?;
        let mut state = InspectorState::new(*o.id, o.name.as_str(), o.transform);
        state.selected = selection.entities().len();
        if let Ok(handle) = material_of.get(e)
            && let Some(m) = materials.get(&handle.0)
        {
            let users = material_of
                .iter()
                .filter(|h| h.0.id() == handle.0.id())
                .count();
            let texture = m.base_color_texture.as_ref().and_then(|t| {
                let size = images.get(t)?.size();
                let id = contexts.add_image(EguiTextureHandle::Weak(t.id()));
                Some((id, size))
            });
            state.material = Some(MaterialView {
                value: MaterialValue::of(m),
                users,
                texture,
            });
        }
        Some(state)
    });
    let mut edited = original.clone();

    // What the viewport draws and drags.
    let camera_entity = cameras.single().ok().map(|(e, ..)| e);
    let camera = cameras.single().ok().map(|(_, c, g)| (c.clone(), *g));
    // The path tracer outlines the selected meshes' silhouettes itself (selection::outline_selected_meshes);
    // the rasteriser gets their boxes.
    let boxes_shown = render.traced.is_none();
    let viewport_scene = viewport_scene(
        &selection,
        &objects,
        (&boxes, boxes_shown),
        &children,
        camera,
        parent_of,
    );

    let mut orbit_copy = orbit.single().ok().copied();
    let mut viewport = egui::Rect::NOTHING;
    let mut render_copy = *render;
    let mut gizmo_copy = *gizmo;
    let history_labels = history.labels();
    let mut go_to = None;
    let mut panel_commands: Vec<EditCommand> = Vec::new();
    let mut actions = ViewportActions::default();
    let mut make_unique = false;
    let mut palette_click = None;
    let mut named_rects = Vec::new();
    let mut row_rects = Vec::new();
    let f2 = chords.triggered(crate::keymap::Action::Rename) && !ctx.egui_wants_keyboard_input();

    let mut root = egui::Ui::new(
        ctx.clone(),
        "treelight-root".into(),
        egui::UiBuilder::new()
            .layer_id(egui::LayerId::background())
            .max_rect(ctx.viewport_rect()),
    );
    let mut menu_action = None;
    egui::Panel::top("menu-bar").show(&mut root, |ui| {
        let state = menus::MenuState {
            history: &history,
            has_selection: !selection.is_empty(),
            can_paste: !clipboard.0.is_empty(),
            recent: &recent.0,
            project: &project,
        };
        menu_action = menus::menu_bar(ui, &state, &mut render_copy, &mut gizmo_copy);
    });
    egui::Panel::bottom("status-bar").show(&mut root, |ui| {
        ui.horizontal(|ui| {
            let fps = diagnostics
                .get(&FrameTimeDiagnosticsPlugin::FPS)
                .and_then(|d| d.smoothed())
                .map_or("–".to_owned(), |f| format!("{f:.0}"));
            ui.label(format!("{fps} FPS"));
            ui.separator();
            ui.label(format!("{} scene objects", items.len()));
            ui.separator();
            ui.label(format!("{} entities in the world", all_entities.iter().count()));
            let stats = scene.stats();
            ui.separator();
            ui.label(format!("BVH: {} triangles, SAH cost {:.1}", stats.triangles, stats.sah_cost))
                .on_hover_text(format!(
                    "{} inner nodes; last insertion {:.2} MTris/s; last mesh ready {:.1} ms after it was sent",
                    stats.inner_nodes,
                    stats.insertion_mtris_per_s,
                    stats.last_latency.as_secs_f64() * 1e3
                ));
            if let (Some(view), Some(camera_entity)) = (render.traced, camera_entity) {
                let figures = tracer.figures();
                ui.separator();
                let spp = figures.samples.get(&camera_entity).copied().unwrap_or(0);
                let trace = figures.traces.get(&camera_entity).copied().unwrap_or_default();
                let progress = if trace.previewing {
                    "preview".to_string()
                } else {
                    format!("{spp} spp")
                };
                let cost = trace.cost.map_or("not measured yet".to_string(), |(ns, source)| {
                    let how = match source {
                        treelight_render::CostSource::Timestamps => "GPU timestamps",
                        treelight_render::CostSource::FrameTimes => "from frame times",
                    };
                    format!("{ns:.0} ns per pixel sample ({how})")
                });
                ui.label(format!("{}: {progress}", view.label())).on_hover_text(format!(
                    "Samples every pixel has accumulated since the last change. This frame traced {} pixel samples; {cost}. Scene upload: {} bytes in the last upload, {} in all",
                    trace.traced_per_frame, figures.last_upload_bytes, figures.total_upload_bytes
                ));
            }
            if let Some(line) = health.status() {
                ui.separator();
                ui.colored_label(egui::Color32::from_rgb(255, 110, 100), line).on_hover_text(
                    [&health.worker, &health.refinement]
                        .into_iter()
                        .flatten()
                        .cloned()
                        .collect::<Vec<_>>()
                        .join("\n"),
                );
            } else if stats.pending > 0 {
                ui.spinner();
                ui.label(format!("{} changes pending", stats.pending));
            }
            match (&original, selection.entities().len()) {
                (Some(state), 1) => {
                    ui.separator();
                    ui.label(format!("Selected: {}", state.name));
                }
                (_, n) if n > 1 => {
                    ui.separator();
                    ui.label(format!("{n} selected"));
                }
                _ => {}
            }
            // Each import until the tree holds it: parsing (no measure of its own), then the
            // share of its triangles traced; either can be cancelled.
            let name = |p: &std::path::Path| {
                p.file_name()
                    .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into())
            };
            if let (Some((done, total)), Some(o)) = (opening.progress(), opening.0.as_ref()) {
                ui.separator();
                ui.spinner();
                ui.label(format!("Opening {}: {done} of {total} sources read", name(&o.path)));
                if ui.small_button("Cancel").clicked() {
                    opening.cancel();
                }
            }
            let mut cancel = Vec::new();
            for (k, job) in imports.pending.0.iter().enumerate() {
                ui.separator();
                ui.spinner();
                ui.label(format!("Opening {}…", name(&job.path)));
                if ui.push_id(("cancel-import", k), |ui| ui.small_button("Cancel")).inner.clicked() {
                    cancel.push(job.path.clone());
                }
            }
            for job in &imports.tracing.jobs {
                ui.separator();
                ui.add(
                    egui::ProgressBar::new(job.fraction())
                        .desired_width(160.0)
                        .text(format!(
                            "{}: {:.0}% traced",
                            name(&job.file),
                            job.fraction() * 100.0
                        )),
                )
                .on_hover_text(format!(
                    "{} of {} triangles in the tree; nearest the camera first",
                    job.traced,
                    job.total()
                ));
                if ui.small_button("Cancel").clicked() {
                    cancel.push(job.file.clone());
                }
            }
            imports.cancel.0.extend(cancel);
        });
    });
    egui::CentralPanel::default()
        .frame(egui::Frame::NONE)
        .show(&mut root, |ui| {
            let mut tabs = EditorTabs {
                viewport: ViewportPanel {
                    scene: &viewport_scene,
                    orbit: orbit_copy.as_mut(),
                    render: &mut render_copy,
                    gizmo: &mut gizmo_copy,
                    drag: &mut drag.0,
                    interaction: &mut interaction,
                    rect: &mut viewport,
                    actions: &mut actions,
                },
                outliner: OutlinerPanel {
                    items,
                    rows,
                    selection: &mut selection,
                    state: &mut outliner,
                    commands: &mut panel_commands,
                    f2,
                    row_rects: &mut row_rects,
                },
                inspected: edited.as_mut(),
                make_unique: &mut make_unique,
                history: (&history_labels, history.head()),
                go_to: &mut go_to,
                palette_click: &mut palette_click,
                library: &imports.library,
                textures: &mut imports.textures,
                named_rects: &mut named_rects,
            };
            DockArea::new(&mut dock.0)
                .style(Style::from_egui(ui.style().as_ref()))
                .show_close_buttons(false)
                .show_leaf_close_all_buttons(false)
                .show_leaf_collapse_buttons(false)
                .show_inside(ui, &mut tabs);
        });

    show_notices(&ctx, &mut notices);
    if let Some(MenuAction::File(a)) = menu_action.clone() {
        files.act(a, &project, history.is_dirty(), &mut project_requests);
    }
    named_rects.extend(files.show(&ctx, &project, &mut project_requests));

    if *render != render_copy {
        *render = render_copy;
    }
    widgets.0 = named_rects
        .into_iter()
        .chain(row_rects)
        .map(|(n, r)| (n, [r.min.x, r.min.y, r.width(), r.height()]))
        .collect();
    if *gizmo != gizmo_copy {
        *gizmo = gizmo_copy;
    }

    // Clicks and boxes in the viewport select through the scene BVH (waiting for the worker if it
    // holds the tree: a click must not miss).
    if let Some((e, modifiers)) = actions.icon_click {
        crate::selection::click(&mut selection, Some(e), modifiers, false, parent_of);
    }
    if let (Some((at, modifiers, same_spot)), Some((camera, cam_gt))) =
        (actions.click, viewport_scene.camera.as_ref())
        && let Ok(ray) = camera.viewport_to_world(cam_gt, at)
    {
        let hit = cast_on(&scene.read_blocking(), ray)
            .map(|h| h.entity)
            .filter(|e| objects.contains(*e));
        crate::selection::click(&mut selection, hit, modifiers, same_spot, parent_of);
    }
    if let (Some((rect, modifiers)), Some((camera, cam_gt))) =
        (actions.box_select, viewport_scene.camera.as_ref())
    {
        let inside = box_select(&scene, camera, cam_gt, rect, &objects, &boxes);
        if !modifiers.toggle {
            selection.clear();
        }
        for e in inside {
            selection.add(e);
        }
    }

    let mut add_at_centre = None;
    let selected_ids: Vec<SceneId> = selection
        .entities()
        .iter()
        .filter_map(|e| objects.get(*e).ok().map(|o| *o.id))
        .collect();
    match menu_action {
        Some(MenuAction::Undo) => requests.0.push(EditRequest::Undo),
        Some(MenuAction::Redo) => requests.0.push(EditRequest::Redo),
        Some(MenuAction::Duplicate) if !selected_ids.is_empty() => {
            requests.apply(EditCommand::Duplicate {
                ids: selected_ids.clone(),
                copies: Vec::new(),
            })
        }
        Some(MenuAction::Delete) if !selected_ids.is_empty() => {
            requests.apply(EditCommand::Delete {
                ids: selected_ids.clone(),
            })
        }
        Some(MenuAction::SelectNone) => selection.clear(),
        Some(MenuAction::Copy) => clipboard.0 = selected_ids.clone(),
        Some(MenuAction::Paste) => requests.0.extend(clipboard.paste(&imports.index)),
        Some(MenuAction::Group) if !selected_ids.is_empty() => requests.apply(EditCommand::Group {
            ids: selected_ids.clone(),
            name: "Group".into(),
            group: None,
        }),
        // A light goes a little above where the view's centre meets the scene; a directional
        // one shines down the way the view looks.
        Some(MenuAction::AddLight(kind)) => {
            if let Some((camera, cam_gt)) = viewport_scene.camera.as_ref()
                && let Some(rect) = camera.logical_viewport_rect()
                && let Ok(ray) = camera.viewport_to_world(cam_gt, rect.center())
            {
                let surface = surface_under(&scene, ray, 5.0);
                let at = surface.point + surface.normal * 1.0;
                let f = Vec3::from(cam_gt.forward());
                let down = Vec3::new(f.x, -1.0, f.z).normalize();
                let transform = match kind {
                    LightKind::Point => Transform::from_translation(at),
                    LightKind::Directional => {
                        Transform::from_translation(at + Vec3::Y * 2.0).looking_to(down, Vec3::Y)
                    }
                };
                requests.apply(EditCommand::AddLight {
                    kind,
                    transform: transform.into(),
                    id: None,
                });
            }
        }
        Some(MenuAction::FrameSelection) => frame_request.0 = true,
        Some(MenuAction::ResetLayout) => *dock = EditorDock::default(),
        // A new shape goes where the view's centre ray lands, by the placement rule.
        Some(MenuAction::Add(shape)) => add_at_centre = Some(shape),
        _ => {}
    }
    let mut palette_shape = None;
    match palette_click {
        Some(palette::PaletteClick::Shape(shape)) => palette_shape = Some(shape),
        Some(palette::PaletteClick::File(file)) => imports.import_at(file, None),
        Some(palette::PaletteClick::AddFolder) => files.act(
            crate::files::FileAction::AddAssetFolder,
            &project,
            history.is_dirty(),
            &mut project_requests,
        ),
        Some(palette::PaletteClick::RemoveFolder(dir)) => imports.library.remove_folder(&dir),
        None => {}
    }
    if let Some(shape) = add_at_centre.or(palette_shape)
        && let Some((camera, cam_gt)) = viewport_scene.camera.as_ref()
        && let Some(rect) = camera.logical_viewport_rect()
        && let Ok(ray) = camera.viewport_to_world(cam_gt, rect.center())
    {
        let surface = surface_under(&scene, ray, 5.0);
        let (min, max) = shape.bounds();
        requests.apply(EditCommand::AddPrimitive {
            shape,
            transform: place_transform(surface, min, max, false).into(),
            id: None,
        });
    }
    // A palette item over the viewport: its ghost (a preview, traced like any object) follows the
    // pointer by the placement rule; a drop makes it one step; anything else removes the ghost.
    let ghost = history.preview_made();
    let ghost_root = ghost.and_then(|g| imports.index.entity(g));
    // The ghost and everything under it, which placement sees through.
    let ghost_parts: Vec<Entity> = ghost_root.map_or_else(Vec::new, |root| {
        objects
            .iter()
            .map(|o| o.entity)
            .filter(|&e| {
                let mut at = Some(e);
                while let Some(x) = at {
                    if x == root {
                        return true;
                    }
                    at = parent_of(x);
                }
                false
            })
            .collect()
    });
    let file_dragged = actions.palette_file.is_some();
    if let (Some((file, at, _, dropped)), Some((camera, cam_gt))) =
        (actions.palette_file.take(), viewport_scene.camera.as_ref())
    {
        let ray = camera.viewport_to_world(cam_gt, at).ok();
        let read = imports.library.parsed(&file);
        match (ray, read.as_ref().map(|(_, bounds)| *bounds)) {
            (Some(ray), Some(bounds)) => {
                // Stands where a dropped file would (its own orientation kept).
                let surface = surface_under_excluding(&scene, ray, 5.0, &ghost_parts);
                let transform = crate::import::drop_transform(bounds, surface);
                match (dropped, ghost) {
                    (false, Some(id)) => {
                        requests
                            .0
                            .push(EditRequest::Preview(EditCommand::SetTransform {
                                id,
                                transform: transform.into(),
                            }))
                    }
                    _ => {
                        // The import command takes the file as the panel read it, under the id
                        // its root will have.
                        let root = imports.index.allocate();
                        if let Some((read, _)) = &read {
                            imports
                                .parsed
                                .0
                                .insert(root, crate::import::ParsedScene::from((**read).clone()));
                        }
                        let command = EditCommand::Import {
                            file,
                            root: Some(root),
                            transform: Some(transform.into()),
                        };
                        requests.0.push(drop_or_preview(command, dropped));
                    }
                }
            }
            // Not read yet: it is imported where it lands, without a ghost.
            _ if dropped => imports.import_at(file, Some(at)),
            _ => {}
        }
    }
    match (actions.palette, viewport_scene.camera.as_ref()) {
        (Some((item, at, aligned, dropped)), Some((camera, cam_gt))) => {
            if let Ok(ray) = camera.viewport_to_world(cam_gt, at) {
                let surface = surface_under_excluding(&scene, ray, 5.0, &ghost_parts);
                let (min, max) = item.0.bounds();
                let transform = place_transform(surface, min, max, aligned);
                let command = match (dropped, ghost) {
                    (false, Some(id)) => EditCommand::SetTransform {
                        id,
                        transform: transform.into(),
                    },
                    _ => EditCommand::AddPrimitive {
                        shape: item.0,
                        transform: transform.into(),
                        id: None,
                    },
                };
                requests.0.push(drop_or_preview(command, dropped));
            }
        }
        _ if ghost.is_some() && drag.0.is_none() && !file_dragged => {
            requests.0.push(EditRequest::CancelPreview)
        }
        _ => {}
    }
    requests.0.append(&mut actions.requests);
    if let Some(i) = go_to {
        requests.0.push(EditRequest::GoTo(i));
    }
    for command in panel_commands {
        requests.apply(command);
    }
    if make_unique && let Some(state) = &original {
        requests.apply(EditCommand::MakeMaterialUnique { id: state.id });
    }
    let active = ctx.dragged_id().or_else(|| ctx.memory(|m| m.focused()));
    if let (Some(before), Some(after)) = (&original, &edited)
        && before != after
    {
        let continuing = active.is_some() && *gesture == active;
        requests
            .0
            .extend(inspector::changes(before, after, continuing));
    }
    *gesture = active;
    if let (Ok(mut o), Some(copy)) = (orbit.single_mut(), orbit_copy)
        && (o.focus != copy.focus
            || o.radius != copy.radius
            || o.yaw != copy.yaw
            || o.pitch != copy.pitch)
    {
        *o = copy;
    }
    let scale = window.scale_factor();
    let rect = if viewport.is_positive() {
        ViewportRect {
            position: UVec2::new(
                (viewport.min.x * scale) as u32,
                (viewport.min.y * scale) as u32,
            ),
            size: UVec2::new(
                (viewport.width() * scale) as u32,
                (viewport.height() * scale) as u32,
            ),
        }
    } else {
        ViewportRect::default()
    };
    if *viewport_rect != rect {
        *viewport_rect = rect;
    }
    Ok(())
}

/// Gathers what the viewport draws (the selection's boxes, when `show_boxes`; icons) and what a
/// drag moves.
fn viewport_scene(
    selection: &Selection,
    objects: &Query<ObjectItem, With<SceneObject>>,
    (boxes, show_boxes): (&Query<(&Aabb, &GlobalTransform)>, bool),
    children: &Query<&Children>,
    camera: Option<(Camera, GlobalTransform)>,
    parent_of: impl Fn(Entity) -> Option<Entity>,
) -> ViewportScene {
    let mut out = ViewportScene {
        camera,
        ..default()
    };
    let active = selection.active();
    for &e in selection.entities().iter().filter(|_| show_boxes) {
        let Ok(o) = objects.get(e) else {
            continue;
        };
        let mesh = o.mesh;
        let is_active = Some(e) == active;
        // A mesh shows its own box, turned with it; a group the box around everything under it.
        if mesh.is_some()
            && let Ok((aabb, gt)) = boxes.get(e)
        {
            let (c, h) = (Vec3::from(aabb.center), Vec3::from(aabb.half_extents));
            out.outlines.push((
                box_corners(c - h, c + h).map(|p| gt.transform_point(p)),
                is_active,
            ));
        } else if let Some((min, max)) = world_bounds(e, boxes, children) {
            out.outlines.push((box_corners(min, max), is_active));
        }
    }
    (out.targets, out.active_world) = crate::viewport::drag_targets(
        selection,
        |e| objects.get(e).ok().map(|o| (*o.id, o.global.affine())),
        &parent_of,
    );
    for o in objects.iter() {
        let (e, gt) = (o.entity, o.global);
        let kind = if o.point_light {
            IconKind::PointLight
        } else if o.directional_light {
            IconKind::DirectionalLight
        } else if o.mesh.is_none() {
            IconKind::Empty
        } else {
            continue;
        };
        out.icons
            .push((e, gt.translation(), kind, selection.contains(e)));
    }
    out
}

/// The meshes a selection box picks: those the image shows inside it (rays through a grid of its
/// pixels, the nearest hit of each) and those whose whole box projects inside it.
fn box_select(
    scene: &SceneBvh,
    camera: &Camera,
    cam_gt: &GlobalTransform,
    rect: Rect,
    objects: &Query<ObjectItem, With<SceneObject>>,
    boxes: &Query<(&Aabb, &GlobalTransform)>,
) -> Vec<Entity> {
    let mut found: Vec<Entity> = Vec::new();
    if rect.width() < 2.0 || rect.height() < 2.0 {
        return found;
    }
    // A ray every 4 pixels, at most 96 a side.
    let nx = ((rect.width() / 4.0).ceil() as usize).clamp(2, 96);
    let ny = ((rect.height() / 4.0).ceil() as usize).clamp(2, 96);
    let tree = scene.read_blocking();
    for j in 0..ny {
        for i in 0..nx {
            let p = rect.min
                + Vec2::new(
                    rect.width() * (i as f32 + 0.5) / nx as f32,
                    rect.height() * (j as f32 + 0.5) / ny as f32,
                );
            if let Ok(ray) = camera.viewport_to_world(cam_gt, p)
                && let Some(hit) = cast_on(&tree, ray)
                && objects.contains(hit.entity)
                && !found.contains(&hit.entity)
            {
                found.push(hit.entity);
            }
        }
    }
    drop(tree);
    for o in objects.iter() {
        let e = o.entity;
        if o.mesh.is_none() || found.contains(&e) {
            continue;
        }
        if let Ok((aabb, gt)) = boxes.get(e) {
            let (c, h) = (Vec3::from(aabb.center), Vec3::from(aabb.half_extents));
            let inside = box_corners(c - h, c + h).iter().all(|p| {
                camera
                    .world_to_viewport(cam_gt, gt.transform_point(*p))
                    .is_ok_and(|s| rect.contains(s))
            });
            if inside {
                found.push(e);
            }
        }
    }
    found
}

/// Shows notices stacked in the top-right corner; each can be dismissed.
fn show_notices(ctx: &egui::Context, notices: &mut Notices) {
    let mut dismissed = None;
    for (k, n) in notices.0.iter().enumerate() {
        let (colour, title) = match n.level {
            Level::Info => (egui::Color32::from_rgb(140, 200, 255), "Info"),
            Level::Warning => (egui::Color32::from_rgb(255, 200, 90), "Warning"),
            Level::Error => (egui::Color32::from_rgb(255, 110, 100), "Error"),
        };
        egui::Area::new(egui::Id::new(("notice", k)))
            .anchor(
                egui::Align2::RIGHT_TOP,
                egui::vec2(-16.0, 40.0 + 64.0 * k as f32),
            )
            .show(ctx, |ui| {
                egui::Frame::popup(ui.style()).show(ui, |ui| {
                    ui.set_max_width(420.0);
                    ui.horizontal(|ui| {
                        ui.colored_label(colour, title);
                        if ui.small_button("✕").clicked() {
                            dismissed = Some(k);
                        }
                    });
                    ui.label(&n.text);
                });
            });
    }
    if let Some(k) = dismissed {
        notices.0.remove(k);
    }
}

/// Fits the 3D camera's viewport to the viewport panel.
pub fn fit_camera_viewport(
    rect: Res<ViewportRect>,
    window: Single<&Window, With<PrimaryWindow>>,
    mut cameras: Query<&mut Camera, With<OrbitCamera>>,
) {
    let max = UVec2::new(window.physical_width(), window.physical_height());
    for mut camera in &mut cameras {
        let pos = rect.position.min(max);
        let size = rect.size.min(max.saturating_sub(pos));
        camera.is_active = size.x > 0 && size.y > 0;
        let size = size.max(UVec2::ONE);
        let same = camera
            .viewport
            .as_ref()
            .is_some_and(|v| v.physical_position == pos && v.physical_size == size);
        if !same {
            camera.viewport = Some(Viewport {
                physical_position: pos,
                physical_size: size,
                ..default()
            });
        }
    }
}

/// The panels, menus and status bar, and the state they keep.
pub struct UiPlugin;

impl Plugin for UiPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<EditorDock>()
            .init_resource::<ViewportRect>()
            .init_resource::<OutlinerState>()
            .init_resource::<ViewportInteraction>()
            .init_resource::<WidgetRects>()
            .init_resource::<OutlinerCache>()
            .add_systems(
                bevy_egui::EguiPrimaryContextPass,
                (outliner::invalidate_outliner, editor_ui).chain(),
            )
            .add_systems(Update, fit_camera_viewport);
    }
}

/// A drag from the Assets panel: a live preview while it moves, one step when it is dropped.
fn drop_or_preview(command: EditCommand, dropped: bool) -> EditRequest {
    if dropped {
        EditRequest::Apply {
            command,
            continuing: false,
        }
    } else {
        EditRequest::Preview(command)
    }
}
