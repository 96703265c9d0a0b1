//! Errors the GPU reports (wgpu validation, out of memory) do not close the editor, as Bevy's own
//! policy would: the first turns the path-traced view off and says so, and the editor goes on with
//! its scene whole. Errors that keep coming stop rendering, never the editor: the scene can still
//! be saved (Ctrl+S) and is autosaved.

use crate::editor::core::viewport_render::ViewportRender;
use bevy::prelude::*;
use bevy::render::error_handler::{RenderError, RenderErrorHandler, RenderErrorPolicy};
use treelight_document::scene::notice::Notices;

/// Errors rendered past before rendering stops.
const IGNORED: u32 = 30;

/// How many GPU errors the renderer reported.
#[derive(Resource, Debug, Default)]
pub struct RenderErrors(pub u32);

/// The editor's answer to a GPU error.
pub fn handler() -> RenderErrorHandler {
    RenderErrorHandler(answer)
}

fn answer(error: &RenderError, main_world: &mut World, _: &mut World) -> RenderErrorPolicy {
    let count = {
        let mut errors = main_world.get_resource_or_init::<RenderErrors>();
        errors.0 += 1;
        errors.0
    };
    let what = error
        .description
        .lines()
        .next()
        .unwrap_or_default()
        .to_owned();
    if count == 1 {
        if let Some(mut render) = main_world.get_resource_mut::<ViewportRender>() {
            render.traced = None;
        }
        if let Some(mut notices) = main_world.get_resource_mut::<Notices>() {
            notices.error(format!(
                "The GPU reported an error ({:?}: {what}). The path-traced view is off; the scene is whole and can be saved.",
                error.ty
            ));
        }
    }
    if count <= IGNORED {
        return RenderErrorPolicy::Ignore;
    }
    if count == IGNORED + 1
        && let Some(mut notices) = main_world.get_resource_mut::<Notices>()
    {
        notices.error(
            "Rendering stopped after repeated GPU errors. The scene is whole: save it (Ctrl+S) and start the editor again.",
        );
    }
    RenderErrorPolicy::StopRendering
}
