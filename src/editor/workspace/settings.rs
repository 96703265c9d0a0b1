//! The editor's settings between runs: the panel layout and the gizmo's snapping steps, in
//! `settings.ron` in the user's config directory ([`treelight_document::files::folders::config_dir`]). A missing file gives the defaults; a
//! broken one gives them too, with a notice naming the file and the problem. Saved when changed,
//! through a temporary file and a rename.

use crate::editor::assets::library::AssetLibrary;
use crate::editor::core::file_requests::RecentProjects;
use crate::editor::core::gizmo_settings::GizmoSettings;
use crate::editor::core::layout::EditorDock;
use crate::editor::core::layout::EditorTab;
use crate::editor::core::layout::rebuild_layout;
use bevy::prelude::*;
use egui_dock::DockState;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use treelight_document::scene::notice::Notices;

/// The version this editor writes and reads.
const VERSION: u32 = 1;

/// What is kept between runs.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EditorSettings {
    /// The file format's version.
    pub version: u32,
    /// The panels' arrangement.
    pub layout: DockState<EditorTab>,
    /// Grid step for moves while snapping.
    pub grid_step: f32,
    /// Angle step for rotations while snapping, degrees.
    pub angle_step_deg: f32,
    /// Factor step for scaling while snapping.
    pub scale_step: f32,
    /// Projects opened or saved lately, newest first.
    #[serde(default)]
    pub recent: Vec<PathBuf>,
    /// Folders the Assets panel lists, in the order they were added.
    #[serde(default)]
    pub asset_folders: Vec<PathBuf>,
}

/// Where the settings file is, if a config directory can be found.
pub fn settings_path() -> Option<PathBuf> {
    treelight_document::files::folders::config_dir().map(|d| d.join("settings.ron"))
}

/// The most a settings file may take: a layout, a few steps and lists of paths.
const MAX_SETTINGS_BYTES: u64 = 1 << 20;

/// The most folders the Assets panel keeps from the file.
const MAX_ASSET_FOLDERS: usize = 64;

/// Reads the settings at `path`: `Ok(None)` when there is no file, an error naming the problem
/// when it cannot be used (read through the editor's bounded opener, so a pipe, a device or a
/// huge file is refused at once). The layout is made again through egui_dock's own operations
/// ([`rebuild_layout`]), so no file can break the dock.
pub fn read_settings(path: &Path) -> Result<Option<EditorSettings>, String> {
    let text =
        match treelight_document::files::own_file::read_text_bounded(path, MAX_SETTINGS_BYTES) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e.to_string()),
        };
    let mut settings: EditorSettings = ron::from_str(&text).map_err(|e| e.to_string())?;
    if settings.version != VERSION {
        return Err(format!(
            "version {} is not one this editor reads ({VERSION})",
            settings.version
        ));
    }
    settings.layout = rebuild_layout(&settings.layout)?;
    let steps = [
        settings.grid_step,
        settings.angle_step_deg,
        settings.scale_step,
    ];
    if !steps
        .iter()
        .all(|s| s.is_finite() && *s > 0.0 && *s < 1.0e6)
    {
        return Err("a snapping step is not a positive number".into());
    }
    settings.recent.truncate(RecentProjects::MAX);
    settings.asset_folders.truncate(MAX_ASSET_FOLDERS);
    Ok(Some(settings))
}

/// Writes `settings` to `path` atomically ([`treelight_document::files::atomic_file`]).
pub fn write_settings(path: &Path, settings: &EditorSettings) -> std::io::Result<()> {
    let text = ron::ser::to_string_pretty(settings, ron::ser::PrettyConfig::default())
        .map_err(std::io::Error::other)?;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    // The editor's own file: never written through a link planted in its place.
    treelight_document::files::own_file::write_own(path, text.as_bytes())
}

/// Writes the settings a new editor starts with (the default layout and steps) to `path`.
pub fn write_default_settings(path: &Path) -> std::io::Result<()> {
    let settings = current(
        &EditorDock::default(),
        &GizmoSettings::default(),
        &RecentProjects::default(),
        None,
    );
    write_settings(path, &settings)
}

/// The settings as last read or written, to save only changes.
#[derive(Resource, Default)]
pub struct SavedSettings {
    path: Option<PathBuf>,
    text: String,
    frames: u32,
}

fn current(
    dock: &EditorDock,
    gizmo: &GizmoSettings,
    recent: &RecentProjects,
    library: Option<&AssetLibrary>,
) -> EditorSettings {
    EditorSettings {
        version: VERSION,
        layout: dock.0.clone(),
        grid_step: gizmo.grid_step,
        angle_step_deg: gizmo.angle_step_deg,
        scale_step: gizmo.scale_step,
        recent: recent.0.clone(),
        asset_folders: library.map_or_else(Vec::new, AssetLibrary::user_folders),
    }
}

