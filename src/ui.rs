//! The docked editor panels (viewport, outliner, inspector, history), the menu bar and the status
//! bar. Every change to the scene leaves as an [`EditRequest`].

use crate::camera::OrbitCamera;
use crate::edit::{EditCommand, EditHistory, EditRequest, EditRequests, Primitive};
use crate::import::PendingImports;
use crate::notice::{Level, Notices};
use crate::placement::{place_on, surface_under};
use crate::render_mode::ViewportRender;
use crate::scene_id::SceneId;
use crate::selection::{SceneObject, Selection};
use bevy::camera::Viewport;
use bevy::diagnostic::{DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_egui::{EguiContexts, egui};
use egui_dock::{DockArea, DockState, NodeIndex, Style, TabViewer};
use std::collections::{HashMap, HashSet};
use treelight_render::PathTracerStats;
use treelight_scene::SceneBvh;

/// The panels that can be docked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EditorTab {
    /// The 3D view.
    Viewport,
    /// The list of scene entities.
    Outliner,
    /// The selected entity's properties.
    Inspector,
    /// The edit history: every step, and a click goes back or forward to it.
    History,
}

/// The dock layout, kept between frames so the user's rearrangements persist.
#[derive(Resource)]
pub struct EditorDock(pub DockState<EditorTab>);

impl Default for EditorDock {
    fn default() -> Self {
        let mut state = DockState::new(vec![EditorTab::Viewport]);
        let tree = state.main_surface_mut();
        let [viewport, _outliner] =
            tree.split_left(NodeIndex::root(), 0.2, vec![EditorTab::Outliner]);
        let [_, inspector] = tree.split_right(viewport, 0.75, vec![EditorTab::Inspector]);
        tree.split_below(inspector, 0.6, vec![EditorTab::History]);
        Self(state)
    }
}

/// Where the viewport panel is, in physical pixels, for the 3D camera.
#[derive(Resource, Debug, Default, Clone, Copy, PartialEq)]
pub struct ViewportRect {
    /// Top-left corner.
    pub position: UVec2,
    /// Size; zero while the panel is hidden.
    pub size: UVec2,
}

/// One row of the outliner.
struct OutlinerRow {
    entity: Entity,
    id: SceneId,
    /// Whether the object itself is shown (its parent may still hide it).
    visible: bool,
    /// Levels below the top.
    depth: usize,
    /// `Some(expanded)` for a row with children.
    expandable: Option<bool>,
    name: String,
    kind: &'static str,
}

/// Editable copy of the selected entity's properties; written back only when changed, so an
/// untouched inspector never marks the transform as changed.
#[derive(Clone, PartialEq)]
struct InspectorState {
    name: String,
    translation: Vec3,
    rotation_deg: Vec3,
    scale: Vec3,
}

struct EditorTabs<'a> {
    rows: &'a [OutlinerRow],
    selection: &'a mut Selection,
    inspected: Option<&'a mut InspectorState>,
    orbit: Option<&'a mut OrbitCamera>,
    viewport: &'a mut egui::Rect,
    clicked_at: &'a mut Option<egui::Pos2>,
    render: &'a mut ViewportRender,
    /// The history's steps and how many are applied.
    history: (&'a [String], usize),
    /// A step the user clicked in the history panel.
    go_to: &'a mut Option<usize>,
    /// Commands the panels ask for this frame.
    commands: &'a mut Vec<EditCommand>,
    /// Outliner rows the user collapsed.
    collapsed: &'a mut HashSet<Entity>,
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
            EditorTab::Viewport => self.viewport_ui(ui),
            EditorTab::Outliner => self.outliner_ui(ui),
            EditorTab::Inspector => self.inspector_ui(ui),
            EditorTab::History => self.history_ui(ui),
        }
    }
}

