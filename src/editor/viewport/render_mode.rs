//! The viewport's render mode: rasterised by Bevy, path traced, or one of the path tracer's debug
//! views. The choice lives in a resource the UI edits; a system puts it on the camera.

use crate::editor::core::view::OrbitCamera;
use crate::editor::core::viewport_render::ViewportRender;
use bevy::prelude::*;
use bevy::render::renderer::RenderAdapterInfo;
use treelight_document::scene::notice::Notices;
use treelight_render::{DebugView, PathTraced, PathTracerStats};

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

/// The multisampling a viewport camera draws with: the raster view's edges are smoothed by four
/// samples a pixel; a path-traced view gains nothing from them (its picture is one resolve pass
/// over pixels its samples already average), and their multisampled target and depth buffer
/// held 32 MiB of device memory at 1280 × 800 for nothing.
pub fn viewport_msaa(traced: Option<DebugView>) -> Msaa {
    if traced.is_some() {
        Msaa::Off
    } else {
        Msaa::Sample4
    }
}

/// Puts the chosen mode on the viewport camera, with its multisampling ([`viewport_msaa`]).
pub fn apply_viewport_render(
    mut commands: Commands,
    render: Res<ViewportRender>,
    // Every camera has its `Msaa` (Bevy's `Camera` requires one).
    cameras: Query<(Entity, Option<&PathTraced>, &Msaa), With<OrbitCamera>>,
) {
    for (e, current, msaa) in &cameras {
        let wanted_msaa = viewport_msaa(render.traced);
        if *msaa != wanted_msaa {
            commands.entity(e).insert(wanted_msaa);
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::ecs::system::RunSystemOnce;

    #[test]
    fn a_traced_view_draws_without_multisampling_and_the_raster_view_with_it() {
        let mut world = World::new();
        world.insert_resource(ViewportRender::default());
        let camera = world.spawn((OrbitCamera::default(), Msaa::Sample4)).id();
        let apply = |world: &mut World| {
            world.run_system_once(apply_viewport_render).unwrap();
            (
                *world.get::<Msaa>(camera).unwrap(),
                world.get::<PathTraced>(camera).map(|t| t.view),
            )
        };
        assert_eq!(apply(&mut world), (Msaa::Off, Some(DebugView::PathTraced)));
        world.resource_mut::<ViewportRender>().traced = None;
        assert_eq!(apply(&mut world), (Msaa::Sample4, None));
        world.resource_mut::<ViewportRender>().traced = Some(DebugView::Albedo);
        assert_eq!(apply(&mut world), (Msaa::Off, Some(DebugView::Albedo)));
    }
}
