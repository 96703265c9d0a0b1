//! The viewport panel: the 3D view's input and what is drawn over it. The pointer goes to the
//! gizmo first, then to selection (click, box), then to the camera, and only inside the panel.
//! Drawn over the image, in raster and path-traced views alike: the selection's boxes, icons for
//! lights and empty groups, the gizmo, and the selection box being dragged.

use crate::editor::core::gizmo_settings::GizmoMode;
use crate::editor::core::gizmo_settings::GizmoSettings;
use crate::editor::core::gizmo_settings::GizmoSpace;
use crate::editor::core::selection::ClickModifiers;
use crate::editor::core::view::OrbitCamera;
use crate::editor::core::viewport_render::ViewportRender;
use crate::editor::core::widget_rects::WidgetRects;
use crate::editor::viewport::actions::ViewportActions;
use crate::editor::viewport::gizmo::DragTarget;
use crate::editor::viewport::gizmo::GizmoDrag;
use crate::editor::viewport::gizmo::GizmoFrame;
use crate::editor::viewport::gizmo::Handle;
use crate::editor::viewport::gizmo::ViewProjection;
use bevy::math::Affine3A;
use bevy::prelude::*;
use bevy_egui::egui;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::EditRequest;
use treelight_document::scene::environment::SceneEnvironment;
use treelight_document::values::light::LightKind;
use treelight_document::values::look::SceneLook;
use treelight_document::values::object::SceneId;

/// An icon drawn at a scene object without geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IconKind {
    /// A light.
    Light(LightKind),
    /// A camera (a glTF file's).
    Camera,
    /// An empty group (an assembly's root or a node without a mesh).
    Empty,
}

impl IconKind {
    fn glyph(self) -> &'static str {
        match self {
            IconKind::Light(kind) => crate::editor::core::object_item::light_glyph(kind),
            IconKind::Camera => "📷",
            IconKind::Empty => "◇",
        }
    }
}

/// What the viewport shows of the scene this frame, gathered before the UI runs.
#[derive(Default)]
pub struct ViewportScene {
    /// The editor camera and its transform.
    pub camera: Option<(Camera, GlobalTransform)>,
    /// Outlines of the selection: boxes as eight corners in world space, and whether each belongs
    /// to the active object.
    pub outlines: Vec<([Vec3; 8], bool)>,
    /// Icons: entity, world position, kind, whether selected.
    pub icons: Vec<(Entity, Vec3, IconKind, bool)>,
    /// The selected objects a drag moves (those not under another selected one).
    pub targets: Vec<DragTarget>,
    /// The active object's world transform.
    pub active_world: Option<Affine3A>,
    /// A line shown across the middle of the viewport, while the view waits for something.
    pub waiting: Option<&'static str>,
}

/// What the viewport remembers between frames.
#[derive(Resource, Default)]
pub struct ViewportInteraction {
    /// Where a selection box began, while one is being dragged.
    box_start: Option<egui::Pos2>,
    /// Where the last click was.
    last_click: Option<egui::Pos2>,
}

/// Pixels within which a second click counts as the same spot.
const SAME_SPOT: f32 = 4.0;
/// Pixels within which a click hits an icon.
const ICON_RADIUS: f32 = 11.0;

fn axis_colour(i: usize, hot: bool) -> egui::Color32 {
    if hot {
        return egui::Color32::from_rgb(255, 220, 60);
    }
    [
        egui::Color32::from_rgb(230, 70, 70),
        egui::Color32::from_rgb(90, 200, 80),
        egui::Color32::from_rgb(70, 130, 240),
    ][i]
}

fn pos(v: Vec2) -> egui::Pos2 {
    egui::pos2(v.x, v.y)
}

fn vec(p: egui::Pos2) -> Vec2 {
    Vec2::new(p.x, p.y)
}

