//! The question an import too large for the free memory asks ([`ImportQuestions`]): import it
//! anyway, or cancel it.

use crate::editor::core::widget_rects::WidgetRects;
use bevy::prelude::*;
use bevy_egui::EguiContexts;
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
    let text = format!(
        "{} has {} triangles. Once traced they need at least {}, and {} of memory are free: the \
         editor may slow to a crawl, or the system may stop it. Unsaved work is autosaved either \
         way.",
        path.display(),
        count_text(held.triangles),
        size_text(held.needed),
        size_text(held.free)
    );
    let (answer, buttons) =
        super::ask_yes_or_cancel(ctx, "Not enough free memory", &text, "Import anyway");
    widgets.extend(buttons);
    if let Some(go) = answer {
        questions.answers.push((path, go));
    }
    Ok(())
}
