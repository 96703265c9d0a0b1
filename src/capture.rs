//! `--screenshot PATH --frames N`: render N frames, save the whole window, exit.

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use std::path::PathBuf;

/// What the command line asked for.
#[derive(Resource, Debug, Clone)]
pub struct CaptureRequest {
    /// Where to save; `None` exits after `frames` frames without a screenshot.
    pub path: Option<PathBuf>,
    /// Frames to render first.
    pub frames: u32,
    /// Frames rendered so far.
    pub rendered: u32,
    /// Whether the screenshot was requested.
    pub requested: bool,
}

/// Counts frames; at the chosen one, asks for a screenshot (or exits). Frames before the scene on
/// the command line has settled and the view draws it, and frames while the path tracer waits for
/// its kernel, do not count: the view has nothing to show yet, and how long loading and the
/// compile take differs between machines.
pub fn count_frames_and_capture(
    mut commands: Commands,
    mut request: ResMut<CaptureRequest>,
    mut exit: MessageWriter<AppExit>,
    loading: treelight_document::app::SceneLoading,
    render: Res<crate::editor::core::viewport_render::ViewportRender>,
    tracer: Res<treelight_render::PathTracerStats>,
) {
    if !render.draws_settled_scene(&loading, &tracer) || tracer.preparing_kernel().is_some() {
        return;
    }
    request.rendered += 1;
    if request.requested || request.rendered < request.frames {
        return;
    }
    request.requested = true;
    match request.path.clone() {
        None => {
            exit.write(AppExit::Success);
        }
        Some(path) => {
            commands
                .spawn(Screenshot::primary_window())
                .observe(save_and_exit(path));
        }
    }
}

/// An observer for a [`Screenshot`] entity: saves the image to `path` as PNG (RGB, written
/// atomically) and exits, with an error status if it cannot be saved.
pub fn save_and_exit(path: PathBuf) -> impl FnMut(On<ScreenshotCaptured>, MessageWriter<AppExit>) {
    move |captured, mut exit| match crate::render_file::save_png(
        &captured.image,
        &path,
        crate::render_file::ImageWrite::Replace,
    ) {
        Ok(()) => {
            info!("screenshot saved to {}", path.display());
            exit.write(AppExit::Success);
        }
        Err(e) => {
            error!("cannot save the screenshot to {}: {e}", path.display());
            exit.write(AppExit::error());
        }
    }
}
