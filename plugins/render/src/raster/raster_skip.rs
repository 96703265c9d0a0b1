//! A path-traced camera rasterises no meshes: the traced image covers them, and drawing them first
//! would cost as much as a raster view. Their entities leave the camera's visible set after Bevy's
//! visibility check, which leaves their visibility flags, lights' shadow views and other cameras as
//! they were.

use crate::types::view::PathTraced;
use bevy::camera::visibility::{VisibilitySystems, VisibleEntities};
use bevy::prelude::*;
use std::any::TypeId;

pub(crate) fn build(app: &mut App) {
    app.add_systems(
        PostUpdate,
        skip_mesh_raster.after(VisibilitySystems::CheckVisibility),
    );
}

fn skip_mesh_raster(mut cameras: Query<&mut VisibleEntities, With<PathTraced>>) {
    for mut visible in &mut cameras {
        visible.clear(TypeId::of::<Mesh3d>());
    }
}
