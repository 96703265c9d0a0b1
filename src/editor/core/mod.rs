//! What the editor's features share, beneath all of them: the selection, the view, the key map
//! and its chords, the gizmo's and the viewport's settings, the dock's layout, the requests one
//! feature makes of another (as messages), where widgets were laid out, and the UI's order.
//! Nothing here names a feature.

pub mod clipboard;
pub mod file_requests;
pub mod gizmo_settings;
pub mod key_chords;
pub mod keymap;
pub mod layout;
pub mod object_item;
pub mod palette_payload;
pub mod place;
pub mod resident;
pub mod rest;
pub mod selection;
pub mod ui_order;
pub mod view;
pub mod viewport_render;
pub mod widget_rects;

use bevy::prelude::*;

/// The shared resources and messages, and the UI's steps.
pub struct CorePlugin;

impl Plugin for CorePlugin {
    fn build(&self, app: &mut App) {
        ui_order::configure_ui_steps(app);
        app.add_plugins(rest::RestPlugin)
            .init_resource::<widget_rects::WidgetRects>()
            .add_message::<file_requests::FileRequest>()
            .add_message::<file_requests::FileChosen>();
    }
}
