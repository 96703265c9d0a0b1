//! The editor shell: one folder and plugin per feature, each answering the document core
//! (`treelight_document`) and never reached into by it; where the features' named widgets were laid
//! out ([`widget_rects`]), for the state report.

pub mod assets;
pub mod files;
pub mod input;
pub mod panels;
pub mod viewport;
pub mod widget_rects;

use bevy::prelude::*;

/// Every feature of the editor shell.
pub struct EditorPlugin;

impl Plugin for EditorPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<widget_rects::WidgetRects>()
            .add_plugins((
                input::InputPlugin,
                viewport::ViewportPlugin,
                panels::PanelsPlugin,
                assets::AssetsPlugin,
                files::FilesPlugin,
            ));
    }
}
