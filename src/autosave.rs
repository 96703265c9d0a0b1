//! Autosave and recovery: while there are unsaved changes, a recovery copy of the project is
//! written every interval (30 s; `TREELIGHT_AUTOSAVE_SECS` changes it) on a thread of its own,
//! beside the project (`.NAME.recovery.treelight`) or, for a scene never saved, in the cache
//! directory. At start, a recovery copy newer than the project it belongs to (or, with no project,
//! the newest one left by an unsaved scene) is offered; a save removes it.

use crate::edit::EditHistory;
use crate::files::{ProjectRequest, ProjectRequests};
use crate::project::{ProjectState, capture_project, write_project};
use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// The recovery copy for the project at `project`.
pub fn recovery_beside(project: &Path) -> PathBuf {
    let name = project
        .file_name()
        .map_or("project".into(), |n| n.to_string_lossy().into_owned());
    let stem = name.strip_suffix(".treelight").unwrap_or(&name);
    project.with_file_name(format!(".{stem}.recovery.treelight"))
}

/// Where unsaved scenes' recovery copies go: `$TREELIGHT_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/treelight`, else `~/.cache/treelight`.
pub fn cache_dir() -> Option<PathBuf> {
    let var = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    var("TREELIGHT_CACHE_DIR")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("treelight")))
        .or_else(|| var("HOME").map(|h| h.join(".cache").join("treelight")))
}

/// The recovery copy of an unsaved scene of this editor process.
fn unsaved_recovery() -> Option<PathBuf> {
    cache_dir().map(|d| d.join(format!("unsaved-{}.recovery.treelight", std::process::id())))
}

fn modified(p: &Path) -> Option<SystemTime> {
    std::fs::metadata(p).and_then(|m| m.modified()).ok()
}

/// The recovery copy to offer at start: for `project`, its own copy when newer than it; with no
/// project, the newest unsaved scene's copy in the cache directory.
pub fn recovery_to_offer(project: Option<&Path>) -> Option<PathBuf> {
    match project {
        Some(p) => {
            let r = recovery_beside(p);
            let newer = match (modified(&r), modified(p)) {
                (Some(a), Some(b)) => a > b,
                (Some(_), None) => true,
                _ => false,
            };
            newer.then_some(r)
        }
        None => {
            let dir = cache_dir()?;
            std::fs::read_dir(dir)
                .ok()?
                .flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name().and_then(|n| n.to_str()).is_some_and(|n| {
                        n.starts_with("unsaved-") && n.ends_with(".recovery.treelight")
                    })
                })
                .filter_map(|p| Some((modified(&p)?, p)))
                .max_by_key(|(t, _)| *t)
                .map(|(_, p)| p)
        }
    }
}

/// Autosave's clock and the recovery offer.
#[derive(Resource)]
pub struct Autosave {
    /// Time between recovery copies.
    pub interval: Duration,
    since: Duration,
    /// A recovery copy offered at start, until the user answers.
    pub offer: Option<PathBuf>,
    /// The copy last written, removed when the scene is saved.
    written: Option<PathBuf>,
    writer: Option<std::thread::JoinHandle<()>>,
}

impl Autosave {
    /// Takes `path` as this scene's recovery copy, so a save removes it.
    pub fn adopt(&mut self, path: PathBuf) {
        self.written = Some(path);
    }
}

impl Default for Autosave {
    fn default() -> Self {
        let secs = std::env::var("TREELIGHT_AUTOSAVE_SECS")
            .ok()
            .and_then(|v| v.parse::<f32>().ok())
            .filter(|v| v.is_finite() && *v > 0.0)
            .unwrap_or(30.0);
        Self {
            interval: Duration::from_secs_f32(secs),
            since: Duration::ZERO,
            offer: None,
            written: None,
            writer: None,
        }
    }
}

