//! Input: the keys pressed this frame read as chords (the chords and the one key map live in
//! [`crate::editor::core`], which every feature reads), the edit shortcuts ([`shortcuts`]), and
//! egui's click windows kept wide enough for slow frames ([`click_timing`]), and only real changes
//! of the modifier keys passed to egui, so that it asks for no frame when nothing changed
//! ([`quiet_modifiers`]).

pub mod click_timing;
pub mod quiet_modifiers;
pub mod shortcuts;

use bevy::prelude::*;
use treelight_document::edit::history::apply_edit_requests;

/// Chords, the clipboard and the edit shortcuts.
pub struct InputPlugin;

impl Plugin for InputPlugin {
    fn build(&self, app: &mut App) {
        quiet_modifiers::register(app);
        app.add_plugins(crate::editor::core::key_chords::KeyChordsPlugin)
            .init_resource::<crate::editor::core::clipboard::EditClipboard>()
            .add_systems(
                Update,
                (
                    shortcuts::edit_shortcuts.before(apply_edit_requests),
                    click_timing::widen_click_windows,
                ),
            );
    }
}
