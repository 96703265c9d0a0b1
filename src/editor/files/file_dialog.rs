//! The editor's own file dialog, drawn in the window: folders to walk, the files a purpose accepts,
//! and a name field for saving. (A desktop portal's dialog is not used yet.)

use bevy_egui::egui;
use std::path::{Path, PathBuf};

/// What the dialog is choosing a file for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DialogPurpose {
    /// A project to open.
    Open,
    /// A scene file to import.
    Import,
    /// Where to save the project.
    SaveAs,
    /// The file a missing source has become.
    Relink,
    /// A folder whose scene files the Assets panel lists.
    AssetFolder,
    /// An HDR panorama to light the scene.
    Environment,
}

impl DialogPurpose {
    pub(crate) fn title(self) -> &'static str {
        match self {
            DialogPurpose::Open => "Open project",
            DialogPurpose::Import => "Import a scene file",
            DialogPurpose::SaveAs => "Save project as",
            DialogPurpose::Relink => "Choose the file for the missing source",
            DialogPurpose::AssetFolder => "Add a folder to the Assets panel",
            DialogPurpose::Environment => "Choose a sky panorama (.hdr, .exr)",
        }
    }

    /// Whether a file with this name is offered.
    pub fn accepts(self, name: &str) -> bool {
        let ext = Path::new(name)
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match self {
            DialogPurpose::Open | DialogPurpose::SaveAs => ext.as_deref() == Some("treelight"),
            DialogPurpose::Import | DialogPurpose::Relink | DialogPurpose::AssetFolder => {
                matches!(ext.as_deref(), Some("gltf" | "glb" | "obj" | "ply"))
            }
            DialogPurpose::Environment => matches!(ext.as_deref(), Some("hdr" | "exr")),
        }
    }
}

/// An open dialog.
#[derive(Debug, Clone)]
pub struct FileDialog {
    /// What it is for.
    pub purpose: DialogPurpose,
    /// The folder shown.
    pub dir: PathBuf,
    /// The file name typed or picked.
    pub name: String,
    entries: Vec<(String, bool)>,
    error: Option<String>,
    /// Whether the name field still has to take the keyboard (it does when the dialog opens).
    focus_name: bool,
}

impl FileDialog {
    /// A dialog for `purpose` showing `dir`, with `name` filled in.
    pub fn new(purpose: DialogPurpose, dir: PathBuf, name: String) -> Self {
        let mut d = Self {
            purpose,
            dir,
            name,
            entries: Vec::new(),
            error: None,
            focus_name: true,
        };
        d.read_dir();
        d
    }

    fn read_dir(&mut self) {
        self.entries.clear();
        self.error = None;
        match std::fs::read_dir(&self.dir) {
            Ok(list) => {
                for e in list.flatten() {
                    let name = e.file_name().to_string_lossy().into_owned();
                    if name.starts_with('.') {
                        continue;
                    }
                    let is_dir = e.file_type().is_ok_and(|t| t.is_dir());
                    if is_dir || self.purpose.accepts(&name) {
                        self.entries.push((name, is_dir));
                    }
                }
                self.entries
                    .sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
            }
            Err(e) => self.error = Some(format!("{}: {e}", self.dir.display())),
        }
    }

    fn chosen(&self) -> Option<PathBuf> {
        let name = self.name.trim();
        if self.purpose == DialogPurpose::AssetFolder {
            // The folder shown, or one typed into it.
            return Some(if name.is_empty() {
                self.dir.clone()
            } else {
                self.dir.join(name)
            });
        }
        if name.is_empty() {
            return None;
        }
        let mut path = self.dir.join(name);
        if self.purpose == DialogPurpose::SaveAs && path.extension().is_none() {
            path.set_extension("treelight");
        }
        Some(path)
    }

    /// Shows the dialog. Returns `Some(Some(path))` when a file was chosen, `Some(None)` when the
    /// dialog was cancelled, `None` while it stays open.
    pub fn show(&mut self, ctx: &egui::Context) -> Option<Option<PathBuf>> {
        let mut out = None;
        let mut go_to: Option<PathBuf> = None;
        egui::Window::new(self.purpose.title())
            .collapsible(false)
            .resizable(true)
            .default_size([520.0, 420.0])
            .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
            .show(ctx, |ui| {
                ui.horizontal(|ui| {
                    if ui.button("⬆ Up").clicked()
                        && let Some(p) = self.dir.parent()
                    {
                        go_to = Some(p.to_owned());
                    }
                    ui.monospace(self.dir.display().to_string());
                });
                if let Some(e) = &self.error {
                    ui.colored_label(egui::Color32::from_rgb(255, 110, 100), e);
                }
                ui.separator();
                egui::ScrollArea::vertical()
                    .max_height(260.0)
                    .auto_shrink([false, false])
                    .show(ui, |ui| {
                        for (name, is_dir) in &self.entries {
                            let label = if *is_dir {
                                format!("🗁 {name}")
                            } else {
                                format!("🗋 {name}")
                            };
                            let r = ui.selectable_label(!is_dir && *name == self.name, label);
                            if r.clicked() {
                                if *is_dir {
                                    go_to = Some(self.dir.join(name));
                                } else if self.purpose != DialogPurpose::AssetFolder {
                                    self.name = name.clone();
                                }
                            }
                            if r.double_clicked()
                                && !is_dir
                                && self.purpose != DialogPurpose::AssetFolder
                            {
                                out = Some(self.chosen());
                            }
                        }
                        if self.entries.is_empty() {
                            ui.weak("No folders or matching files here.");
                        }
                    });
                ui.separator();
                ui.horizontal(|ui| {
                    ui.label("Name");
                    let r = ui.add(egui::TextEdit::singleline(&mut self.name).desired_width(300.0));
                    // Taken once the keys that opened the dialog are up: a chord's letter arriving
                    // late must not be typed into the name.
                    let keys_up = ui.input(|i| i.keys_down.is_empty() && i.modifiers.is_none());
                    if self.focus_name && keys_up {
                        self.focus_name = false;
                        r.request_focus();
                    }
                    if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                        out = Some(self.chosen());
                    }
                });
                ui.horizontal(|ui| {
                    let ok = match self.purpose {
                        DialogPurpose::SaveAs => "Save",
                        DialogPurpose::Open => "Open",
                        DialogPurpose::Import => "Import",
                        DialogPurpose::Relink => "Relink",
                        DialogPurpose::AssetFolder => "Add this folder",
                        DialogPurpose::Environment => "Use",
                    };
                    let ready =
                        !self.name.trim().is_empty() || self.purpose == DialogPurpose::AssetFolder;
                    if ui.add_enabled(ready, egui::Button::new(ok)).clicked() {
                        out = Some(self.chosen());
                    }
                    if ui.button("Cancel").clicked() {
                        out = Some(None);
                    }
                });
            });
        if let Some(dir) = go_to {
            self.dir = dir;
            self.read_dir();
        }
        out
    }
}
