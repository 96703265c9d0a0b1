//! The File menu's work: new, open, import, save and save as, through the editor's own file dialog;
//! the window title (the project's name, `*` while unsaved); closing the window, New or Open with
//! unsaved changes asks first (save, discard or cancel). What the user chose leaves as a
//! [`ProjectRequest`] for the document.

use crate::editor::core::file_requests::{FileAction, FileChosen, FileRequest, RecentProjects};
use crate::editor::core::key_chords::KeyChords;
use crate::editor::core::keymap::Action;
use crate::editor::core::rest::Waker;
use crate::editor::core::ui_order::UiStep;
use crate::editor::core::widget_rects::WidgetRects;
use crate::editor::files::file_dialog::DialogPurpose;
use crate::editor::files::file_dialog::FileDialog;
use crate::editor::files::native_dialog::NativeDialog;
use crate::editor::files::native_dialog::native_dialogs;
use bevy::prelude::*;
use bevy::window::{PrimaryWindow, WindowCloseRequested};
use bevy_egui::{EguiContexts, egui};
use std::path::PathBuf;
use treelight_document::edit::history::EditHistory;
use treelight_document::project::format::ProjectState;
use treelight_document::project::requests::{
    ProjectRequest, ProjectRequests, apply_project_requests,
};
use treelight_document::scene::outbox::DocumentEvent;

/// What waits on the user's answer about unsaved changes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AfterSave {
    /// Start an empty scene.
    New,
    /// Choose a project to open.
    Open,
    /// Open this project.
    OpenPath(PathBuf),
    /// Close the editor.
    Quit,
}

/// The File menu's dialogs.
#[derive(Resource, Default)]
pub struct FileUi {
    /// The in-window file dialog, while open.
    pub dialog: Option<FileDialog>,
    /// The desktop's file dialog, while open (where the desktop has one).
    pub native: Option<NativeDialog>,
    /// The question about unsaved changes, while asked.
    pub confirm: Option<AfterSave>,
    /// What to do once the save the user chose has happened.
    pub then: Option<AfterSave>,
    /// A file that Save As chose and that already exists, while the user is asked whether to
    /// replace it.
    pub replace: Option<PathBuf>,
    /// The project's file, changed on disk since this editor read or wrote it (another editor
    /// saved it), while the user is asked whether to save over it.
    pub overwrite_changed: Option<PathBuf>,
    /// Whether the Relink window is open.
    pub relink: bool,
    /// The missing source the file dialog is choosing a file for.
    relink_from: Option<PathBuf>,
    /// Files chosen for other features (a folder for the Assets panel, a panorama for the sky),
    /// until they are handed on as messages.
    chosen: Vec<FileChosen>,
    /// Wakes a resting editor when a desktop dialog answers.
    waker: Waker,
    /// File → Render image… was chosen, until the render window opens.
    pub render_image: bool,
}

impl FileUi {
    fn start_dir(state: &ProjectState) -> PathBuf {
        state
            .path
            .as_ref()
            .and_then(|p| p.parent().map(|d| d.to_owned()))
            .filter(|d| !d.as_os_str().is_empty())
            .or_else(|| std::env::current_dir().ok())
            .unwrap_or_else(|| PathBuf::from("."))
    }

    fn dialog(&mut self, purpose: DialogPurpose, state: &ProjectState) {
        let name = match purpose {
            DialogPurpose::SaveAs => state
                .path
                .as_ref()
                .and_then(|p| p.file_name())
                .map_or("scene.treelight".into(), |n| {
                    n.to_string_lossy().into_owned()
                }),
            _ => String::new(),
        };
        self.open_dialog(purpose, Self::start_dir(state), name);
    }

    /// The desktop's dialog where there is one, else the in-window one; never two at once.
    fn open_dialog(&mut self, purpose: DialogPurpose, dir: PathBuf, name: String) {
        if self.dialog.is_some() || self.native.is_some() {
            return;
        }
        if native_dialogs() {
            self.native = Some(NativeDialog::open(purpose, dir, name, self.waker.clone()));
        } else {
            self.dialog = Some(FileDialog::new(purpose, dir, name));
        }
    }