/// The edges of a box given by its corners in [`treelight_document::scene::placement::box_corners`] order.
const BOX_EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// What a drag of the selection moves (the selected objects with no selected ancestor: their
/// children follow them) and the active object's world transform. `world_of` gives an object's id
/// and world transform, `parent_of` its parent among the scene objects.
pub fn drag_targets(
    selection: &crate::editor::core::selection::Selection,
    world_of: impl Fn(Entity) -> Option<(SceneId, Affine3A)>,
    parent_of: impl Fn(Entity) -> Option<Entity>,
) -> (Vec<DragTarget>, Option<Affine3A>) {
    let mut targets = Vec::new();
    let mut active = None;
    for &e in selection.entities() {
        let Some((id, world)) = world_of(e) else {
            continue;
        };
        if Some(e) == selection.active() {
            active = Some(world);
        }
        let mut up = parent_of(e);
        let mut under_selected = false;
        while let Some(p) = up {
            if selection.contains(p) {
                under_selected = true;
                break;
            }
            up = parent_of(p);
        }
        if !under_selected {
            let parent_world = parent_of(e)
                .and_then(&world_of)
                .map_or(Affine3A::IDENTITY, |(_, w)| w);
            targets.push(DragTarget {
                id,
                start_world: world,
                parent_world,
            });
        }
    }
    (targets, active)
}

/// The gizmo's frame for the selection: at the median of the moved objects, with the world's axes
/// or the active object's (scaling always takes the object's own).
pub fn gizmo_frame(
    targets: &[DragTarget],
    active_world: Option<Affine3A>,
    settings: &GizmoSettings,
    view: &impl ViewProjection,
) -> Option<GizmoFrame> {
    if targets.is_empty() {
        return None;
    }
    let pivot = targets
        .iter()
        .map(|t| Vec3::from(t.start_world.translation))
        .sum::<Vec3>()
        / targets.len() as f32;
    let local = settings.space == GizmoSpace::Local || settings.mode == GizmoMode::Scale;
    let axes = match (local, active_world) {
        (true, Some(w)) => GizmoFrame::axes_of(&w),
        _ => [Vec3::X, Vec3::Y, Vec3::Z],
    };
    GizmoFrame::new(pivot, axes, view)
}

/// The path tracer's denoiser, its resolution and the samples per pixel at which it stops.
fn quality_menu(ui: &mut egui::Ui, render: &mut ViewportRender, widgets: &mut WidgetRects) {
    // A settings popup: it stays open while its boxes are ticked, until a click outside it.
    let config = egui::containers::menu::MenuConfig::new()
        .close_behavior(egui::PopupCloseBehavior::CloseOnClickOutside);
    let (button, _) = egui::containers::menu::MenuButton::new("Quality")
        .config(config)
        .ui(ui, |ui| {
            if render.traced == Some(treelight_render::DebugView::PathTraced) {
                let toggle = ui
                    .checkbox(&mut render.settings.denoise, "Denoise")
                    .on_hover_text(
                        "Filter the path tracer's noise, guided by the surfaces' objects, normals, \
                     depths and colours (no light crosses an object's edge); while the camera \
                     moves, the last frames' picture is carried along",
                    );
                widgets.push("Denoise", toggle.rect);
                ui.separator();
            }
            ui.label(egui::RichText::new("Resolution").strong());
            for (scale, name) in crate::editor::core::viewport_render::TRACE_SCALES {
                let chosen = render.settings.resolution_scale == scale;
                let radio = ui.radio(chosen, name);
                widgets.push(format!("Resolution {name}"), radio.rect);
                if radio
                    .on_hover_text(format!(
                        "Trace {} the viewport's pixels along each axis (the image is upscaled)",
                        if scale == 1.0 {
                            "all".to_string()
                        } else {
                            format!("{:.0}% of", scale * 100.0)
                        }
                    ))
                    .clicked()
                {
                    render.settings.resolution_scale = scale;
                    render.scale_chosen = true;
                }
            }
            ui.separator();
            ui.horizontal(|ui| {
                ui.label("Stop at");
                ui.add(
                    egui::DragValue::new(&mut render.settings.max_samples)
                        .range(1..=65536)
                        .speed(8.0)
                        .suffix(" samples"),
                )
                .on_hover_text(
                    "Samples per pixel the view accumulates before it stops tracing (an edit or a \
                 camera move starts it again)",
                );
            });
        });
    widgets.push("Quality", button.rect);
    button.on_hover_text(
        "The path tracer's denoiser and resolution, and how many samples a view accumulates",
    );
}