impl EditorTabs<'_> {
    fn viewport_ui(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        *self.viewport = rect;
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        // The render-mode switch floats over the viewport's top-left corner.
        let mut overlay = ui.new_child(
            egui::UiBuilder::new()
                .max_rect(rect.shrink(6.0))
                .layout(egui::Layout::left_to_right(egui::Align::Min)),
        );
        egui::ComboBox::from_id_salt("render-mode")
            .selected_text(ViewportRender::label(self.render.traced))
            .show_ui(&mut overlay, |ui| {
                for mode in ViewportRender::modes() {
                    ui.selectable_value(&mut self.render.traced, mode, ViewportRender::label(mode));
                }
            })
            .response
            .on_hover_text("How the viewport is drawn: Bevy's rasteriser, the path tracer, or one of its debug views");
        if response.clicked() {
            *self.clicked_at = response.interact_pointer_pos();
        }
        let Some(orbit) = self.orbit.as_deref_mut() else {
            return;
        };
        let delta = response.drag_delta();
        let delta = Vec2::new(delta.x, delta.y);
        let pan = ui.input(|i| i.modifiers.shift);
        if response.dragged_by(egui::PointerButton::Primary) && !pan {
            orbit.rotate(delta);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
            || (response.dragged_by(egui::PointerButton::Primary) && pan)
        {
            orbit.pan(delta, rect.height());
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                orbit.zoom(scroll / 50.0);
            }
        }
    }

    fn outliner_ui(&mut self, ui: &mut egui::Ui) {
        egui::ScrollArea::vertical()
            .auto_shrink([false; 2])
            .show(ui, |ui| {
                for row in self.rows {
                    let selected = self.selection.0 == Some(row.entity);
                    ui.horizontal(|ui| {
                        ui.add_space(row.depth as f32 * 14.0);
                        match row.expandable {
                            Some(expanded) => {
                                let arrow = if expanded { "⏷" } else { "⏵" };
                                if ui.small_button(arrow).clicked() {
                                    if expanded {
                                        self.collapsed.insert(row.entity);
                                    } else {
                                        self.collapsed.remove(&row.entity);
                                    }
                                }
                            }
                            None => ui.add_space(18.0),
                        }
                        // Show or hide: a hidden mesh leaves the traced scene too.
                        let eye = if row.visible { "👁" } else { "—" };
                        let tip = if row.visible { "Hide" } else { "Show" };
                        if ui.small_button(eye).on_hover_text(tip).clicked() {
                            self.commands.push(EditCommand::SetVisible {
                                id: row.id,
                                visible: !row.visible,
                            });
                        }
                        let label = format!("{}  {}", row.kind, row.name);
                        if ui.selectable_label(selected, label).clicked() {
                            self.selection.0 = Some(row.entity);
                        }
                    });
                }
                if self.rows.is_empty() {
                    ui.weak("The scene is empty.");
                }
            });
    }

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

    fn inspector_ui(&mut self, ui: &mut egui::Ui) {
        let Some(state) = self.inspected.as_deref_mut() else {
            ui.weak("Select an entity in the outliner.");
            return;
        };
        egui::Grid::new("inspector")
            .num_columns(2)
            .spacing([8.0, 6.0])
            .show(ui, |ui| {
                ui.label("Name");
                ui.text_edit_singleline(&mut state.name);
                ui.end_row();
                vec3_row(ui, "Translation", &mut state.translation, 0.05);
                vec3_row(ui, "Rotation (°)", &mut state.rotation_deg, 1.0);
                vec3_row(ui, "Scale", &mut state.scale, 0.01);
            });
    }
}