/// Applies the saved settings at start.
pub fn load_settings(
    mut saved: ResMut<SavedSettings>,
    mut dock: ResMut<EditorDock>,
    mut gizmo: ResMut<GizmoSettings>,
    mut recent: ResMut<RecentProjects>,
    mut notices: ResMut<Notices>,
    mut library: Option<ResMut<AssetLibrary>>,
) {
    let Some(path) = settings_path() else {
        return;
    };
    match read_settings(&path) {
        Ok(Some(s)) => {
            dock.0 = s.layout;
            gizmo.grid_step = s.grid_step;
            gizmo.angle_step_deg = s.angle_step_deg;
            gizmo.scale_step = s.scale_step;
            recent.0 = s.recent;
            recent.0.truncate(RecentProjects::MAX);
            if let Some(library) = library.as_mut() {
                // A folder gone since is listed with the reason, not dropped.
                for folder in s.asset_folders {
                    library.add_folder(folder, false);
                }
            }
        }
        Ok(None) => {}
        Err(e) => {
            // Set aside, so the next start does not meet it again and the user can look at it.
            let aside = match treelight_document::files::own_file::set_aside(&path) {
                Ok(to) => format!("; it was moved to {}", to.display()),
                Err(why) => format!("; it could not be moved aside ({why})"),
            };
            notices.warn(format!(
                "{}: {e}; the default settings are used{aside}",
                path.display()
            ));
        }
    }
    saved.text =
        ron::to_string(&current(&dock, &gizmo, &recent, library.as_deref())).unwrap_or_default();
    saved.path = Some(path);
}

/// Saves the settings when they have changed (checked twice a second at most) and when the app
/// exits.
pub fn save_settings(
    mut saved: ResMut<SavedSettings>,
    dock: Res<EditorDock>,
    gizmo: Res<GizmoSettings>,
    recent: Res<RecentProjects>,
    library: Option<Res<AssetLibrary>>,
    exit: MessageReader<AppExit>,
    time: Res<Time>,
) {
    saved.frames += 1;
    let exiting = !exit.is_empty();
    if !exiting && (saved.frames as f32) < 30.0_f32.min(0.5 / time.delta_secs().max(1e-3)) {
        return;
    }
    saved.frames = 0;
    let Some(path) = saved.path.clone() else {
        return;
    };
    let settings = current(&dock, &gizmo, &recent, library.as_deref());
    let Ok(text) = ron::to_string(&settings) else {
        return;
    };
    if text == saved.text {
        return;
    }
    match write_settings(&path, &settings) {
        Ok(()) => saved.text = text,
        Err(e) => {
            // Saving again every half second would only repeat the error.
            warn!("{}: cannot save the settings: {e}", path.display());
            saved.path = None;
        }
    }
}

/// Loads the settings at start and saves them when they change.
pub struct SettingsPlugin;

impl Plugin for SettingsPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<SavedSettings>()
            .add_systems(
                Startup,
                load_settings.after(crate::editor::assets::library::add_samples),
            )
            .add_systems(Last, save_settings);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("treelight-settings-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn settings_round_trip_and_bad_files_are_refused() {
        let d = dir("round-trip");
        let path = d.join("settings.ron");
        assert!(read_settings(&path).unwrap().is_none());
        let mut settings = current(
            &EditorDock::default(),
            &GizmoSettings::default(),
            &RecentProjects(vec![PathBuf::from("/work/house.treelight")]),
            None,
        );
        settings.grid_step = 0.5;
        write_settings(&path, &settings).unwrap();
        let back = read_settings(&path).unwrap().unwrap();
        assert_eq!(back.grid_step, 0.5);
        assert_eq!(back.recent, vec![PathBuf::from("/work/house.treelight")]);
        assert_eq!(back.layout.iter_all_tabs().count(), EditorTab::ALL.len());
        for (text, problem) in [("not ron at all {", ""), ("(version: 7)", "")] {
            std::fs::write(&path, text).unwrap();
            let e = read_settings(&path).unwrap_err();
            assert!(e.contains(problem), "{e}");
        }
        // A layout with a panel twice.
        settings.layout = DockState::new(vec![EditorTab::Viewport, EditorTab::Viewport]);
        write_settings(&path, &settings).unwrap();
        assert!(read_settings(&path).unwrap_err().contains("panel"));
        std::fs::remove_dir_all(&d).ok();
    }
}
