//! The menu bar (Edit, Add, View, Help) and the status bar.

use crate::edit::{EditHistory, LightKind, Primitive};
use crate::gizmo::{GizmoMode, GizmoSettings, GizmoSpace};
use crate::keymap::Action;
use crate::render_mode::ViewportRender;
use bevy_egui::egui;

/// The mouse controls and modified drags the Help menu lists after the keys (which come from
/// [`crate::keymap::KEYMAP`]).
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
#[derive(Debug, Clone, PartialEq)]
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
    /// View → Frame selection.
    FrameSelection,
    /// View → Reset layout.
    ResetLayout,
    /// An entry of the File menu.
    File(crate::files::FileAction),
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
    pub project: &'a crate::project::ProjectState,
}

/// Draws the menu bar; returns what was chosen.
pub fn menu_bar(
    ui: &mut egui::Ui,
    state: &MenuState,
    render: &mut ViewportRender,
    gizmo: &mut GizmoSettings,
) -> Option<MenuAction> {
    let MenuState {
        history,
        has_selection,
        can_paste,
        recent,
        project,
    } = *state;
    let mut action = None;
    egui::MenuBar::new().ui(ui, |ui| {
        ui.menu_button("File", |ui| {
            use crate::files::FileAction;
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
                        let name = p.file_name().map_or_else(
                            || p.display().to_string(),
                            |n| n.to_string_lossy().into(),
                        );
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
            let can_relink = !crate::project::missing_sources(project).is_empty();
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
                (FileAction::Quit, "Quit", Action::Quit.keys()),
            ] {
                if matches!(what, FileAction::Import | FileAction::Quit) {
                    ui.separator();
                }
                if ui
                    .add(egui::Button::new(label).shortcut_text(keys))
                    .clicked()
                {
                    action = Some(MenuAction::File(what));
                }
            }
        });
        ui.menu_button("Edit", |ui| {
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
        });
        ui.menu_button("Add", |ui| {
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
        });
        ui.menu_button("View", |ui| {
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
            let button = egui::Button::new("Frame selection").shortcut_text(Action::Frame.keys());
            if ui.add_enabled(has_selection, button).clicked() {
                action = Some(MenuAction::FrameSelection);
            }
            if ui
                .button("Reset panel layout")
                .on_hover_text("Put the panels back where they start")
                .clicked()
            {
                action = Some(MenuAction::ResetLayout);
            }
        });
        ui.menu_button("Help", |ui| {
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
        });
    });
    action
}