fn vec3_row(ui: &mut egui::Ui, label: &str, v: &mut Vec3, speed: f32) {
    ui.label(label);
    ui.horizontal(|ui| {
        for (axis, c) in ["x", "y", "z"]
            .into_iter()
            .zip([&mut v.x, &mut v.y, &mut v.z])
        {
            ui.label(axis);
            ui.add(egui::DragValue::new(c).speed(speed).max_decimals(3));
        }
    });
    ui.end_row();
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

/// What the outliner and inspector read and edit of each scene entity.
type ObjectItem = (
    Entity,
    &'static SceneId,
    &'static Name,
    &'static Transform,
    Has<Mesh3d>,
    Has<PointLight>,
    Has<DirectionalLight>,
    Option<&'static Visibility>,
    Option<&'static ChildOf>,
);

/// The shortcuts and mouse controls the Help menu lists.
const SHORTCUTS: &[(&str, &str)] = &[
    ("Ctrl+Z", "Undo"),
    ("Ctrl+Shift+Z, Ctrl+Y", "Redo"),
    ("Del", "Delete the selection"),
    ("Ctrl+D", "Duplicate the selection (the copy is selected)"),
    ("F", "Frame the selection"),
    ("Esc", "Clear the selection"),
    ("Left click", "Select what is under the pointer"),
    ("Left drag", "Orbit"),
    ("Right or middle drag, Shift+left drag", "Pan"),
    ("Wheel", "Zoom"),
];

/// What the UI reads of the history and how it asks for edits.
#[derive(SystemParam)]
pub struct EditAccess<'w, 's> {
    history: Res<'w, EditHistory>,
    requests: ResMut<'w, EditRequests>,
    /// The widget whose drag or typing made the last request, to merge what it does next.
    gesture: Local<'s, Option<egui::Id>>,
    /// Outliner rows the user collapsed.
    outliner: Local<'s, HashSet<Entity>>,
}

/// Draws the editor UI and turns what the user changed into edit requests.
#[allow(clippy::too_many_arguments)]
pub fn editor_ui(
    mut contexts: EguiContexts,
    mut dock: ResMut<EditorDock>,
    mut selection: ResMut<Selection>,
    mut viewport_rect: ResMut<ViewportRect>,
    objects: Query<ObjectItem, With<SceneObject>>,
    mut orbit: Query<&mut OrbitCamera>,
    diagnostics: Res<DiagnosticsStore>,
    window: Single<&Window, With<PrimaryWindow>>,
    all_entities: Query<()>,
    mut notices: ResMut<Notices>,
    pending: Res<PendingImports>,
    scene: Res<SceneBvh>,
    cameras: Query<(Entity, &Camera, &GlobalTransform), With<OrbitCamera>>,
    mut render: ResMut<ViewportRender>,
    tracer: Res<PathTracerStats>,
    edits: EditAccess,
) -> Result {
    let EditAccess {
        history,
        mut requests,
        mut gesture,
        mut outliner,
    } = edits;
    let ctx = contexts.ctx_mut()?.clone();
    // The outliner lists the scene as a tree: each object after its parent, indented, and nothing
    // under a collapsed row.
    let mut children: HashMap<Option<Entity>, Vec<Entity>> = HashMap::new();
    for (entity, .., parent) in objects.iter() {
        let parent = parent.map(|p| p.parent()).filter(|p| objects.contains(*p));
        children.entry(parent).or_default().push(entity);
    }
    for list in children.values_mut() {
        list.sort_by_key(|e| e.index());
    }
    outliner.retain(|e| objects.contains(*e));
    let mut rows: Vec<OutlinerRow> = Vec::new();
    let mut stack: Vec<(Entity, usize)> = children
        .get(&None)
        .map(|r| r.iter().rev().map(|e| (*e, 0)).collect())
        .unwrap_or_default();
    while let Some((entity, depth)) = stack.pop() {
        let Ok((_, id, name, _, mesh, point, dir, vis, _)) = objects.get(entity) else {
            continue;
        };
        let kids = children.get(&Some(entity));
        let collapsed = outliner.contains(&entity);
        rows.push(OutlinerRow {
            entity,
            id: *id,
            name: name.as_str().to_owned(),
            kind: kind_of(mesh, point, dir),
            visible: vis != Some(&Visibility::Hidden),
            depth,
            expandable: kids.is_some_and(|k| !k.is_empty()).then_some(!collapsed),
        });
        if !collapsed && let Some(kids) = kids {
            stack.extend(kids.iter().rev().map(|e| (*e, depth + 1)));
        }
    }
    let original = selection
        .0
        .and_then(|e| objects.get(e).ok())
        .map(|(_, _, name, t, ..)| {
            let (y, x, z) = t.rotation.to_euler(EulerRot::YXZ);
            InspectorState {
                name: name.as_str().to_owned(),
                translation: t.translation,
                rotation_deg: Vec3::new(x, y, z) * (180.0 / std::f32::consts::PI),
                scale: t.scale,
            }
        });
    let mut edited = original.clone();
    let mut orbit_copy = orbit.single().ok().copied();
    let mut viewport = egui::Rect::NOTHING;
    let mut clicked_at = None;
    let mut render_copy = *render;
    let history_labels = history.labels();
    let mut go_to = None;
    let mut panel_commands: Vec<EditCommand> = Vec::new();

    let mut root = egui::Ui::new(
        ctx.clone(),
        "treelight-root".into(),
        egui::UiBuilder::new()
            .layer_id(egui::LayerId::background())
            .max_rect(ctx.viewport_rect()),
    );
    let selected_id = selection
        .0
        .and_then(|e| objects.get(e).ok())
        .map(|(_, id, ..)| *id);
    let mut added: Option<Primitive> = None;
    egui::Panel::top("menu-bar").show(&mut root, |ui| {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("Edit", |ui| {
                let undo = history.undo_label();
                let label = undo.as_ref().map_or("Undo".into(), |l| format!("Undo {l}"));
                let button = egui::Button::new(label).shortcut_text("Ctrl+Z");
                if ui.add_enabled(undo.is_some(), button).clicked() {
                    requests.0.push(EditRequest::Undo);
                }
                let redo = history.redo_label();
                let label = redo.as_ref().map_or("Redo".into(), |l| format!("Redo {l}"));
                let button = egui::Button::new(label).shortcut_text("Ctrl+Shift+Z, Ctrl+Y");
                if ui.add_enabled(redo.is_some(), button).clicked() {
                    requests.0.push(EditRequest::Redo);
                }
                ui.separator();
                let button = egui::Button::new("Duplicate").shortcut_text("Ctrl+D");
                if ui.add_enabled(selected_id.is_some(), button).clicked()
                    && let Some(id) = selected_id
                {
                    requests.apply(EditCommand::Duplicate {
                        ids: vec![id],
                        copies: Vec::new(),
                    });
                }
                let button = egui::Button::new("Delete").shortcut_text("Del");
                if ui.add_enabled(selected_id.is_some(), button).clicked()
                    && let Some(id) = selected_id
                {
                    requests.apply(EditCommand::Delete { ids: vec![id] });
                }
            });
            ui.menu_button("Add", |ui| {
                for shape in Primitive::ALL {
                    if ui.button(shape.label()).clicked() {
                        added = Some(shape);
                    }
                }
            });
            ui.menu_button("Help", |ui| {
                ui.label(egui::RichText::new("Keys and mouse").strong());
                egui::Grid::new("shortcuts").num_columns(2).show(ui, |ui| {
                    for (keys, what) in SHORTCUTS {
                        ui.monospace(*keys);
                        ui.label(*what);
                        ui.end_row();
                    }
                });
                ui.weak("Keys do nothing while a text field has the keyboard.");
            });
        });
    });
    egui::Panel::bottom("status-bar").show(&mut root, |ui| {
        ui.horizontal(|ui| {
            let fps = diagnostics
                .get(&FrameTimeDiagnosticsPlugin::FPS)
                .and_then(|d| d.smoothed())
                .map_or("–".to_owned(), |f| format!("{f:.0}"));
            ui.label(format!("{fps} FPS"));
            ui.separator();
            ui.label(format!("{} scene entities", rows.len()));
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
            if let (Some(view), Ok((camera, ..))) = (render.traced, cameras.single()) {
                let figures = tracer.figures();
                ui.separator();
                let spp = figures.samples.get(&camera).copied().unwrap_or(0);
                let trace = figures.traces.get(&camera).copied().unwrap_or_default();
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
            if stats.pending > 0 {
                ui.spinner();
                ui.label(format!("{} changes pending", stats.pending));
            }
            if let Some(state) = &original {
                ui.separator();
                ui.label(format!("Selected: {}", state.name));
            }
            for (path, _) in &pending.0 {
                ui.separator();
                ui.spinner();
                ui.label(format!("Opening {}…", path.display()));
            }
        });
    });
    egui::CentralPanel::default()
        .frame(egui::Frame::NONE)
        .show(&mut root, |ui| {
            let mut tabs = EditorTabs {
                collapsed: &mut outliner,
                commands: &mut panel_commands,
                history: (&history_labels, history.head()),
                go_to: &mut go_to,
                rows: &rows,
                selection: &mut selection,
                inspected: edited.as_mut(),
                orbit: orbit_copy.as_mut(),
                viewport: &mut viewport,
                clicked_at: &mut clicked_at,
                render: &mut render_copy,
            };
            DockArea::new(&mut dock.0)
                .style(Style::from_egui(ui.style().as_ref()))
                .show_close_buttons(false)
                .show_leaf_close_all_buttons(false)
                .show_leaf_collapse_buttons(false)
                .show_inside(ui, &mut tabs);
        });

    show_notices(&ctx, &mut notices);

    // A click (not a drag) in the viewport selects what is under the pointer, through the scene BVH.
    if *render != render_copy {
        *render = render_copy;
    }
    if let (Some(pos), Ok((_, camera, cam_transform))) = (clicked_at, cameras.single())
        && let Ok(ray) = camera.viewport_to_world(cam_transform, Vec2::new(pos.x, pos.y))
    {
        selection.0 = scene
            .cast_ray(ray)
            .map(|hit| hit.entity)
            .filter(|e| objects.contains(*e));
    }

    if let Some(i) = go_to {
        requests.0.push(EditRequest::GoTo(i));
    }
    for command in panel_commands {
        requests.apply(command);
    }
    // A new shape goes where the view's centre ray lands, by the placement rule.
    if let (Some(shape), Ok((_, camera, cam_transform))) = (added, cameras.single())
        && let Some(size) = camera.logical_viewport_size()
        && let Ok(ray) = camera.viewport_to_world(cam_transform, size / 2.0)
    {
        let surface = surface_under(&scene, ray, 5.0);
        let (min, max) = shape.bounds();
        let translation = place_on(surface, min, max, Vec3::ONE);
        requests.apply(EditCommand::AddPrimitive {
            shape,
            transform: Transform::from_translation(translation).into(),
            id: None,
        });
    }
    // Inspector edits: one request per change; the changes of one drag of a field (or one text
    // field's typing) continue one step.
    let active = ctx.dragged_id().or_else(|| ctx.memory(|m| m.focused()));
    if let (Some(id), Some(before), Some(after)) = (selected_id, &original, &edited)
        && before != after
    {
        let continuing = active.is_some() && *gesture == active;
        if before.name != after.name {
            requests.0.push(EditRequest::Apply {
                command: EditCommand::Rename {
                    id,
                    name: after.name.clone(),
                },
                continuing,
            });
        }
        let r = after.rotation_deg * (std::f32::consts::PI / 180.0);
        let transform = Transform {
            translation: after.translation,
            rotation: Quat::from_euler(EulerRot::YXZ, r.y, r.x, r.z),
            scale: after.scale,
        };
        if (before.translation, before.rotation_deg, before.scale)
            != (after.translation, after.rotation_deg, after.scale)
        {
            requests.0.push(EditRequest::Apply {
                command: EditCommand::SetTransform {
                    id,
                    transform: transform.into(),
                },
                continuing,
            });
        }
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
