//! Files: the File menu and its dialogs ([`file_menu`], [`file_dialog`], [`native_dialog`]), the
//! settings file ([`settings`]), the recovery offer ([`recovery`]) and the report of a crash
//! ([`crash_report`]).

pub mod crash_report;
pub mod file_dialog;
pub mod file_menu;
pub mod native_dialog;
pub mod recovery;
pub mod settings;

use bevy::prelude::*;

/// The File menu, settings, the recovery offer and crash reports.
pub struct FilesPlugin;

impl Plugin for FilesPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins((
            file_menu::FileMenuPlugin,
            settings::SettingsPlugin,
            crash_report::CrashReportPlugin,
        ))
        .add_systems(bevy_egui::EguiPrimaryContextPass, recovery::offer_recovery);
    }
}
