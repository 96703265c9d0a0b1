//! The menu bar (File, Edit, Add, View, Help), drawn by [`menu_bar_tab`], and what its entries do
//! ([`apply_menu_actions`]).

use treelight_document::edit::history::EditHistory;

use treelight_document::edit::command::LightKind;

use crate::editor::core::clipboard::EditClipboard;
use crate::editor::core::file_requests::{FileAction, FileRequest, RecentProjects};
use crate::editor::core::gizmo_settings::GizmoMode;
use crate::editor::core::gizmo_settings::GizmoSettings;
use crate::editor::core::gizmo_settings::GizmoSpace;
use crate::editor::core::keymap::Action;
use crate::editor::core::layout::EditorDock;
use crate::editor::core::place::{light_at, shape_at, view_ray};
use crate::editor::core::selection::Selection;
use crate::editor::core::view::{OrbitCamera, ViewChange, ViewRequest};
use crate::editor::core::viewport_render::ViewportRender;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy_egui::egui;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::{EditRequest, EditRequests};
use treelight_document::project::format::ProjectState;
use treelight_document::values::object::{SceneId, SceneIndex};
use treelight_document::values::primitive::Primitive;
use treelight_scene::SceneBvh;

/// The mouse controls and modified drags the Help menu lists after the keys (which come from
/// [`crate::editor::core::keymap::KEYMAP`]).
pub const MOUSE: &[(&str, &str)] = &[
    (
        "Ctrl while dragging",
        "Snap to the grid, angle and scale steps",
    ),
    ("Right click while dragging", "Cancel the drag"),
    ("Double click in the outliner", "Rename"),
    ("Left click", "Select what is under the pointer"),
    (
        "Left click again on the same spot, Alt+click",
        "Select the parent assembly",
    ),
    (
        "Ctrl+click, Shift+click",
        "Add to or remove from the selection",
    ),
    ("Left drag on the image", "Select with a box"),
    (
        "Drag from the Assets panel",
        "Place a shape on the surface under the pointer (Shift: along its normal)",
    ),
    ("Middle drag, Alt+left drag", "Orbit"),
    ("Shift+middle drag, right drag", "Pan"),
    ("Wheel", "Zoom"),
];

/// What the user chose in the menus this frame.
#[derive(Message, Debug, Clone, PartialEq)]
pub enum MenuAction {
    /// Edit → Undo.
    Undo,
    /// Edit → Redo.
    Redo,
    /// Edit → Duplicate.
    Duplicate,
    /// Edit → Delete.
    Delete,
    /// Edit → Copy.
    Copy,
    /// Edit → Paste.
    Paste,
    /// Edit → Group.
    Group,
    /// Add → a light.
    AddLight(LightKind),
    /// Edit → Select none.
    SelectNone,
    /// Add → a shape.
    Add(Primitive),
    /// View → a framing or a view direction.
    View(ViewChange),
    /// View → Reset layout.
    ResetLayout,
    /// View → Look through → a scene camera.
    LookThrough(Entity),
    /// An entry of the File menu.
    File(FileAction),
}

/// What decides which menu entries are enabled.
pub struct MenuState<'a> {
    /// The history, for Undo and Redo.
    pub history: &'a EditHistory,
    /// Whether anything is selected.
    pub has_selection: bool,
    /// Whether the clipboard holds objects.
    pub can_paste: bool,
    /// Projects opened or saved lately.
    pub recent: &'a [std::path::PathBuf],
    /// The open project (Relink… is offered when it misses sources).
    pub project: &'a treelight_document::project::format::ProjectState,
    /// The scene's cameras and their names, for View → Look through.
    pub cameras: Vec<(Entity, String)>,
}

/// Draws the menu bar; returns what was chosen.
pub fn menu_bar(
    ui: &mut egui::Ui,
    state: &MenuState,
    render: &mut ViewportRender,
    gizmo: &mut GizmoSettings,
) -> Option<MenuAction> {
    let mut action = None;
    egui::MenuBar::new().ui(ui, |ui| {
        let file = ui.menu_button("File", |ui| file_menu(ui, state)).inner;
        let edit = ui.menu_button("Edit", |ui| edit_menu(ui, state)).inner;
        let add = ui.menu_button("Add", add_menu).inner;
        let view = ui
            .menu_button("View", |ui| view_menu(ui, state, render, gizmo))
            .inner;
        ui.menu_button("Help", help_menu);
        action = [file, edit, add, view]
            .into_iter()
            .flatten()
            .flatten()
            .next();
    });
    action
}

