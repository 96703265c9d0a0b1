//! The workspace: what spans the features and so sits above them. The window's frame and dock
//! ([`dock`]) draws each feature's tab; the settings file ([`settings`]) remembers the layout, the
//! gizmo's settings, the Assets panel's folders and the recent projects between runs.

pub mod dock;
pub mod settings;

use crate::editor::core::ui_order::UiStep;
use bevy::prelude::*;

/// The window's frame and the settings file.
pub struct WorkspacePlugin;

impl Plugin for WorkspacePlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(settings::SettingsPlugin).add_systems(
            bevy_egui::EguiPrimaryContextPass,
            dock::draw_editor.in_set(UiStep::Draw),
        );
    }
}
