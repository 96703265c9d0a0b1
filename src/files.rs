//! The File menu's work: new, open, import, save and save as, through the editor's own file dialog;
//! the window title (the project's name, `*` while unsaved); closing the window, New or Open with
//! unsaved changes asks first (save, discard or cancel); `--save PATH` for scripts.

use crate::edit::EditHistory;
use crate::import::PendingImports;
use crate::key_chords::KeyChords;
use crate::keymap::Action;
use crate::notice::Notices;
use crate::project::{ProjectState, save_project};
use crate::project_open::{OpenKind, OpeningProjects};
use crate::ui::file_dialog::{DialogPurpose, FileDialog};
use crate::ui::native_dialog::{NativeDialog, native_dialogs};
use bevy::prelude::*;
use bevy::window::{PrimaryWindow, WindowCloseRequested};
use bevy_egui::{EguiContexts, egui};
use std::path::PathBuf;

/// What the user (or the command line) asked of the project this frame.
#[derive(Clone, Debug, PartialEq)]
pub enum ProjectRequest {
    /// An empty scene.
    New,
    /// Open a project.
    Open(PathBuf),
    /// Save the project here.
    Save(PathBuf),
    /// Import a scene file into the scene.
    Import(PathBuf),
    /// Close the editor.
    Quit,
    /// Open a recovery copy: the scene it holds, unsaved, belonging to the project it was made for.
    OpenRecovery(PathBuf),
    /// Add a folder to the Assets panel.
    AddAssetFolder(PathBuf),
    /// Point a missing source at another file.
    Relink {
        /// The source as the project names it (resolved).
        from: PathBuf,
        /// The file to use instead.
        to: PathBuf,
    },
    /// Tell the user that something failed (a dialog that crashed).
    Report(String),
}

/// The frame's project requests, applied by [`apply_project_requests`].
#[derive(Resource, Default, Debug)]
pub struct ProjectRequests(pub Vec<ProjectRequest>);

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
    /// Whether the Relink window is open.
    pub relink: bool,
    /// The missing source the file dialog is choosing a file for.
    relink_from: Option<PathBuf>,
}

