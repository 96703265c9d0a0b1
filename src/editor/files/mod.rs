//! Files: the File menu and its dialogs ([`file_menu`], [`file_dialog`], [`native_dialog`]), the
//! settings file ([`settings`]), the recovery offer ([`recovery`]), the question an import too
//! large for the free memory asks ([`import_question`]) and the report of a crash
//! ([`crash_report`]).

pub mod crash_report;
pub mod file_dialog;
pub mod file_menu;
pub mod import_question;
pub mod native_dialog;
pub mod recovery;
pub mod settings;

use bevy::prelude::*;

/// The File menu, settings, the recovery offer, the large-import question and crash reports.
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
            settings::SettingsPlugin,
            crash_report::CrashReportPlugin,
        ))
        .add_systems(
            bevy_egui::EguiPrimaryContextPass,
            (
                recovery::offer_recovery,
                // After the panels, which clear the widget rectangles it records.
                import_question::ask_about_large_imports.after(crate::editor::panels::EditorUi),
            ),
        );
    }
}
