//! The offer of recovery copies left behind ([`Autosave::offer`]), once the scene they would
//! belong to is known: each listed with whose work it is and when it was written; open one,
//! delete one, or leave them all for a later start. Nothing is deleted unless the user says so.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};
use std::path::PathBuf;
use treelight_document::project::autosave::Autosave;
use treelight_document::project::recovery::RecoveryCopy;
use treelight_document::project::requests::{ProjectRequest, ProjectRequests};

/// How long ago `copy` was written, in words.
fn age(copy: &RecoveryCopy) -> String {
    let secs = copy.modified.elapsed().map_or(0, |d| d.as_secs());
    match secs {
        s if s < 120 => format!("{s} s ago"),
        s if s < 7200 => format!("{} min ago", s / 60),
        s if s < 172_800 => format!("{} h ago", s / 3600),
        s => format!("{} days ago", s / 86_400),
    }
}

/// Whose work `copy` holds, in words.
fn whose(copy: &RecoveryCopy) -> String {
    match &copy.owner {
        Some(p) => format!(
            "unsaved work on {}",
            p.file_name().unwrap_or_default().to_string_lossy()
        ),
        None => "a scene never saved".into(),
    }
}

/// What the user answered.
enum Answer {
    Open(PathBuf),
    Delete(PathBuf),
    Later,
}

/// Offers the recovery copies: Return (or the first Open) opens the newest; Delete removes one;
/// Escape (or Later) leaves them all for the next start.
pub fn offer_recovery(
    mut contexts: EguiContexts,
    auto: Option<ResMut<Autosave>>,
    mut requests: ResMut<ProjectRequests>,
) -> Result {
    // No autosave (a run that ends by itself), or nothing to offer.
    let Some(mut auto) = auto.filter(|a| !a.offer.is_empty()) else {
        return Ok(());
    };
    let ctx = contexts.ctx_mut()?;
    let mut answer = None;
    egui::Window::new("Recover unsaved work?")
        .collapsible(false)
        .resizable(false)
        .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
        .show(ctx, |ui| {
            ui.label("Recovery copies of work that was not saved were left behind:");
            egui::ScrollArea::vertical()
                .max_height(240.0)
                .show(ui, |ui| {
                    for (k, copy) in auto.offer.iter().enumerate() {
                        ui.separator();
                        let old = if copy.is_old() { " (old)" } else { "" };
                        ui.label(format!("{}, written {}{old}", whose(copy), age(copy)));
                        ui.monospace(copy.path.display().to_string());
                        ui.horizontal(|ui| {
                            let open = ui.button("Open");
                            if k == 0 {
                                open.request_focus();
                            }
                            if open.clicked() {
                                answer = Some(Answer::Open(copy.path.clone()));
                            }
                            if ui.button("Delete the copy").clicked() {
                                answer = Some(Answer::Delete(copy.path.clone()));
                            }
                        });
                    }
                });
            ui.separator();
            if ui.button("Later (keep the copies)").clicked() {
                answer = Some(Answer::Later);
            }
        });
    if ctx.input(|i| i.key_pressed(egui::Key::Escape)) {
        answer = Some(Answer::Later);
    } else if answer.is_none() && ctx.input(|i| i.key_pressed(egui::Key::Enter)) {
        answer = auto.offer.first().map(|c| Answer::Open(c.path.clone()));
    }
    match answer {
        Some(Answer::Open(path)) => {
            // The rest stay on disk for a later start.
            auto.answered(&path);
            auto.keep_for_later();
            requests.0.push(ProjectRequest::OpenRecovery(path));
        }
        Some(Answer::Delete(path)) => {
            let _ = std::fs::remove_file(&path);
            auto.answered(&path);
        }
        Some(Answer::Later) => auto.keep_for_later(),
        None => {}
    }
    Ok(())
}
