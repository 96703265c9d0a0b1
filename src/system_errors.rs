//! The editor's policy for errors its systems and commands return: logged and shown once as a
//! notice, and the editor carries on. Bevy's default (panic) would take the open scene down with
//! an error as small as a command aimed at an entity an edit despawned in the same frame.

use bevy::ecs::error::{BevyError, ErrorContext};
use bevy::prelude::*;
use std::sync::Mutex;
use treelight_document::scene::notice::Notices;

/// Errors reported since the UI last looked, and how many were left out.
static REPORTED: Mutex<(Vec<String>, usize)> = Mutex::new((Vec::new(), 0));

/// Most errors kept for the UI between two frames (a system failing every frame would flood it).
const KEPT: usize = 16;

/// The error handler: logs the error and keeps it for [`show_system_errors`].
pub fn report_error(error: BevyError, ctx: ErrorContext) {
    let text = format!("{ctx}: {error}");
    error!("{text}");
    let mut reported = REPORTED.lock().unwrap_or_else(|p| p.into_inner());
    if reported.0.len() < KEPT {
        reported.0.push(text);
    } else {
        reported.1 += 1;
    }
}

/// Shows each distinct error once as a notice.
pub fn show_system_errors(mut notices: ResMut<Notices>, mut shown: Local<Vec<String>>) {
    let (errors, _) = std::mem::take(&mut *REPORTED.lock().unwrap_or_else(|p| p.into_inner()));
    for text in errors {
        // The first line names the system or command; repeats of it are not shown again.
        let head = text.lines().next().unwrap_or_default().to_owned();
        if shown.contains(&head) || shown.len() > 256 {
            continue;
        }
        shown.push(head);
        notices.error(format!(
            "internal error, the editor carried on (this is a bug in Treelight): {text}"
        ));
    }
}