    /// Acts on a file chosen (or the dialog cancelled) for `purpose`.
    fn chosen(
        &mut self,
        purpose: DialogPurpose,
        choice: Option<PathBuf>,
        requests: &mut ProjectRequests,
    ) {
        match (choice, purpose) {
            (Some(p), DialogPurpose::Open) => requests.0.push(ProjectRequest::Open(p)),
            (Some(p), DialogPurpose::Import) => requests.0.push(ProjectRequest::Import(p)),
            (Some(mut p), DialogPurpose::SaveAs) => {
                // A desktop dialog may return the name as typed.
                if !p
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("treelight"))
                {
                    p.as_mut_os_string().push(".treelight");
                }
                // An existing file (or link, or anything else there) is replaced only when the
                // user says so.
                if std::fs::symlink_metadata(&p).is_ok() {
                    self.replace = Some(p);
                } else {
                    requests.0.push(ProjectRequest::Save(p));
                }
            }
            (Some(to), DialogPurpose::Relink) => {
                if let Some(from) = self.relink_from.take() {
                    requests.0.push(ProjectRequest::Relink { from, to });
                }
            }
            (Some(dir), DialogPurpose::AssetFolder) => {
                self.chosen.push(FileChosen::AssetFolder(dir))
            }
            (Some(file), DialogPurpose::Environment) => {
                self.chosen.push(FileChosen::Panorama(file))
            }
            // A cancelled save also drops what was to follow it.
            (None, _) => self.then = None,
        }
    }

    /// Acts on a menu entry: asks first when changes would be lost.
    pub fn act(
        &mut self,
        action: FileAction,
        state: &ProjectState,
        dirty: bool,
        requests: &mut ProjectRequests,
    ) {
        let ask = |after| if dirty { Some(after) } else { None };
        match action {
            FileAction::New => match ask(AfterSave::New) {
                Some(q) => self.confirm = Some(q),
                None => requests.0.push(ProjectRequest::New),
            },
            FileAction::Open => match ask(AfterSave::Open) {
                Some(q) => self.confirm = Some(q),
                None => self.dialog(DialogPurpose::Open, state),
            },
            FileAction::OpenRecent(p) => match ask(AfterSave::OpenPath(p.clone())) {
                Some(q) => self.confirm = Some(q),
                None => requests.0.push(ProjectRequest::Open(p)),
            },
            FileAction::Quit => match ask(AfterSave::Quit) {
                Some(q) => self.confirm = Some(q),
                None => requests.0.push(ProjectRequest::Quit),
            },
            FileAction::Import => self.dialog(DialogPurpose::Import, state),
            FileAction::Save => self.save(state, requests),
            FileAction::SaveAs => self.dialog(DialogPurpose::SaveAs, state),
            FileAction::Relink => self.relink = true,
            FileAction::RenderImage => self.render_image = true,
            FileAction::AddAssetFolder => {
                let dir = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
                self.open_dialog(DialogPurpose::AssetFolder, dir, String::new());
            }
            FileAction::ChoosePanorama(current) => {
                self.choose_environment(current.as_deref(), state)
            }
        }
    }

    /// Saves to the project's file (asking first if something else wrote it since this editor
    /// read it), or asks where for a scene never saved.
    fn save(&mut self, state: &ProjectState, requests: &mut ProjectRequests) {
        match &state.path {
            Some(p) if state.changed_on_disk() => self.overwrite_changed = Some(p.clone()),
            Some(p) => requests.0.push(ProjectRequest::Save(p.clone())),
            None => self.dialog(DialogPurpose::SaveAs, state),
        }
    }

    /// Opens the dialog that chooses a sky panorama, in the folder of `current` (the one in use)
    /// or the project's.
    fn choose_environment(&mut self, current: Option<&std::path::Path>, state: &ProjectState) {
        let dir = current
            .and_then(|p| p.parent())
            .filter(|d| !d.as_os_str().is_empty())
            .map(|d| d.to_owned())
            .unwrap_or_else(|| Self::start_dir(state));
        self.open_dialog(DialogPurpose::Environment, dir, String::new());
    }

    /// What `after` does once its question is settled.
    fn proceed(&mut self, after: AfterSave, state: &ProjectState, requests: &mut ProjectRequests) {
        match after {
            AfterSave::New => requests.0.push(ProjectRequest::New),
            AfterSave::Open => self.dialog(DialogPurpose::Open, state),
            AfterSave::OpenPath(p) => requests.0.push(ProjectRequest::Open(p)),
            AfterSave::Quit => requests.0.push(ProjectRequest::Quit),
        }
    }

    /// The question before dropping unsaved changes: save them, discard them or cancel.
    fn ask_unsaved(
        &mut self,
        ctx: &egui::Context,
        state: &ProjectState,
        requests: &mut ProjectRequests,
    ) {
        if let Some(after) = self.confirm.clone() {
            let name = state
                .path
                .as_ref()
                .and_then(|p| p.file_name())
                .map_or("the scene".into(), |n| n.to_string_lossy().into_owned());
            let mut answer = None;
            egui::Window::new("Unsaved changes")
                .collapsible(false)
                .resizable(false)
                .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
                .show(ctx, |ui| {
                    ui.label(format!("Save the changes to {name} first?"));
                    ui.horizontal(|ui| {
                        if ui.button("Save").clicked() {
                            answer = Some(0);
                        }
                        if ui.button("Discard").clicked() {
                            answer = Some(1);
                        }
                        if ui.button("Cancel").clicked() {
                            answer = Some(2);
                        }
                    });
                });
            match answer {
                Some(0) => {
                    self.confirm = None;
                    self.then = Some(after);
                    self.save(state, requests);
                }
                Some(1) => {
                    self.confirm = None;
                    // The changes are dropped: so are their recovery copies.
                    requests.0.push(ProjectRequest::DiscardChanges);
                    self.proceed(after, state, requests);
                }
                Some(_) => self.confirm = None,
                None => {}
            }
        }
    }

    /// The window that lists the open project's missing sources, each with a way to choose where
    /// it is now.
    fn relink_window(&mut self, ctx: &egui::Context, state: &ProjectState) {
        if self.relink {
            let missing = treelight_document::project::restore::missing_sources(state);
            let mut open = true;
            egui::Window::new("Relink missing sources")
                .open(&mut open)
                .collapsible(false)
                .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
                .show(ctx, |ui| {
                    if missing.is_empty() {
                        ui.label("Every source of the project is there.");
                    }
                    for p in &missing {
                        ui.horizontal(|ui| {
                            ui.monospace(p.display().to_string());
                            if ui.button("Choose…").clicked() {
                                self.relink_from = Some(p.clone());
                                let dir = p
                                    .parent()
                                    .filter(|d| d.is_dir())
                                    .map(|d| d.to_owned())
                                    .unwrap_or_else(|| Self::start_dir(state));
                                self.open_dialog(DialogPurpose::Relink, dir, String::new());
                            }
                        });
                    }
                });
            if !open {
                self.relink = false;
            }
        }
    }

    /// Draws the dialog and the questions, if open, and turns answers into requests. Returns the
    /// questions' buttons by name, with where they were laid out (for the state report).
    pub fn show(
        &mut self,
        ctx: &egui::Context,
        state: &ProjectState,
        requests: &mut ProjectRequests,
    ) -> Vec<(String, egui::Rect)> {
        let mut buttons = Vec::new();
        self.ask_unsaved(ctx, state, requests);
        if let Some(path) = self.replace.clone() {
            let name = path
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned());
            let folder = path
                .parent()
                .map_or(String::new(), |d| d.display().to_string());
            let (answer, asked) = super::ask_yes_or_cancel(
                ctx,
                "Replace the file?",
                &format!(
                    "{name} already exists in {folder}.\nReplacing it overwrites what it holds."
                ),
                "Replace",
            );
            buttons.extend(asked);
            match answer {
                Some(true) => {
                    self.replace = None;
                    requests.0.push(ProjectRequest::Save(path));
                }
                Some(false) => {
                    // A cancelled save also drops what was to follow it.
                    self.replace = None;
                    self.then = None;
                }
                None => {}
            }
        }
        if let Some(path) = self.overwrite_changed.clone() {
            let name = path
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned());
            let (answer, asked) = super::ask_yes_or_cancel(
                ctx,
                "Save over a newer file?",
                &format!(
                    "{name} changed on disk since it was opened here (another editor may have \
                     saved it).\nSaving replaces those changes with this scene."
                ),
                "Save over it",
            );
            buttons.extend(asked);
            match answer {
                Some(true) => {
                    self.overwrite_changed = None;
                    requests.0.push(ProjectRequest::Save(path));
                }
                Some(false) => {
                    self.overwrite_changed = None;
                    self.then = None;
                }
                None => {}
            }
        }
        self.relink_window(ctx, state);
        if let Some(dialog) = self.dialog.as_mut()
            && let Some(choice) = dialog.show(ctx)
        {
            let purpose = dialog.purpose;
            self.dialog = None;
            self.chosen(purpose, choice, requests);
        }
        if let Some(native) = self.native.as_mut()
            && let Some(answer) = native.poll()
        {
            let purpose = native.purpose;
            self.native = None;
            match answer {
                Ok(choice) => self.chosen(purpose, choice, requests),
                Err(e) => {
                    self.then = None;
                    requests.0.push(ProjectRequest::Report(e));
                }
            }
        }
        buttons
    }
}

