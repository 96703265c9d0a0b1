//! A gizmo drag as the viewport sends it, shared by the benches: one live preview of a new
//! transform per frame at 60 Hz, then the commit as one step.

use bevy::prelude::*;
use std::time::{Duration, Instant};
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::{EditRequest, EditRequests};
use treelight_document::values::object::SceneId;

/// Frames of a drag come at 60 per second, as a display would pace them.
pub const FRAME: Duration = Duration::from_micros(16_667);

/// What a drag's frames took.
pub struct DragFrames {
    /// The main thread's time of each frame, milliseconds.
    pub frame_ms: Vec<f64>,
    /// When the last frame's request (the commit) was made.
    pub commit: Instant,
}

/// Drags `id` over `frames` frames to `at(1)`, ..., `at(frames)`: previews, the last the commit.
/// Frames are paced at 60 Hz; `after_frame` runs once a frame's time is out, just before the next
/// (after the last, at once: the caller times what follows the commit from its end).
pub fn drag(
    app: &mut App,
    id: SceneId,
    frames: u32,
    at: impl Fn(u32) -> Transform,
    mut after_frame: impl FnMut(&mut App),
) -> DragFrames {
    let mut frame_ms = Vec::with_capacity(frames as usize);
    let mut commit = Instant::now();
    for k in 1..=frames {
        let command = EditCommand::SetTransform {
            id,
            transform: at(k).into(),
        };
        let request = if k == frames {
            EditRequest::Apply {
                command,
                continuing: false,
            }
        } else {
            EditRequest::Preview(command)
        };
        app.world_mut()
            .resource_mut::<EditRequests>()
            .0
            .push(request);
        let t = Instant::now();
        commit = t;
        app.update();
        frame_ms.push(t.elapsed().as_secs_f64() * 1e3);
        if k < frames {
            std::thread::sleep(FRAME.saturating_sub(t.elapsed()));
        }
        after_frame(app);
    }
    DragFrames { frame_ms, commit }
}

/// The median of `v` (the upper one of an even count).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