/// The viewport's toolbar: render mode, gizmo mode, axes and snapping, then the look (exposure and
/// tone curve, as edit requests).
fn toolbar(
    ui: &mut egui::Ui,
    render: &mut ViewportRender,
    gizmo: &mut GizmoSettings,
    look: &SceneLook,
    environment: &SceneEnvironment,
    actions: &mut ViewportActions,
    widgets: &mut WidgetRects,
) {
    let combo = egui::ComboBox::from_id_salt("render-mode")
        .selected_text(ViewportRender::label(render.traced))
        .show_ui(ui, |ui| {
            for mode in ViewportRender::modes() {
                let label = ViewportRender::label(mode);
                let option = ui.selectable_value(&mut render.traced, mode, label);
                widgets.push(format!("Render mode {label}"), option.rect);
            }
        })
        .response
        .on_hover_text(
            "How the viewport is drawn: Bevy's rasteriser, the path tracer, or one of its debug views",
        );
    widgets.push("Render mode", combo.rect);
    if render.traced.is_some() {
        quality_menu(ui, render, widgets);
    }
    ui.separator();
    for (mode, key) in [
        (GizmoMode::Translate, "W"),
        (GizmoMode::Rotate, "E"),
        (GizmoMode::Scale, "R"),
    ] {
        ui.selectable_value(&mut gizmo.mode, mode, mode.label())
            .on_hover_text(format!(
                "{} the selection with the gizmo ({key})",
                mode.label()
            ));
    }
    ui.separator();
    let space = match gizmo.space {
        GizmoSpace::World => "World axes",
        GizmoSpace::Local => "Local axes",
    };
    if ui
        .button(space)
        .on_hover_text("Whether the gizmo follows the world's axes or the active object's")
        .clicked()
    {
        gizmo.space = match gizmo.space {
            GizmoSpace::World => GizmoSpace::Local,
            GizmoSpace::Local => GizmoSpace::World,
        };
    }
    ui.menu_button("Snap", |ui| {
        ui.label("Steps while Ctrl is held during a drag");
        egui::Grid::new("snap-steps").num_columns(2).show(ui, |ui| {
            ui.label("Grid");
            ui.add(
                egui::DragValue::new(&mut gizmo.grid_step)
                    .speed(0.01)
                    .range(0.001..=1000.0),
            );
            ui.end_row();
            ui.label("Angle (°)");
            ui.add(
                egui::DragValue::new(&mut gizmo.angle_step_deg)
                    .speed(0.5)
                    .range(0.1..=180.0),
            );
            ui.end_row();
            ui.label("Scale");
            ui.add(
                egui::DragValue::new(&mut gizmo.scale_step)
                    .speed(0.01)
                    .range(0.001..=10.0),
            );
            ui.end_row();
        });
    })
    .response
    .on_hover_text("Snapping steps for moves, rotations and scaling (hold Ctrl while dragging)");
    ui.separator();
    let edits = super::look::look_controls(ui, look, environment, widgets);
    actions.requests.extend(edits.requests);
    actions.choose_panorama |= edits.choose_panorama;
}

/// What the pointer and keys did over the viewport this frame.
#[derive(Clone, Copy)]
struct PointerInput {
    pointer: Option<egui::Pos2>,
    modifiers: egui::Modifiers,
    secondary_pressed: bool,
    press_origin: Option<egui::Pos2>,
    escape: bool,
}

