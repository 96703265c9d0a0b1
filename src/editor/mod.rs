//! The editor shell, in three layers. [`core`] holds what the features share (the selection, the
//! view, the key map, the settings of the gizmo and the viewport, the requests one feature makes of
//! another, where widgets were laid out); each feature folder ([`input`], [`viewport`], [`panels`],
//! [`assets`], [`files`]) owns and registers its systems and imports `core`, never another feature;
//! the [`workspace`] above them lays their tabs out in the window and remembers their settings. All
//! of it answers the document core (`treelight_document`) and is never reached into by it.

pub mod assets;
pub mod core;
pub mod files;
pub mod input;
pub mod panels;
pub mod viewport;
pub mod workspace;

use bevy::prelude::*;

/// Every feature of the editor shell.
pub struct EditorPlugin;

impl Plugin for EditorPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins((
            core::CorePlugin,
            input::InputPlugin,
            viewport::ViewportPlugin,
            panels::PanelsPlugin,
            assets::AssetsPlugin,
            files::FilesPlugin,
            workspace::WorkspacePlugin,
        ));
    }
}
