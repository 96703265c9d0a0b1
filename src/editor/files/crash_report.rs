//! When the editor itself dies of a panic, its message and backtrace are kept in the cache folder
//! (`crash-PID.txt`) and shown at the next start, beside the recovery offer. Panics that a job
//! contains ([`treelight_document::files::contain`], the scene's background threads) are not crashes and leave no
//! report.

use treelight_document::project::autosave::cache_dir;

use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};
use std::path::{Path, PathBuf};
use treelight_document::project::editor_lock::left_by_gone_editors;

fn report_path(dir: &Path, pid: u32) -> PathBuf {
    dir.join(format!("crash-{pid}.txt"))
}

/// Whether a panic on the current thread is one a job contains (so not a crash of the editor).
fn contained_here() -> bool {
    if treelight_document::files::contain::is_containing() {
        return true;
    }
    // The scene's worker, refinement and pool threads, and the autosave writer, catch their own
    // panics; every task of the async compute pool runs inside `contain`.
    std::thread::current()
        .name()
        .is_some_and(|n| n.starts_with("treelight-") || n.starts_with("Async Compute Task Pool"))
}

/// Installs the hook that writes the report into the cache folder (then runs the default hook,
/// which prints it).
pub fn install_hook() {
    if let Some(dir) = cache_dir() {
        install_hook_in(dir);
    }
}

/// [`install_hook`] writing into `dir`.
pub fn install_hook_in(dir: PathBuf) {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !contained_here() {
            let thread = std::thread::current();
            let text = format!(
                "Treelight {} crashed (process {}, thread '{}'):\n{info}\n\nBacktrace:\n{}\n",
                env!("CARGO_PKG_VERSION"),
                std::process::id(),
                thread.name().unwrap_or("unnamed"),
                std::backtrace::Backtrace::force_capture()
            );
            let _ = std::fs::create_dir_all(&dir);
            // Never through a link planted under the report's name.
            let _ = treelight_document::files::own_file::write_own(
                &report_path(&dir, std::process::id()),
                text.as_bytes(),
            );
        }
        default(info);
    }));
}

/// Reports left by editors that are no longer running, newest first.
pub fn reports_to_show(dir: &Path) -> Vec<PathBuf> {
    let mut found: Vec<(std::time::SystemTime, PathBuf)> =
        left_by_gone_editors(dir, "crash-", ".txt")
            .into_iter()
            // A link or a pipe named as a report is no editor's report: not read.
            .filter_map(|(_, p)| {
                let meta = std::fs::symlink_metadata(&p).ok().filter(|m| m.is_file())?;
                Some((meta.modified().ok()?, p))
            })
            .collect();
    found.sort_by_key(|f| std::cmp::Reverse(f.0));
    found.into_iter().map(|(_, p)| p).collect()
}

/// The crash reports shown at start, until dismissed.
#[derive(Resource, Default)]
pub struct CrashReports {
    /// Each report's file and text.
    pub shown: Vec<(PathBuf, String)>,
}

fn find_reports(mut reports: ResMut<CrashReports>) {
    let Some(dir) = cache_dir() else {
        return;
    };
    reports.shown = reports_to_show(&dir)
        .into_iter()
        .filter_map(|p| {
            // A report is small; a pipe, a device or a huge file there is not read.
            let text = treelight_document::files::own_file::read_own_text(&p, 256 << 10).ok()?;
            Some((p, text))
        })
        .collect();
}

/// Shows the first report: its message, the backtrace to copy, and Dismiss (which deletes it).
fn show_reports(mut contexts: EguiContexts, mut reports: ResMut<CrashReports>) -> Result {
    let Some((path, text)) = reports.shown.first().cloned() else {
        return Ok(());
    };
    let ctx = contexts.ctx_mut()?;
    let mut dismissed = false;
    egui::Window::new("Treelight crashed last time")
        .collapsible(false)
        .default_size([560.0, 320.0])
        .anchor(egui::Align2::CENTER_TOP, [0.0, 40.0])
        .show(ctx, |ui| {
            ui.label(
                "The editor stopped because of a bug. Any recovery copy of your work is offered \
                 separately. The report below is kept in:",
            );
            ui.monospace(path.display().to_string());
            egui::ScrollArea::vertical()
                .max_height(200.0)
                .show(ui, |ui| ui.monospace(&text));
            ui.horizontal(|ui| {
                if ui.button("Copy the report").clicked() {
                    ui.ctx().copy_text(text.clone());
                }
                if ui.button("Dismiss").clicked() {
                    dismissed = true;
                }
            });
        });
    if dismissed {
        let _ = std::fs::remove_file(&path);
        reports.shown.remove(0);
    }
    Ok(())
}

/// The crash reports of earlier runs, shown at start.
pub struct CrashReportPlugin;

impl Plugin for CrashReportPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<CrashReports>()
            .add_systems(Startup, find_reports)
            .add_systems(bevy_egui::EguiPrimaryContextPass, show_reports);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_of_editors_still_running_are_not_shown() {
        let dir = std::env::temp_dir().join(format!("treelight-crash-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(report_path(&dir, 4_100_001), "dead").unwrap();
        std::fs::write(report_path(&dir, 4_100_002), "alive").unwrap();
        let lock = std::fs::File::create(dir.join("editor-4100002.lock")).unwrap();
        lock.lock().unwrap();
        assert_eq!(reports_to_show(&dir), vec![report_path(&dir, 4_100_001)]);
        drop(lock);
        assert_eq!(reports_to_show(&dir).len(), 2);
        std::fs::remove_dir_all(&dir).ok();
    }
}