/// New, Open, Save, Save As and Quit by their keys (not while a text field has the keyboard).
pub fn file_shortcuts(
    chords: Res<KeyChords>,
    mut contexts: EguiContexts,
    mut ui: ResMut<FileUi>,
    state: Res<ProjectState>,
    history: Res<EditHistory>,
    mut requests: ResMut<ProjectRequests>,
) {
    if chords.current.is_none() || !crate::editor::core::key_chords::keyboard_is_free(&mut contexts)
    {
        return;
    }
    let action = [
        (Action::Save, FileAction::Save),
        (Action::SaveAs, FileAction::SaveAs),
        (Action::Open, FileAction::Open),
        (Action::New, FileAction::New),
        (Action::Quit, FileAction::Quit),
        (Action::RenderImage, FileAction::RenderImage),
    ]
    .into_iter()
    .find(|(key, _)| chords.triggered(*key))
    .map(|(_, action)| action);
    if let Some(a) = action {
        ui.act(a, &state, history.is_dirty(), &mut requests);
    }
}

/// Closing the window asks first when there are unsaved changes.
pub fn close_requested(
    mut closes: MessageReader<WindowCloseRequested>,
    mut ui: ResMut<FileUi>,
    state: Res<ProjectState>,
    history: Res<EditHistory>,
    mut requests: ResMut<ProjectRequests>,
) {
    if closes.read().count() > 0 {
        ui.act(FileAction::Quit, &state, history.is_dirty(), &mut requests);
    }
}