/// Everything the viewport panel reads and changes.
pub struct ViewportPanel<'a> {
    /// What to draw and the drag targets.
    pub scene: &'a ViewportScene,
    /// The orbit camera's parameters, changed by camera input.
    pub orbit: Option<&'a mut OrbitCamera>,
    /// The render mode switch.
    pub render: &'a mut ViewportRender,
    /// The gizmo's settings.
    pub gizmo: &'a mut GizmoSettings,
    /// The scene's exposure and tone curve (changed through requests in `actions`).
    pub look: &'a SceneLook,
    /// The scene's sky panorama (changed likewise).
    pub environment: &'a SceneEnvironment,
    /// Where the named widgets are, for the report.
    pub widgets: &'a mut WidgetRects,
    /// The drag in progress.
    pub drag: &'a mut Option<GizmoDrag>,
    /// State kept between frames.
    pub interaction: &'a mut ViewportInteraction,
    /// Where the panel is, set here.
    pub rect: &'a mut egui::Rect,
    /// What the user did.
    pub actions: &'a mut ViewportActions,
    /// The key map's Cancel was pressed this frame: a palette drag or a gizmo drag is dropped.
    pub cancel: bool,
}

impl ViewportPanel<'_> {
    /// Lays out the viewport panel and handles its input.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        *self.rect = rect;
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let mut overlay = ui.new_child(
            egui::UiBuilder::new()
                .max_rect(rect.shrink(6.0))
                .layout(egui::Layout::left_to_right(egui::Align::Min)),
        );
        // A layout whose rows are as tall as their controls (a separator placed in the overlay
        // itself would run down the whole viewport), wrapping onto more rows where the viewport
        // is too narrow for one, so every control stays in reach in a small window.
        let bar = overlay.horizontal_wrapped(|ui| {
            toolbar(
                ui,
                self.render,
                self.gizmo,
                self.look,
                self.environment,
                self.actions,
                self.widgets,
            )
        });
        self.widgets.push("Viewport toolbar", bar.response.rect);

        let painter = ui.painter_at(rect);
        let Some((camera, cam_gt)) = self.scene.camera.as_ref() else {
            return;
        };
        let view = (camera, cam_gt);
        let input = ui.input(|i| PointerInput {
            pointer: i.pointer.hover_pos(),
            modifiers: i.modifiers,
            secondary_pressed: i.pointer.button_pressed(egui::PointerButton::Secondary),
            press_origin: i.pointer.press_origin(),
            escape: self.cancel,
        });
        let frame = gizmo_frame(
            &self.scene.targets,
            self.scene.active_world,
            self.gizmo,
            &view,
        );
        self.palette_drags(ui.ctx(), &response, rect, &input);
        // The gizmo has the pointer first, then selection, then the camera.
        let gizmo_took = self.gizmo_input(&response, &input, &view, frame, &painter);
        if !gizmo_took {
            self.selection_input(&response, &input, &view, &painter);
        }
        self.camera_input(ui, &response, &input, rect, gizmo_took);
        self.paint(&painter, &view, frame, input.pointer);
    }

    /// A palette item or file dragged over the viewport is shown where it would land (Escape
    /// cancels it); a release drops it.
    fn palette_drags(
        &mut self,
        ctx: &egui::Context,
        response: &egui::Response,
        rect: egui::Rect,
        input: &PointerInput,
    ) {
        let PointerInput {
            pointer,
            modifiers,
            escape,
            ..
        } = *input;
        // A palette item dragged over the viewport is shown where it would land; Escape cancels it.
        if let Some(item) =
            egui::DragAndDrop::payload::<crate::editor::core::palette_payload::PaletteItem>(ctx)
        {
            if escape {
                egui::DragAndDrop::clear_payload(ctx);
            } else if let Some(p) = pointer
                && rect.contains(p)
            {
                self.actions.palette = Some((*item, vec(p), modifiers.shift, false));
            }
        }
        // Taking a payload drops one of another type: each kind is taken only when it is the one
        // carried.
        if egui::DragAndDrop::has_payload_of_type::<crate::editor::core::palette_payload::PaletteItem>(
            ctx,
        ) && let Some(item) =
            response.dnd_release_payload::<crate::editor::core::palette_payload::PaletteItem>()
            && let Some(p) = pointer.or(response.interact_pointer_pos())
        {
            self.actions.palette = Some((*item, vec(p), modifiers.shift, true));
        }
        // A file from the panel is shown where it would land, like a shape; Escape cancels it.
        if let Some(file) =
            egui::DragAndDrop::payload::<crate::editor::core::palette_payload::PaletteFile>(ctx)
        {
            if escape {
                egui::DragAndDrop::clear_payload(ctx);
            } else if let Some(p) = pointer
                && rect.contains(p)
            {
                self.actions.palette_file = Some((file.clone(), vec(p), modifiers.shift, false));
            }
        }
        if egui::DragAndDrop::has_payload_of_type::<crate::editor::core::palette_payload::PaletteFile>(
            ctx,
        ) && let Some(file) =
            response.dnd_release_payload::<crate::editor::core::palette_payload::PaletteFile>()
            && let Some(p) = pointer.or(response.interact_pointer_pos())
        {
            self.actions.palette_file = Some((file, vec(p), modifiers.shift, true));
        }
    }

    /// A gizmo drag in progress, or one starting on a handle; whether the gizmo took the pointer.
    fn gizmo_input(
        &mut self,
        response: &egui::Response,
        input: &PointerInput,
        view: &(&Camera, &GlobalTransform),
        frame: Option<GizmoFrame>,
        painter: &egui::Painter,
    ) -> bool {
        let PointerInput {
            pointer,
            modifiers,
            secondary_pressed,
            press_origin,
            ..
        } = *input;
        let mut gizmo_took = false;
        if let Some(drag) = self.drag.as_ref() {
            gizmo_took = true;
            if secondary_pressed {
                *self.drag = None;
                self.actions.requests.push(EditRequest::CancelPreview);
            } else if let Some(p) = pointer.or(response.interact_pointer_pos()) {
                let snapping = modifiers.ctrl || modifiers.command;
                if let Some(result) = drag.result(vec(p), view, self.gizmo, snapping) {
                    let command = set_transforms(drag.transforms(result.delta));
                    let finished = response.drag_stopped() || !response.dragged();
                    if finished {
                        self.actions.requests.push(EditRequest::Apply {
                            command,
                            continuing: false,
                        });
                    } else {
                        self.actions.requests.push(EditRequest::Preview(command));
                    }
                    let text = match drag.handle {
                        Handle::Axis(_) | Handle::Plane(_) => format!("{:+.3}", result.amount),
                        Handle::Ring(_) => format!("{:+.1}°", result.amount),
                        Handle::ScaleAxis(_) | Handle::ScaleUniform => {
                            format!("×{:.3}", result.amount)
                        }
                    };
                    painter.text(
                        p + egui::vec2(16.0, -16.0),
                        egui::Align2::LEFT_BOTTOM,
                        text,
                        egui::FontId::proportional(14.0),
                        egui::Color32::WHITE,
                    );
                    if finished {
                        *self.drag = None;
                    }
                } else if response.drag_stopped() {
                    // Released where the drag means nothing: keep what the last preview showed.
                    *self.drag = None;
                    self.actions.requests.push(EditRequest::CancelPreview);
                }
            }
        } else if response.drag_started_by(egui::PointerButton::Primary)
            && !modifiers.alt
            && let (Some(frame), Some(origin)) = (frame, press_origin)
            && let Some(handle) = frame.pick(self.gizmo.mode, view, vec(origin))
        {
            *self.drag =
                GizmoDrag::start(handle, frame, vec(origin), view, self.scene.targets.clone());
            gizmo_took = self.drag.is_some();
        }
        gizmo_took
    }

    /// Clicks on icons or the image, and boxes dragged on it.
    fn selection_input(
        &mut self,
        response: &egui::Response,
        input: &PointerInput,
        view: &(&Camera, &GlobalTransform),
        painter: &egui::Painter,
    ) {
        let PointerInput {
            pointer,
            modifiers,
            press_origin,
            ..
        } = *input;
        let click_mods = ClickModifiers {
            toggle: modifiers.ctrl || modifiers.shift || modifiers.command,
            parent: modifiers.alt,
        };
        if response.drag_started_by(egui::PointerButton::Primary) && !modifiers.alt {
            self.interaction.box_start = press_origin;
        }
        if let Some(start) = self.interaction.box_start {
            let now = pointer.or(response.interact_pointer_pos()).unwrap_or(start);
            let r = egui::Rect::from_two_pos(start, now);
            painter.rect(
                r,
                0.0,
                egui::Color32::from_rgba_unmultiplied(120, 170, 255, 30),
                egui::Stroke::new(1.0, egui::Color32::from_rgb(120, 170, 255)),
                egui::StrokeKind::Inside,
            );
            if response.drag_stopped() || !response.dragged() {
                self.interaction.box_start = None;
                self.actions.box_select =
                    Some((Rect::from_corners(vec(r.min), vec(r.max)), click_mods));
            }
        }
        if response.clicked()
            && let Some(p) = response.interact_pointer_pos()
        {
            let icon = self
                .scene
                .icons
                .iter()
                .filter_map(|(e, w, ..)| Some((*e, view.project(*w)?.distance(vec(p)))))
                .filter(|(_, d)| *d <= ICON_RADIUS)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((e, _)) = icon {
                self.actions.icon_click = Some((e, click_mods));
            } else {
                let same = self
                    .interaction
                    .last_click
                    .is_some_and(|l| l.distance(p) <= SAME_SPOT);
                self.actions.click = Some((vec(p), click_mods, same));
            }
            self.interaction.last_click = Some(p);
        }
    }

    /// Orbit with the middle button or Alt+left, pan with Shift+middle or the right button, zoom
    /// with the wheel.
    fn camera_input(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        input: &PointerInput,
        rect: egui::Rect,
        gizmo_took: bool,
    ) {
        let modifiers = input.modifiers;
        if let Some(orbit) = self.orbit.as_deref_mut() {
            let delta = response.drag_delta();
            let delta = Vec2::new(delta.x, delta.y);
            // A right click that cancels a left drag must not pan.
            let left_down = ui.input(|i| i.pointer.button_down(egui::PointerButton::Primary));
            let middle = response.dragged_by(egui::PointerButton::Middle);
            let alt_left = response.dragged_by(egui::PointerButton::Primary) && modifiers.alt;
            let right = response.dragged_by(egui::PointerButton::Secondary) && !left_down;
            if (middle && modifiers.shift) || right {
                orbit.pan(delta, rect.height());
            } else if (middle || alt_left) && !gizmo_took {
                orbit.rotate(delta);
            }
            if response.hovered() {
                let scroll = ui.input(|i| i.smooth_scroll_delta.y);
                if scroll != 0.0 {
                    orbit.zoom(scroll / 50.0);
                }
            }
        }
    }

    fn paint(
        &self,
        painter: &egui::Painter,
        view: &impl ViewProjection,
        frame: Option<GizmoFrame>,
        pointer: Option<egui::Pos2>,
    ) {
        if let Some(line) = self.scene.waiting {
            painter.text(
                painter.clip_rect().center(),
                egui::Align2::CENTER_CENTER,
                line,
                egui::FontId::proportional(15.0),
                egui::Color32::from_gray(200),
            );
        }
        // Selection outlines, complete every frame whatever the path tracer has converged to.
        for (corners, active) in &self.scene.outlines {
            let colour = if *active {
                egui::Color32::from_rgb(255, 170, 40)
            } else {
                egui::Color32::from_rgb(230, 120, 30)
            };
            let stroke = egui::Stroke::new(if *active { 2.0 } else { 1.5 }, colour);
            for (a, b) in BOX_EDGES {
                if let (Some(pa), Some(pb)) = (view.project(corners[a]), view.project(corners[b])) {
                    painter.line_segment([pos(pa), pos(pb)], stroke);
                }
            }
        }
        for (_, at, kind, selected) in &self.scene.icons {
            let Some(p) = view.project(*at) else { continue };
            let fill = if *selected {
                egui::Color32::from_rgba_unmultiplied(255, 170, 40, 200)
            } else {
                egui::Color32::from_rgba_unmultiplied(30, 30, 36, 170)
            };
            painter.circle(
                pos(p),
                ICON_RADIUS - 1.0,
                fill,
                egui::Stroke::new(1.0, egui::Color32::from_gray(220)),
            );
            painter.text(
                pos(p),
                egui::Align2::CENTER_CENTER,
                kind.glyph(),
                egui::FontId::proportional(12.0),
                egui::Color32::WHITE,
            );
        }
        let Some(frame) = frame else { return };
        let hot = match self.drag.as_ref() {
            Some(d) => Some(d.handle),
            None => pointer.and_then(|p| frame.pick(self.gizmo.mode, view, vec(p))),
        };
        for (handle, shape) in frame.handles(self.gizmo.mode, view) {
            let is_hot = hot == Some(handle);
            let points: Vec<egui::Pos2> = shape.iter().map(|v| pos(*v)).collect();
            match handle {
                Handle::Axis(i) | Handle::ScaleAxis(i) => {
                    let colour = axis_colour(i, is_hot);
                    painter.line_segment([points[0], points[1]], egui::Stroke::new(3.0, colour));
                    if matches!(handle, Handle::Axis(_)) {
                        painter.circle_filled(points[1], 5.5, colour);
                    } else {
                        painter.rect_filled(
                            egui::Rect::from_center_size(points[1], egui::vec2(10.0, 10.0)),
                            1.0,
                            colour,
                        );
                    }
                }
                Handle::Plane(i) => {
                    let colour = axis_colour(i, is_hot);
                    painter.add(egui::Shape::convex_polygon(
                        points,
                        colour.gamma_multiply(if is_hot { 0.7 } else { 0.4 }),
                        egui::Stroke::new(1.0, colour),
                    ));
                }
                Handle::Ring(i) => {
                    painter.add(egui::Shape::line(
                        points,
                        egui::Stroke::new(2.5, axis_colour(i, is_hot)),
                    ));
                }
                Handle::ScaleUniform => {
                    let colour = if is_hot {
                        axis_colour(0, true)
                    } else {
                        egui::Color32::from_gray(230)
                    };
                    painter.circle_stroke(points[0], 7.0, egui::Stroke::new(2.5, colour));
                }
            }
        }
    }
}