/// The File menu.
fn file_menu(ui: &mut egui::Ui, state: &MenuState) -> Option<MenuAction> {
    let mut action = None;
    let recent = state.recent;
    let project = state.project;
    for (what, label, keys) in [
        (FileAction::New, "New", Action::New.keys()),
        (FileAction::Open, "Open…", Action::Open.keys()),
    ] {
        if ui
            .add(egui::Button::new(label).shortcut_text(keys))
            .clicked()
        {
            action = Some(MenuAction::File(what));
        }
    }
    ui.add_enabled_ui(!recent.is_empty(), |ui| {
        ui.menu_button("Open Recent", |ui| {
            for p in recent {
                let name = p
                    .file_name()
                    .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into());
                let exists = p.is_file();
                let button = ui
                    .add_enabled(exists, egui::Button::new(name))
                    .on_hover_text(p.display().to_string())
                    .on_disabled_hover_text(format!("{} is gone", p.display()));
                if button.clicked() {
                    action = Some(MenuAction::File(FileAction::OpenRecent(p.clone())));
                }
            }
        });
    });
    // Looked up only while the menu is open: it asks the file system.
    let can_relink = !treelight_document::project::restore::missing_sources(project).is_empty();
    ui.add_enabled_ui(can_relink, |ui| {
        if ui
            .button("Relink…")
            .on_hover_text("Point the project's missing source files at files that exist")
            .clicked()
        {
            action = Some(MenuAction::File(FileAction::Relink));
        }
    });
    for (what, label, keys) in [
        (FileAction::Import, "Import…", String::new()),
        (FileAction::Save, "Save", Action::Save.keys()),
        (FileAction::SaveAs, "Save As…", Action::SaveAs.keys()),
        (
            FileAction::RenderImage,
            "Render image…",
            Action::RenderImage.keys(),
        ),
        (FileAction::Quit, "Quit", Action::Quit.keys()),
    ] {
        if matches!(
            what,
            FileAction::Import | FileAction::RenderImage | FileAction::Quit
        ) {
            ui.separator();
        }
        if ui
            .add(egui::Button::new(label).shortcut_text(keys))
            .clicked()
        {
            action = Some(MenuAction::File(what));
        }
    }
    action
}

/// The Edit menu.
fn edit_menu(ui: &mut egui::Ui, state: &MenuState) -> Option<MenuAction> {
    let mut action = None;
    let MenuState {
        history,
        has_selection,
        can_paste,
        ..
    } = *state;
    let undo = history.undo_label();
    let label = undo.as_ref().map_or("Undo".into(), |l| format!("Undo {l}"));
    let button = egui::Button::new(label).shortcut_text(Action::Undo.keys());
    if ui.add_enabled(undo.is_some(), button).clicked() {
        action = Some(MenuAction::Undo);
    }
    let redo = history.redo_label();
    let label = redo.as_ref().map_or("Redo".into(), |l| format!("Redo {l}"));
    let button = egui::Button::new(label).shortcut_text(Action::Redo.keys());
    if ui.add_enabled(redo.is_some(), button).clicked() {
        action = Some(MenuAction::Redo);
    }
    ui.separator();
    for (what, label, keys, enabled) in [
        (MenuAction::Copy, "Copy", Action::Copy, has_selection),
        (MenuAction::Paste, "Paste", Action::Paste, can_paste),
        (
            MenuAction::Duplicate,
            "Duplicate",
            Action::Duplicate,
            has_selection,
        ),
        (MenuAction::Group, "Group", Action::Group, has_selection),
        (MenuAction::Delete, "Delete", Action::Delete, has_selection),
        (
            MenuAction::SelectNone,
            "Select none",
            Action::Cancel,
            has_selection,
        ),
    ] {
        let button = egui::Button::new(label).shortcut_text(keys.keys());
        if ui.add_enabled(enabled, button).clicked() {
            action = Some(what);
        }
    }
    action
}

