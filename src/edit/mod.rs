//! Editing: commands as values ([`command`]), the history that applies and takes them back
//! ([`history`]), snapshots of deleted objects ([`snapshot`]) and the keyboard shortcuts
//! ([`shortcuts`]). Everything that changes the scene goes through [`EditRequests`].

pub mod command;
pub mod history;
pub mod shortcuts;
pub mod snapshot;

pub use command::{EditCommand, EditError, LightKind, MaterialValue, Primitive, TransformValue};
pub use history::{EditHistory, EditRequest, EditRequests, apply_edit_requests, apply_request};

use crate::scene_id::SceneIndex;
use bevy::prelude::*;

/// Stable ids, the command path, the history and the shortcuts.
pub struct EditPlugin;

impl Plugin for EditPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<SceneIndex>()
            .init_resource::<EditHistory>()
            .init_resource::<EditRequests>()
            .init_resource::<shortcuts::EditClipboard>()
            .add_systems(
                Update,
                (shortcuts::edit_shortcuts, apply_edit_requests).chain(),
            );
    }
}
