//! Where the pointer is in a window, asked of the X server. winit reports no pointer position while
//! an X11 drag-and-drop is over the window, yet a file dropped from the desktop should land where it
//! was dropped; the X server knows where the pointer is.

use bevy::math::Vec2;
use bevy::window::RawHandleWrapper;
use raw_window_handle::RawWindowHandle;
use x11rb::protocol::xproto::ConnectionExt;

/// The pointer's position in X window `window` (physical pixels from its top-left corner) on
/// `display` (`None`: `$DISPLAY`), or `None` when there is no X server to ask or the pointer is on
/// another screen.
pub fn pointer_in_window(display: Option<&str>, window: u32) -> Option<(i16, i16)> {
    let (conn, _) = x11rb::connect(display).ok()?;
    let reply = conn.query_pointer(window).ok()?.reply().ok()?;
    // A pointer on another screen has no position in this window.
    reply.same_screen.then_some((reply.win_x, reply.win_y))
}

/// The pointer's position in a Bevy window (logical pixels, as `Window::cursor_position` gives),
/// for a window on an X server; `None` on other window systems.
pub fn pointer_in(handle: &RawHandleWrapper, scale_factor: f32) -> Option<Vec2> {
    let window = match handle.get_window_handle() {
        RawWindowHandle::Xlib(h) => u32::try_from(h.window).ok()?,
        RawWindowHandle::Xcb(h) => h.window.get(),
        _ => return None,
    };
    let (x, y) = pointer_in_window(None, window)?;
    Some(Vec2::new(x as f32, y as f32) / scale_factor.max(f32::EPSILON))
}
