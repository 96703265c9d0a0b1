//! Files dropped on the window from the desktop: each is imported where it was dropped, through the
//! ray from the viewport's camera under the pointer (the viewport's centre where the window system
//! does not say).

use crate::editor::core::place::view_ray;
use crate::editor::core::view::OrbitCamera;
use bevy::prelude::*;
use bevy::window::FileDragAndDrop;
use treelight_document::import::parse::PendingImports;

/// Starts an import for every file dropped on the window, with where it was dropped.
pub fn import_dropped_files(
    mut drops: MessageReader<FileDragAndDrop>,
    mut pending: ResMut<PendingImports>,
    windows: Query<(&Window, Option<&bevy::window::RawHandleWrapper>)>,
    cameras: Query<(&Camera, &GlobalTransform), With<OrbitCamera>>,
) {
    for drop in drops.read() {
        if let FileDragAndDrop::DroppedFile { path_buf, window } = drop {
            // winit knows the pointer except during an X11 drag; then the X server is asked.
            let at = windows.get(*window).ok().and_then(|(w, handle)| {
                w.cursor_position().or_else(|| {
                    handle.and_then(|h| {
                        crate::editor::viewport::x11_pointer::pointer_in(h, w.scale_factor())
                    })
                })
            });
            // Without a camera to drop through, the file is opened as from the menu (framed).
            let ray = cameras
                .single()
                .ok()
                .and_then(|(camera, cam_gt)| view_ray(camera, cam_gt, at));
            pending.start_at(path_buf.clone(), ray);
        }
    }
}
