//! The question an import too large for the free memory asks ([`ImportQuestions`]): import it
//! anyway, or cancel it.

use crate::editor::panels::widget_rects::WidgetRects;
use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};
use treelight_document::import::ask::{ImportQuestions, count_text, size_text};

/// Asks about the oldest held import: Import anyway, or Cancel (Escape).
pub fn ask_about_large_imports(
    mut contexts: EguiContexts,
    mut questions: ResMut<ImportQuestions>,
    mut widgets: ResMut<WidgetRects>,
) -> Result {
    let Some(held) = questions.waiting.first() else {
        return Ok(());
    };
    let ctx = contexts.ctx_mut()?;
    let path = held.path.clone();
    let mut answer = None;
    egui::Window::new("Not enough free memory")
        .collapsible(false)
        .resizable(false)
        .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
        .show(ctx, |ui| {
            ui.label(format!(
                "{} has {} triangles. Once traced they need at least {}, and {} of memory are \
                 free: the editor may slow to a crawl, or the system may stop it. Unsaved work \
                 is autosaved either way.",
                path.display(),
                count_text(held.triangles),
                size_text(held.needed),
                size_text(held.free)
            ));
            ui.horizontal(|ui| {
                let go = ui.button("Import anyway");
                widgets.push("Import anyway", go.rect);
                if go.clicked() {
                    answer = Some(true);
                }
                // The keyboard's default is the answer that risks nothing.
                let cancel = ui.button("Cancel");
                widgets.push("Cancel", cancel.rect);
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
    if let Some(go) = answer {
        questions.answers.push((path, go));
    }
    Ok(())
}