/// The menu's entries, chosen in the menu bar or by their keys.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FileAction {
    /// File → Open Recent → a project.
    OpenRecent(PathBuf),
    /// File → New.
    New,
    /// File → Open….
    Open,
    /// File → Import….
    Import,
    /// File → Save.
    Save,
    /// File → Save As….
    SaveAs,
    /// File → Quit.
    Quit,
    /// File → Relink….
    Relink,
    /// Assets → Add folder….
    AddAssetFolder,
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
            self.native = Some(NativeDialog::open(purpose, dir, name));
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
                requests.0.push(ProjectRequest::AddAssetFolder(dir))
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
            FileAction::Save => match &state.path {
                Some(p) => requests.0.push(ProjectRequest::Save(p.clone())),
                None => self.dialog(DialogPurpose::SaveAs, state),
            },
            FileAction::SaveAs => self.dialog(DialogPurpose::SaveAs, state),
            FileAction::Relink => self.relink = true,
            FileAction::AddAssetFolder => {
                let dir = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
                self.open_dialog(DialogPurpose::AssetFolder, dir, String::new());
            }
        }
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

    /// Draws the dialog and the questions, if open, and turns answers into requests. Returns the
    /// questions' buttons by name, with where they were laid out (for the state report).
    pub fn show(
        &mut self,
        ctx: &egui::Context,
        state: &ProjectState,
        requests: &mut ProjectRequests,
    ) -> Vec<(String, egui::Rect)> {
        let mut buttons = Vec::new();
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
                    match &state.path {
                        Some(p) => requests.0.push(ProjectRequest::Save(p.clone())),
                        None => self.dialog(DialogPurpose::SaveAs, state),
                    }
                }
                Some(1) => {
                    self.confirm = None;
                    self.proceed(after, state, requests);
                }
                Some(_) => self.confirm = None,
                None => {}
            }
        }
        if let Some(path) = self.replace.clone() {
            let name = path
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned());
            let folder = path
                .parent()
                .map_or(String::new(), |d| d.display().to_string());
            let mut answer = None;
            egui::Window::new("Replace the file?")
                .collapsible(false)
                .resizable(false)
                .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
                .show(ctx, |ui| {
                    ui.label(format!(
                        "{name} already exists in {folder}.\nReplacing it overwrites what it holds."
                    ));
                    ui.horizontal(|ui| {
                        let replace = ui.button("Replace");
                        buttons.push(("Replace".to_owned(), replace.rect));
                        if replace.clicked() {
                            answer = Some(true);
                        }
                        // The keyboard's default is the answer that loses nothing.
                        let cancel = ui.button("Cancel");
                        buttons.push(("Cancel".to_owned(), cancel.rect));
                        if !ctx.memory(|m| m.focused().is_some()) {
                            cancel.request_focus();
                        }
                        if cancel.clicked() {
                            answer = Some(false);
                        }
                    });
                });
            if ctx.input(|i| i.key_pressed(egui::Key::Escape)) {
                answer = Some(false);
            }
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
        if self.relink {
            let missing = crate::project::missing_sources(state);
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

/// The projects opened or saved lately, newest first (kept in the settings file).
#[derive(Resource, Debug, Default, Clone, PartialEq)]
pub struct RecentProjects(pub Vec<PathBuf>);

impl RecentProjects {
    /// How many are kept.
    pub const MAX: usize = 10;

    /// Puts `path` first.
    pub fn add(&mut self, path: &std::path::Path) {
        let path = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
        self.0.retain(|p| *p != path);
        self.0.insert(0, path);
        self.0.truncate(Self::MAX);
    }
}

/// Applies the frame's project requests.
pub fn apply_project_requests(world: &mut World) {
    let requests = std::mem::take(&mut world.resource_mut::<ProjectRequests>().0);
    for request in requests {
        match request {
            ProjectRequest::New => new_scene(world),
            ProjectRequest::Open(path) => world
                .resource_mut::<OpeningProjects>()
                .start(path, OpenKind::Project),
            ProjectRequest::Save(path) => match save_project(world, &path) {
                Ok(unsaved) => {
                    world.resource_mut::<RecentProjects>().add(&path);
                    let mut notices = world.resource_mut::<Notices>();
                    notices.info(format!("saved {}", path.display()));
                    if !unsaved.is_empty() {
                        notices.warn(format!(
                            "{}: not saved, their geometry has no source file: {}",
                            path.display(),
                            unsaved.join(", ")
                        ));
                    }
                    let then = world.resource_mut::<FileUi>().then.take();
                    if let Some(after) = then {
                        world.resource_scope(|world, mut ui: Mut<FileUi>| {
                            let state = world.resource::<ProjectState>();
                            let mut more = ProjectRequests::default();
                            ui.proceed(after, state, &mut more);
                            world.resource_mut::<ProjectRequests>().0.extend(more.0);
                        });
                    }
                }
                Err(e) => {
                    world.resource_mut::<FileUi>().then = None;
                    world.resource_mut::<Notices>().error(e.to_string());
                }
            },
            ProjectRequest::Import(path) => world.resource_mut::<PendingImports>().start(path),
            ProjectRequest::OpenRecovery(path) => {
                let owner = world.resource::<ProjectState>().path.clone();
                world
                    .resource_mut::<OpeningProjects>()
                    .start(path, OpenKind::Recovery { owner });
            }
            ProjectRequest::Report(e) => world.resource_mut::<Notices>().error(e),
            ProjectRequest::Quit => {
                // Quitting with unsaved changes means the user chose to discard them: their
                // recovery copy goes too, or the next start would offer them back.
                if let Some(mut auto) = world.get_resource_mut::<crate::autosave::Autosave>() {
                    auto.remove_copy();
                }
                world.write_message(AppExit::Success);
            }
            ProjectRequest::AddAssetFolder(dir) => {
                if dir.is_dir() {
                    if let Some(mut library) =
                        world.get_resource_mut::<crate::asset_library::AssetLibrary>()
                    {
                        library.add_folder(dir, false);
                    }
                } else {
                    world
                        .resource_mut::<Notices>()
                        .error(format!("{}: not a folder", dir.display()));
                }
            }
            ProjectRequest::Relink { from, to } => {
                match crate::project::relink_source(world, &from, &to) {
                    Ok(report) => {
                        let mut notices = world.resource_mut::<Notices>();
                        notices.info(format!(
                            "{} now stands for {}",
                            to.display(),
                            from.display()
                        ));
                        if report.missing_nodes > 0 {
                            notices.warn(format!(
                                "{}: {} objects name nodes it does not have; they stay in the project",
                                to.display(),
                                report.missing_nodes
                            ));
                        }
                    }
                    Err(e) => world.resource_mut::<Notices>().error(e.to_string()),
                }
            }
        }
    }
}

/// An empty scene with a fresh history, not saved anywhere.
fn new_scene(world: &mut World) {
    let mut q = world.query_filtered::<Entity, With<crate::selection::SceneObject>>();
    for e in q.iter(world).collect::<Vec<_>>() {
        if let Ok(entity) = world.get_entity_mut(e) {
            entity.despawn();
        }
    }
    *world.resource_mut::<EditHistory>() = EditHistory::default();
    world.resource_mut::<crate::selection::Selection>().clear();
    world
        .resource_mut::<crate::import::SourceCatalog>()
        .0
        .clear();
    world.insert_resource(ProjectState::default());
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
    if chords.current.is_none() || !crate::edit::shortcuts::keyboard_is_free(&mut contexts) {
        return;
    }
    let action = [
        (Action::Save, FileAction::Save),
        (Action::SaveAs, FileAction::SaveAs),
        (Action::Open, FileAction::Open),
        (Action::New, FileAction::New),
        (Action::Quit, FileAction::Quit),
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

/// `--save PATH`: saves the project once the scene has settled and the scripted commands are in,
/// then exits (unless `--frames` asks for more frames).
#[derive(Resource, Debug)]
pub struct SaveWhenSettled {
    /// Where.
    pub path: PathBuf,
    settled: u32,
}

impl SaveWhenSettled {
    /// A save to `path`.
    pub fn new(path: PathBuf) -> Self {
        Self { path, settled: 0 }
    }
}

/// Saves for `--save` once nothing is loading and no script waits.
pub fn save_when_settled(world: &mut World) {
    let loading = !world.resource::<PendingImports>().0.is_empty()
        || !world
            .resource::<crate::import::ParsedImports>()
            .0
            .is_empty()
        || world.resource::<OpeningProjects>().busy()
        || world
            .get_resource::<crate::script::ScriptedEdits>()
            .is_some_and(|s| s.commands.is_some());
    let Some(mut save) = world.get_resource_mut::<SaveWhenSettled>() else {
        return;
    };
    save.settled = if loading { 0 } else { save.settled + 1 };
    if save.settled < 3 {
        return;
    }
    let path = save.path.clone();
    world.remove_resource::<SaveWhenSettled>();
    // A scene whose script could not run is not what was asked to be saved.
    let not_applied = world
        .get_resource::<crate::script::ScriptedEdits>()
        .and_then(|s| s.failed.clone());
    if let Some(why) = not_applied {
        error!("{}: not saved: {why}", path.display());
        world.write_message(AppExit::error());
        return;
    }
    let code = match save_project(world, &path) {
        Ok(unsaved) => {
            info!("saved {}", path.display());
            if !unsaved.is_empty() {
                warn!("{}: not saved: {}", path.display(), unsaved.join(", "));
            }
            AppExit::Success
        }
        Err(e) => {
            error!("{e}");
            AppExit::error()
        }
    };
    // Without `--frames`, the job is done.
    if !world.contains_resource::<crate::capture::CaptureRequest>() {
        world.write_message(code);
    }
}

/// The File menu's requests, dialogs, keys, title and close prompt.
pub struct FilesPlugin;

impl Plugin for FilesPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ProjectRequests>()
            .init_resource::<FileUi>()
            .init_resource::<RecentProjects>()
            .init_resource::<OpeningProjects>()
            .add_systems(
                Update,
                (
                    (
                        file_shortcuts,
                        close_requested,
                        apply_project_requests,
                        crate::project_open::finish_opening,
                    )
                        .chain(),
                    window_title,
                    save_when_settled.after(crate::edit::apply_edit_requests),
                ),
            );
    }
}