/// Keeps the window title on the project's name, with `*` while there are unsaved changes.
pub fn window_title(
    state: Res<ProjectState>,
    history: Res<EditHistory>,
    mut window: Single<&mut Window, With<PrimaryWindow>>,
) {
    let name = state
        .path
        .as_ref()
        .and_then(|p| p.file_name())
        .map_or("Untitled".into(), |n| n.to_string_lossy().into_owned());
    let star = if history.is_dirty() { " *" } else { "" };
    let title = format!("{name}{star} — Treelight");
    if window.title != title {
        window.title = title;
    }
}

/// Follows the document: a save or an open puts the project first among the recent ones; what
/// waited on a save (New, Open, Quit after "Save") goes on once it succeeded and is dropped if it
/// failed.
pub fn follow_document(
    mut events: MessageReader<DocumentEvent>,
    mut recent: ResMut<RecentProjects>,
    mut ui: ResMut<FileUi>,
    state: Res<ProjectState>,
    mut requests: ResMut<ProjectRequests>,
) {
    for event in events.read() {
        match event {
            DocumentEvent::Opened(path) => recent.add(path),
            DocumentEvent::Saved(path) => {
                recent.add(path);
                if let Some(after) = ui.then.take() {
                    ui.proceed(after, &state, &mut requests);
                }
            }
            DocumentEvent::SaveFailed(_) => ui.then = None,
            _ => {}
        }
    }
}

/// Lets a desktop dialog's answer wake a resting editor.
fn wake_on_answers(mut files: ResMut<FileUi>, waker: Res<Waker>) {
    files.waker = waker.clone();
}

/// Acts on the File actions other features asked for this frame (the menu bar, the Assets
/// panel, the sky controls).
pub fn take_file_requests(
    mut asked: MessageReader<FileRequest>,
    mut files: ResMut<FileUi>,
    state: Res<ProjectState>,
    history: Res<EditHistory>,
    mut requests: ResMut<ProjectRequests>,
) {
    for FileRequest(action) in asked.read() {
        files.act(action.clone(), &state, history.is_dirty(), &mut requests);
    }
}

/// Shows the File menu's dialogs and questions (their buttons go to the state report), and hands
/// on the files chosen for other features.
pub fn file_dialogs(
    mut contexts: EguiContexts,
    mut files: ResMut<FileUi>,
    state: Res<ProjectState>,
    mut requests: ResMut<ProjectRequests>,
    mut widgets: ResMut<WidgetRects>,
    mut chosen: MessageWriter<FileChosen>,
) -> Result {
    let ctx = contexts.ctx_mut()?.clone();
    let buttons = files.show(&ctx, &state, &mut requests);
    widgets.extend(buttons);
    chosen.write_batch(std::mem::take(&mut files.chosen));
    Ok(())
}

/// The File menu's dialogs, keys, title and close prompt.
pub struct FileMenuPlugin;

impl Plugin for FileMenuPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<FileUi>()
            .init_resource::<RecentProjects>()
            .add_systems(Startup, wake_on_answers)
            .add_systems(
                Update,
                (
                    (file_shortcuts, close_requested).before(apply_project_requests),
                    follow_document.after(apply_project_requests),
                    window_title,
                ),
            )
            .add_systems(
                bevy_egui::EguiPrimaryContextPass,
                (take_file_requests, file_dialogs)
                    .chain()
                    .in_set(UiStep::Files),
            );
    }
}