/// The Add menu: shapes and lights.
fn add_menu(ui: &mut egui::Ui) -> Option<MenuAction> {
    let mut action = None;
    ui.weak("Placed where the view's centre meets the scene");
    for shape in Primitive::ALL {
        if ui.button(shape.label()).clicked() {
            action = Some(MenuAction::Add(shape));
        }
    }
    ui.separator();
    for kind in LightKind::ALL {
        if ui.button(kind.label()).clicked() {
            action = Some(MenuAction::AddLight(kind));
        }
    }
    action
}

/// The View menu: the render mode, the gizmo's mode and axes, framing and the layout.
fn view_menu(
    ui: &mut egui::Ui,
    state: &MenuState,
    render: &mut ViewportRender,
    gizmo: &mut GizmoSettings,
) -> Option<MenuAction> {
    let mut action = None;
    let has_selection = state.has_selection;
    ui.label(egui::RichText::new("Viewport").strong());
    for mode in ViewportRender::modes() {
        ui.radio_value(&mut render.traced, mode, ViewportRender::label(mode));
    }
    ui.separator();
    ui.label(egui::RichText::new("Gizmo").strong());
    for (mode, key) in [
        (GizmoMode::Translate, Action::MoveMode),
        (GizmoMode::Rotate, Action::RotateMode),
        (GizmoMode::Scale, Action::ScaleMode),
    ] {
        let selected = gizmo.mode == mode;
        if ui
            .add(egui::Button::selectable(selected, mode.label()).shortcut_text(key.keys()))
            .clicked()
        {
            gizmo.mode = mode;
        }
    }
    let mut local = gizmo.space == GizmoSpace::Local;
    if ui.checkbox(&mut local, "Local axes").changed() {
        gizmo.space = if local {
            GizmoSpace::Local
        } else {
            GizmoSpace::World
        };
    }
    ui.separator();
    for change in ViewChange::ALL {
        let button = egui::Button::new(change.label()).shortcut_text(change.action().keys());
        let enabled = has_selection || change != ViewChange::FrameSelection;
        if ui.add_enabled(enabled, button).clicked() {
            action = Some(MenuAction::View(change));
        }
    }
    ui.add_enabled_ui(!state.cameras.is_empty(), |ui| {
        ui.menu_button("Look through", |ui| {
            for (e, name) in &state.cameras {
                if ui.button(name).clicked() {
                    action = Some(MenuAction::LookThrough(*e));
                }
            }
        })
        .response
        .on_hover_text("Put the viewport where one of the scene's cameras is")
        .on_disabled_hover_text("The scene has no cameras (glTF files can bring some)");
    });
    ui.separator();
    if ui
        .button("Reset panel layout")
        .on_hover_text("Put the panels back where they start")
        .clicked()
    {
        action = Some(MenuAction::ResetLayout);
    }
    action
}

/// The Help menu: every key from the key map, then the mouse.
fn help_menu(ui: &mut egui::Ui) {
    ui.label(egui::RichText::new("Keys and mouse").strong());
    egui::Grid::new("shortcuts").num_columns(2).show(ui, |ui| {
        for a in Action::all() {
            ui.monospace(a.keys());
            ui.label(a.describe());
            ui.end_row();
        }
        for (keys, what) in MOUSE {
            ui.monospace(*keys);
            ui.label(*what);
            ui.end_row();
        }
    });
    ui.weak("Keys do nothing while a text field has the keyboard.");
}

