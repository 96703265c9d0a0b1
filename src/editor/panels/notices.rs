//! Notices stacked in the window's top-right corner; each can be dismissed.

use crate::editor::core::widget_rects::WidgetRects;
use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};
use treelight_document::scene::notice::{Level, Notices};

/// Shows the notices (each a named widget, "Notice 1" at the top, for the report).
pub fn show_notices(
    mut contexts: EguiContexts,
    mut notices: ResMut<Notices>,
    mut widgets: ResMut<WidgetRects>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    let mut dismissed = None;
    for (k, n) in notices.0.iter().enumerate() {
        let (colour, title) = match n.level {
            Level::Info => (egui::Color32::from_rgb(140, 200, 255), "Info"),
            Level::Warning => (egui::Color32::from_rgb(255, 200, 90), "Warning"),
            Level::Error => (egui::Color32::from_rgb(255, 110, 100), "Error"),
        };
        let shown = egui::Area::new(egui::Id::new(("notice", k)))
            .anchor(
                egui::Align2::RIGHT_TOP,
                egui::vec2(-16.0, 40.0 + 64.0 * k as f32),
            )
            .show(ctx, |ui| {
                egui::Frame::popup(ui.style()).show(ui, |ui| {
                    ui.set_max_width(420.0);
                    ui.horizontal(|ui| {
                        ui.colored_label(colour, title);
                        if ui.small_button("✕").clicked() {
                            dismissed = Some(k);
                        }
                    });
                    ui.label(&n.text);
                });
            });
        widgets.push(format!("Notice {}", k + 1), shown.response.rect);
    }
    if let Some(k) = dismissed {
        notices.0.remove(k);
    }
    Ok(())
}
