//! The editor's panels: the window's frame and dock ([`dock`], its layout in [`layout`]), the menu
//! bar ([`menus`]), the status bar ([`status_bar`]), the outliner ([`outliner`]), the inspector
//! ([`inspector`]), the history ([`history`]) and notices ([`notices`]); the scene threads' health
//! ([`worker_watch`]).

pub mod dock;
pub mod history;
pub mod inspector;
pub mod layout;
pub mod menus;
pub mod notices;
pub mod outliner;
pub mod status_bar;
pub mod worker_watch;

use bevy::prelude::*;

/// The systems that draw the editor's UI and act on it, in egui's pass.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub struct EditorUi;

/// The panels, the menus, the status bar and the state they keep.
pub struct PanelsPlugin;

impl Plugin for PanelsPlugin {
    fn build(&self, app: &mut App) {
        use crate::editor::files::file_menu::file_dialogs;
        use crate::editor::viewport::actions::apply_viewport_actions;
        app.add_plugins(worker_watch::WorkerWatchPlugin)
            .add_message::<menus::MenuAction>()
            .init_resource::<layout::EditorDock>()
            .init_resource::<outliner::OutlinerState>()
            .init_resource::<outliner::OutlinerCache>()
            .add_systems(
                bevy_egui::EguiPrimaryContextPass,
                (
                    outliner::invalidate_outliner,
                    dock::draw_editor,
                    notices::show_notices,
                    menus::apply_menu_actions,
                    file_dialogs,
                    // Before the viewport's actions are taken: the sky menu's Choose….
                    crate::editor::viewport::look::choose_panorama,
                    apply_viewport_actions,
                )
                    .chain()
                    .in_set(EditorUi),
            );
    }
}
