//! The editor's panels: the menu bar ([`menus`]), the status bar ([`status_bar`]), the outliner
//! ([`outliner`]), the inspector ([`inspector`]), the history ([`history`]) and notices
//! ([`notices`]); the scene threads' health ([`worker_watch`]). The workspace lays them out.

pub mod history;
pub mod inspector;
pub mod menus;
pub mod notices;
pub mod outliner;
pub mod status_bar;
pub mod worker_watch;

use crate::editor::core::layout::EditorDock;
use crate::editor::core::ui_order::UiStep;
use bevy::prelude::*;

/// The panels, the menus, the status bar and the state they keep.
pub struct PanelsPlugin;

impl Plugin for PanelsPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(worker_watch::WorkerWatchPlugin)
            .add_message::<menus::MenuAction>()
            .init_resource::<EditorDock>()
            .init_resource::<outliner::OutlinerState>()
            .init_resource::<outliner::OutlinerCache>()
            .add_systems(
                bevy_egui::EguiPrimaryContextPass,
                (
                    outliner::invalidate_outliner.in_set(UiStep::Prepare),
                    notices::show_notices.in_set(UiStep::Overlay),
                    menus::apply_menu_actions.in_set(UiStep::Menus),
                ),
            );
    }
}
