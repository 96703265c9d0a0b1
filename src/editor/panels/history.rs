//! The History tab: every step of the edit history, the scene as opened first; a click goes back
//! or forward to a step.

use bevy::prelude::*;
use bevy_egui::egui;
use treelight_document::edit::history::{EditHistory, EditRequest, EditRequests};

/// Draws the history tab into `ui`.
pub fn history_tab(
    InMut(ui): InMut<egui::Ui>,
    history: Res<EditHistory>,
    mut requests: ResMut<EditRequests>,
) {
    let labels = history.labels();
    let head = history.head();
    let mut go_to = None;
    egui::ScrollArea::vertical()
        .auto_shrink([false; 2])
        .stick_to_bottom(true)
        .show(ui, |ui| {
            // Row 0 is the scene as opened; row i the scene after step i.
            if ui.selectable_label(head == 0, "Opened").clicked() && head != 0 {
                go_to = Some(0);
            }
            for (i, label) in labels.iter().enumerate() {
                let text = egui::RichText::new(label);
                let text = if i < head { text } else { text.weak() };
                if ui.selectable_label(head == i + 1, text).clicked() && head != i + 1 {
                    go_to = Some(i + 1);
                }
            }
        });
    if let Some(i) = go_to {
        requests.0.push(EditRequest::GoTo(i));
    }
}
