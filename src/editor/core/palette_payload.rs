//! What a drag from the Assets panel carries to the viewport, and the label beside the pointer
//! that the Assets panel and the outliner draw while dragging.

use bevy::math::Vec3;
use bevy_egui::egui;
use std::path::PathBuf;
use std::sync::Arc;
use treelight_document::import::parse::{ContentHashes, ParsedScene};
use treelight_document::values::primitive::Primitive;
use treelight_import::ImportedScene;

/// What a palette drag of a shape carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PaletteItem(pub Primitive);

/// What a palette drag of a scene file carries: the file, and what the Assets panel read of it for
/// its thumbnail (none for a file not read yet or too large to hold, imported where it is dropped
/// without a ghost).
#[derive(Clone, Debug)]
pub struct PaletteFile {
    /// The scene file.
    pub path: PathBuf,
    /// The file as read, when it was.
    pub read: Option<FileReadAhead>,
}

/// A scene file as the Assets panel read it: what placing it needs, so that neither a drag's ghost
/// nor a drop reads or hashes it again on the main thread.
#[derive(Clone, Debug)]
pub struct FileReadAhead {
    /// The file's scene.
    pub scene: Arc<ImportedScene>,
    /// The content of its meshes and textures, so that placing it again finds them in the scene.
    pub hashes: ContentHashes,
    /// The file's bounds, for placing it.
    pub bounds: (Vec3, Vec3),
}

impl FileReadAhead {
    /// The file, ready to be imported (its meshes and images made only where the scene lacks them).
    pub fn parsed(&self) -> ParsedScene {
        ParsedScene::read_ahead(self.scene.clone(), self.hashes.clone(), self.bounds)
    }
}

/// What is being dragged, in a label beside the pointer at `at`, above every panel (the Assets
/// panel's tiles and the outliner's rows).
pub fn paint_drag_label(ctx: &egui::Context, at: egui::Pos2, text: &str) {
    ctx.layer_painter(egui::LayerId::new(
        egui::Order::Tooltip,
        egui::Id::new("drag-label"),
    ))
    .text(
        at + egui::vec2(14.0, 4.0),
        egui::Align2::LEFT_TOP,
        text,
        egui::FontId::proportional(13.0),
        egui::Color32::WHITE,
    );
}
