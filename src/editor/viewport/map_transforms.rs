//! The document's per-map UV transforms (materials whose maps each have their own
//! `KHR_texture_transform`) handed to the path tracer, which reads each map through its own.

use bevy::prelude::*;
use treelight_document::values::map_transforms::MaterialMapTransforms;
use treelight_render::MapUvTransforms;

/// Copies the document's transforms into the path tracer's when they changed (every traced view of
/// the app: the viewport's, a render's).
pub fn map_transforms_to_tracer(
    document: Res<MaterialMapTransforms>,
    mut tracer: ResMut<MapUvTransforms>,
) {
    if document.is_changed() {
        tracer.set_if_neq(MapUvTransforms(document.0.clone()));
    }
}