/// One command for a drag's new transforms: `SetTransform` for one object, `SetTransforms` for
/// several.
pub fn set_transforms(transforms: Vec<(SceneId, Transform)>) -> EditCommand {
    match transforms.as_slice() {
        [(id, t)] => EditCommand::SetTransform {
            id: *id,
            transform: (*t).into(),
        },
        _ => EditCommand::SetTransforms {
            transforms: transforms
                .into_iter()
                .map(|(id, t)| (id, t.into()))
                .collect(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::editor::core::selection::Selection;

    /// A pinhole camera at (0, 0, 10) looking down -z, 800 × 600 logical pixels, 60° vertical field.
    struct Pinhole;

    const FOCAL: f32 = 300.0 / 0.577_350_26; // 300 / tan(30°)

    impl ViewProjection for Pinhole {
        fn project(&self, w: Vec3) -> Option<Vec2> {
            let v = w - Vec3::new(0.0, 0.0, 10.0);
            (v.z < -1e-4).then(|| Vec2::new(400.0 + FOCAL * v.x / -v.z, 300.0 - FOCAL * v.y / -v.z))
        }
        fn ray(&self, s: Vec2) -> Option<Ray3d> {
            let d = Vec3::new((s.x - 400.0) / FOCAL, -(s.y - 300.0) / FOCAL, -1.0);
            Some(Ray3d::new(Vec3::new(0.0, 0.0, 10.0), Dir3::new(d).ok()?))
        }
    }

    fn at(x: f32, y: f32, z: f32) -> Affine3A {
        Affine3A::from_translation(Vec3::new(x, y, z))
    }

    /// Three selected objects, the third a child of the first: a drag moves the first two about
    /// their median, and the child follows its parent instead of moving twice.
    fn selection_of_three() -> (Vec<DragTarget>, Option<Affine3A>) {
        let (a, b, child) = (
            Entity::from_bits(1 << 32 | 1),
            Entity::from_bits(1 << 32 | 2),
            Entity::from_bits(1 << 32 | 3),
        );
        let mut selection = Selection::default();
        selection.set_all([a, child, b]);
        let world = move |e: Entity| match e {
            e if e == a => Some((SceneId(1), at(-2.0, 0.0, 0.0))),
            e if e == b => Some((SceneId(2), at(2.0, 1.0, 0.0))),
            e if e == child => Some((SceneId(3), at(-2.0, 1.0, 0.0))),
            _ => None,
        };
        let parent = move |e: Entity| (e == child).then_some(a);
        drag_targets(&selection, world, parent)
    }

    #[test]
    fn a_multiple_selection_turns_about_one_pivot_and_children_follow_their_parent() {
        let (targets, active) = selection_of_three();
        let ids: Vec<_> = targets.iter().map(|t| t.id).collect();
        assert_eq!(
            ids,
            vec![SceneId(1), SceneId(2)],
            "the child is not a target"
        );
        assert_eq!(
            active,
            Some(at(2.0, 1.0, 0.0)),
            "the last selected is active"
        );
        let settings = GizmoSettings {
            mode: GizmoMode::Rotate,
            ..default()
        };
        let frame = gizmo_frame(&targets, active, &settings, &Pinhole).unwrap();
        assert!(frame.pivot.distance(Vec3::new(0.0, 0.5, 0.0)) < 1e-6);
        // A half turn on screen about the z ring (facing the camera) swaps the two objects.
        let c = Pinhole.project(frame.pivot).unwrap();
        let drag = GizmoDrag::start(
            Handle::Ring(2),
            frame,
            c + Vec2::new(90.0, 0.0),
            &Pinhole,
            targets,
        )
        .unwrap();
        let turned = drag
            .result(c + Vec2::new(-90.0, 0.001), &Pinhole, &settings, false)
            .unwrap();
        let moved = drag.transforms(turned.delta);
        assert!(moved[0].1.translation.distance(Vec3::new(2.0, 1.0, 0.0)) < 1e-3);
        assert!(moved[1].1.translation.distance(Vec3::new(-2.0, 0.0, 0.0)) < 1e-3);
    }

    #[test]
    fn a_plane_drag_moves_in_its_plane_with_the_grabbed_point_under_the_pointer() {
        let (targets, active) = selection_of_three();
        let settings = GizmoSettings::default();
        let frame = gizmo_frame(&targets, active, &settings, &Pinhole).unwrap();
        // The plane normal to y, seen at a slant: grab a point on it and move the pointer.
        let grab = frame.pivot + Vec3::new(0.3, 0.0, 0.3) * frame.size;
        let from = Pinhole.project(grab).unwrap();
        let to = from + Vec2::new(60.0, 25.0);
        let drag = GizmoDrag::start(Handle::Plane(1), frame, from, &Pinhole, targets).unwrap();
        let r = drag.result(to, &Pinhole, &settings, false).unwrap();
        let moved = Vec3::from(r.delta.translation);
        assert_eq!(moved.y, 0.0, "{moved}");
        assert!(moved.length() > 0.1);
        // The grabbed point, moved, is where the pointer now is.
        let now = Pinhole.project(grab + moved).unwrap();
        assert!(now.distance(to) < 1e-2, "{now} vs {to}");
        // Snapped: both in-plane components on the grid.
        let r = drag.result(to, &Pinhole, &settings, true).unwrap();
        for c in [r.delta.translation.x, r.delta.translation.z] {
            let step = settings.grid_step;
            assert!(((c / step).round() * step - c).abs() < 1e-5, "{c}");
        }
    }
}
