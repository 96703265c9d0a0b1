//! Files: the File menu and its dialogs ([`file_menu`], [`file_dialog`], [`native_dialog`]), the
//! recovery offer ([`recovery`]), the question an import too
//! large for the free memory asks ([`import_question`]), the report of a crash ([`crash_report`])
//! and File → Render image… ([`render_image`]).

pub mod crash_report;
pub mod file_dialog;
pub mod file_menu;
pub mod import_question;
pub mod native_dialog;
pub mod recovery;
pub mod render_image;

use crate::editor::core::rest::{Activity, ActivitySources};
use bevy::prelude::*;

/// The File menu, the recovery offer, the large-import question and crash reports.
pub struct FilesPlugin;

impl Plugin for FilesPlugin {
    fn build(&self, app: &mut App) {
        // The editor asks before an import past the free memory (the document alone goes ahead).
        app.insert_resource(treelight_document::import::ask::ImportQuestions {
            ask: true,
            ..default()
        });
        app.add_plugins((
            file_menu::FileMenuPlugin,
            crash_report::CrashReportPlugin,
            crate::render_file::PipelineWatchPlugin,
        ))
        .init_resource::<render_image::RenderImageUi>()
        .add_systems(Update, (open_render_window, render_image::finish_render))
        .add_systems(
            Last,
            (render_activity, pipelines_activity).in_set(ActivitySources),
        )
        .add_systems(
            bevy_egui::EguiPrimaryContextPass,
            (
                recovery::offer_recovery,
                // After the panels, which clear the widget rectangles they record.
                import_question::ask_about_large_imports
                    .after(crate::editor::core::ui_order::EditorUi),
                render_image::render_image_window.after(crate::editor::core::ui_order::EditorUi),
            ),
        );
    }
}

/// A render to file keeps the editor drawing until it is saved.
fn render_activity(render: Res<render_image::RenderImageUi>, mut activity: ResMut<Activity>) {
    if render.job.is_some() {
        activity.busy("render image");
    }
}

/// Render pipelines still compiling (a material's, the raster view's sky light filters, the
/// tonemapper's for an image) keep the editor drawing: what they draw appears once they are in.
fn pipelines_activity(
    ready: Option<Res<crate::render_file::PipelinesReady>>,
    mut activity: ResMut<Activity>,
) {
    if ready.is_some_and(|r| !r.is_ready()) {
        activity.busy("pipelines compiling");
    }
}

/// Opens the render window when File → Render image… (or its key) was chosen.
fn open_render_window(
    mut files: ResMut<file_menu::FileUi>,
    mut render: ResMut<render_image::RenderImageUi>,
    project: Res<treelight_document::project::format::ProjectState>,
) {
    if std::mem::take(&mut files.render_image) {
        render.open(&project);
    }
}

/// A question in a window of its own, centred: `text`, a button `yes` and Cancel, which the
/// keyboard's focus starts on (the answer that loses nothing) and Escape gives. Returns the answer
/// given this frame, and the two buttons by name with where they were laid out.
pub fn ask_yes_or_cancel(
    ctx: &bevy_egui::egui::Context,
    title: &str,
    text: &str,
    yes: &str,
) -> (Option<bool>, Vec<(String, bevy_egui::egui::Rect)>) {
    use bevy_egui::egui;
    let mut answer = None;
    let mut buttons = Vec::new();
    egui::Window::new(title)
        .collapsible(false)
        .resizable(false)
        .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
        .show(ctx, |ui| {
            ui.label(text);
            ui.horizontal(|ui| {
                let go = ui.button(yes);
                buttons.push((yes.to_owned(), go.rect));
                if go.clicked() {
                    answer = Some(true);
                }
                let cancel = ui.button("Cancel");
                buttons.push(("Cancel".to_owned(), cancel.rect));
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
    (answer, buttons)
}
