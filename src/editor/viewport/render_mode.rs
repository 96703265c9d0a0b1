//! The viewport's render mode: rasterised by Bevy, path traced, or one of the path tracer's debug
//! views. The choice lives in a resource the UI edits; a system puts it on the camera.

use crate::editor::core::view::OrbitCamera;
use crate::editor::core::viewport_render::ViewportRender;
use bevy::prelude::*;
use bevy::render::renderer::RenderAdapterInfo;
use treelight_document::scene::notice::Notices;
use treelight_render::{PathTraced, PathTracerStats};

/// On a software adapter (llvmpipe, WARP) path tracing every viewport pixel takes seconds a frame;
/// tracing a quarter of them keeps the preview interactive.
pub fn adapt_to_adapter(
    adapter: Option<Res<RenderAdapterInfo>>,
    mut render: ResMut<ViewportRender>,
) {
    if !render.scale_chosen && adapter.is_some_and(|a| a.device_type == wgpu_types::DeviceType::Cpu)
    {
        render.settings.resolution_scale = 0.5;
        info!("software adapter: the viewport is path traced at half resolution");
    }
}

/// A scene the adapter cannot hold for the path tracer (a buffer larger than it binds): the
/// viewport shows the raster view, once, and says why; the scene stays whole and editable.
pub fn fall_back_when_too_large(
    stats: Res<PathTracerStats>,
    mut render: ResMut<ViewportRender>,
    mut notices: ResMut<Notices>,
    mut told: Local<bool>,
) {
    if *told {
        return;
    }
    if let Some(why) = stats.trace_off() {
        *told = true;
        render.traced = None;
        notices.error(format!(
            "Path tracing is off: {why}. The viewport shows the raster view; the scene is whole and can be edited and saved."
        ));
    }
}

/// Tells the user, once each time it happens, that the scene's textures are traced smaller than
/// they are because more of them are in use than the path tracer's texture budget holds at full
/// size.
pub fn report_texture_downsizing(
    stats: Res<PathTracerStats>,
    mut notices: ResMut<Notices>,
    mut told: Local<u32>,
) {
    let side = stats.texture_side();
    if side > 0 && side < treelight_render::TEXTURE_LAYER_SIZE && side != *told {
        *told = side;
        notices.warn(format!(
            "The scene uses more textures than the path tracer's {} MiB hold at full size: each is \
             traced at {side} × {side} texels (the raster view keeps them whole).",
            treelight_render::TEXTURE_BUDGET_BYTES >> 20
        ));
    }
}

/// Puts the chosen mode on the viewport camera.
pub fn apply_viewport_render(
    mut commands: Commands,
    render: Res<ViewportRender>,
    cameras: Query<(Entity, Option<&PathTraced>), With<OrbitCamera>>,
) {
    for (e, current) in &cameras {
        match render.traced {
            None => {
                if current.is_some() {
                    commands.entity(e).remove::<PathTraced>();
                }
            }
            Some(view) => {
                let wanted = PathTraced {
                    view,
                    ..render.settings
                };
                if current != Some(&wanted) {
                    commands.entity(e).insert(wanted);
                }
            }
        }
    }
}
