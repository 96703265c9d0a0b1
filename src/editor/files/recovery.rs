//! The offer at start of a recovery copy left behind ([`Autosave::offer`]): open it, discard it,
//! or leave it for the next start.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};
use treelight_document::project::autosave::Autosave;
use treelight_document::project::requests::{ProjectRequest, ProjectRequests};

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
