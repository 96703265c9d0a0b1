//! Input: the keys pressed this frame as chords ([`key_chords`]), the one key map that the
//! handlers, the menus and Help read ([`keymap`]), and the edit shortcuts with the clipboard
//! ([`shortcuts`]), and egui's click windows kept wide enough for slow frames ([`click_timing`]).

pub mod click_timing;
pub mod key_chords;
pub mod keymap;
pub mod shortcuts;

use bevy::prelude::*;
use treelight_document::edit::history::apply_edit_requests;

/// Chords, the clipboard and the edit shortcuts.
pub struct InputPlugin;

impl Plugin for InputPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(key_chords::KeyChordsPlugin)
            .init_resource::<shortcuts::EditClipboard>()
            .add_systems(
                Update,
                (
                    shortcuts::edit_shortcuts.before(apply_edit_requests),
                    click_timing::widen_click_windows,
                ),
            );
    }
}