/// Writes a recovery copy every interval while there are unsaved changes; removes it once saved.
pub fn autosave(world: &mut World) {
    let dt = world.resource::<Time>().delta();
    let dirty = world.resource::<EditHistory>().is_dirty();
    let project = world.resource::<ProjectState>().path.clone();
    let mut auto = world.resource_mut::<Autosave>();
    if !dirty {
        auto.since = Duration::ZERO;
        if let Some(old) = auto.written.take() {
            let _ = std::fs::remove_file(old);
        }
        return;
    }
    auto.since += dt;
    let busy = auto.writer.as_ref().is_some_and(|w| !w.is_finished());
    if auto.since < auto.interval || busy {
        return;
    }
    auto.since = Duration::ZERO;
    let Some(target) = project
        .as_deref()
        .map(recovery_beside)
        .or_else(unsaved_recovery)
    else {
        return;
    };
    // Capturing reads the world (no geometry: quick); the disk write happens off this thread.
    let at = project.clone().unwrap_or_else(|| target.clone());
    let (file, _) = capture_project(world, &at);
    let path = target.clone();
    let writer = std::thread::Builder::new()
        .name("treelight-autosave".into())
        .spawn(move || {
            if let Some(dir) = path.parent() {
                let _ = std::fs::create_dir_all(dir);
            }
            if let Err(e) = write_project(&path, &file) {
                warn!("autosave: {e}");
            }
        })
        .ok();
    let mut auto = world.resource_mut::<Autosave>();
    auto.writer = writer;
    auto.written = Some(target);
}

/// Looks for a recovery copy to offer, once the scene named on the command line is known.
pub fn find_recovery(mut auto: ResMut<Autosave>, state: Res<ProjectState>, mut done: Local<u32>) {
    // A project named on the command line is opened in the first frames.
    *done += 1;
    if *done != 3 {
        return;
    }
    auto.offer = recovery_to_offer(state.path.as_deref());
}

/// Offers the recovery copy: Return (or the button) opens it; Discard deletes it; Escape leaves it
/// for the next start.
pub fn offer_recovery(
    mut contexts: EguiContexts,
    mut auto: ResMut<Autosave>,
    mut requests: ResMut<ProjectRequests>,
) -> Result {
    let Some(path) = auto.offer.clone() else {
        return Ok(());
    };
    let ctx = contexts.ctx_mut()?;
    let mut answer = None;
    egui::Window::new("Recover unsaved work?")
        .collapsible(false)
        .resizable(false)
        .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
        .show(ctx, |ui| {
            ui.label(format!(
                "A recovery copy newer than the saved scene was left behind:\n{}",
                path.display()
            ));
            ui.horizontal(|ui| {
                let open = ui.button("Open the recovery copy");
                open.request_focus();
                if open.clicked() {
                    answer = Some(true);
                }
                if ui.button("Discard the copy").clicked() {
                    let _ = std::fs::remove_file(&path);
                    answer = Some(false);
                }
            });
        });
    if ctx.input(|i| i.key_pressed(egui::Key::Escape)) {
        answer = Some(false);
    } else if ctx.input(|i| i.key_pressed(egui::Key::Enter)) {
        answer = Some(true);
    }
    match answer {
        Some(true) => {
            auto.offer = None;
            requests.0.push(ProjectRequest::OpenRecovery(path));
        }
        Some(false) => auto.offer = None,
        None => {}
    }
    Ok(())
}

/// Recovery copies while editing, and the offer at start.
pub struct AutosavePlugin;

impl Plugin for AutosavePlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<Autosave>()
            .add_systems(Update, (autosave, find_recovery))
            .add_systems(bevy_egui::EguiPrimaryContextPass, offer_recovery);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recovery_copy_is_offered_only_when_newer_than_its_project() {
        let dir = std::env::temp_dir().join(format!("treelight-recovery-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let project = dir.join("house.treelight");
        let recovery = recovery_beside(&project);
        assert_eq!(recovery, dir.join(".house.recovery.treelight"));
        std::fs::write(&recovery, "old").unwrap();
        std::thread::sleep(Duration::from_millis(20));
        std::fs::write(&project, "saved later").unwrap();
        assert_eq!(recovery_to_offer(Some(&project)), None);
        std::thread::sleep(Duration::from_millis(20));
        std::fs::write(&recovery, "newer").unwrap();
        assert_eq!(recovery_to_offer(Some(&project)), Some(recovery));
        std::fs::remove_dir_all(&dir).ok();
    }
}
