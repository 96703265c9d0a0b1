//! Editing: commands as values ([`command`]), the history that applies and takes them back
//! ([`history`]) and snapshots of deleted objects ([`snapshot`]). Everything that changes the
//! scene goes through [`history::EditRequests`].

pub mod command;
pub mod history;
pub mod snapshot;

use bevy::prelude::*;

/// Stable ids, the command path and the history.
pub struct EditPlugin;

impl Plugin for EditPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<crate::values::object::SceneIndex>()
            .init_resource::<crate::values::object::EditedObjects>()
            .init_resource::<history::EditHistory>()
            .init_resource::<history::EditRequests>();
    }
}