/// What the menu bar reads to enable its entries.
#[derive(SystemParam)]
pub struct MenuView<'w, 's> {
    history: Res<'w, EditHistory>,
    selection: Res<'w, Selection>,
    clipboard: Res<'w, EditClipboard>,
    recent: Res<'w, RecentProjects>,
    project: Res<'w, ProjectState>,
    cameras: Query<'w, 's, (Entity, &'static Name), SceneCameras>,
}

/// Filter for the scene's cameras.
type SceneCameras = (
    With<treelight_document::values::camera::SceneCamera>,
    With<treelight_document::values::object::SceneObject>,
);

/// Draws the menu bar into `ui`; what was chosen leaves as a [`MenuAction`].
pub fn menu_bar_tab(
    InMut(ui): InMut<egui::Ui>,
    view: MenuView,
    mut render: ResMut<ViewportRender>,
    mut gizmo: ResMut<GizmoSettings>,
    mut actions: MessageWriter<MenuAction>,
) {
    let state = MenuState {
        history: &view.history,
        has_selection: !view.selection.is_empty(),
        can_paste: !view.clipboard.0.is_empty(),
        recent: &view.recent.0,
        project: &view.project,
        cameras: view
            .cameras
            .iter()
            .map(|(e, n)| (e, n.as_str().to_owned()))
            .collect(),
    };
    let (mut render_copy, mut gizmo_copy) = (*render, *gizmo);
    if let Some(action) = menu_bar(ui, &state, &mut render_copy, &mut gizmo_copy) {
        actions.write(action);
    }
    render.set_if_neq(render_copy);
    gizmo.set_if_neq(gizmo_copy);
}

/// What the Edit, Add and View menus change.
#[derive(SystemParam)]
pub struct MenuTargets<'w, 's> {
    selection: ResMut<'w, Selection>,
    ids: Query<'w, 's, &'static SceneId>,
    requests: ResMut<'w, EditRequests>,
    clipboard: ResMut<'w, EditClipboard>,
    index: Res<'w, SceneIndex>,
    view: ResMut<'w, ViewRequest>,
    dock: ResMut<'w, EditorDock>,
    look: ResMut<'w, crate::editor::core::view::LookThrough>,
    scene: Res<'w, SceneBvh>,
    cameras: Query<'w, 's, (&'static Camera, &'static GlobalTransform), With<OrbitCamera>>,
}

/// Does what the menus asked: edits leave as requests; a shape or light goes where the view's
/// centre meets the scene.
pub fn apply_menu_actions(
    mut actions: MessageReader<MenuAction>,
    mut t: MenuTargets,
    mut files: MessageWriter<FileRequest>,
) {
    for action in actions.read() {
        let selected = t.selection.ids(&t.ids);
        let ray = t
            .cameras
            .single()
            .ok()
            .and_then(|(c, g)| Some((view_ray(c, g, None)?, Vec3::from(g.forward()))));
        match action.clone() {
            MenuAction::File(a) => {
                files.write(FileRequest(a));
            }
            MenuAction::Undo => t.requests.0.push(EditRequest::Undo),
            MenuAction::Redo => t.requests.0.push(EditRequest::Redo),
            MenuAction::Duplicate if !selected.is_empty() => {
                t.requests.apply(EditCommand::Duplicate {
                    ids: selected,
                    copies: Vec::new(),
                })
            }
            MenuAction::Delete if !selected.is_empty() => {
                t.requests.apply(EditCommand::Delete { ids: selected })
            }
            MenuAction::SelectNone => t.selection.clear(),
            MenuAction::Copy => t.clipboard.0 = selected,
            MenuAction::Paste => {
                if let Some(r) = t.clipboard.paste(&t.index) {
                    t.requests.0.push(r);
                }
            }
            MenuAction::Group if !selected.is_empty() => t.requests.apply(EditCommand::Group {
                ids: selected,
                name: "Group".into(),
                group: None,
            }),
            MenuAction::AddLight(kind) => {
                if let Some((ray, forward)) = ray {
                    t.requests.apply(light_at(&t.scene, ray, forward, kind));
                }
            }
            MenuAction::Add(shape) => {
                if let Some((ray, _)) = ray {
                    t.requests.apply(shape_at(&t.scene, ray, shape));
                }
            }
            MenuAction::View(change) => t.view.0 = Some(change),
            MenuAction::LookThrough(e) => {
                *t.look = crate::editor::core::view::LookThrough::Object(e)
            }
            MenuAction::ResetLayout => *t.dock = EditorDock::default(),
            _ => {}
        }
    }
}
