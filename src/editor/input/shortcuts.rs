//! Keyboard shortcuts for the history and the selection (undo, redo, delete, duplicate, copy,
//! paste, group; their keys are in [`crate::editor::core::keymap`]). None fires while a text field has the
//! keyboard.

use crate::editor::core::clipboard::EditClipboard;
use crate::editor::core::key_chords::KeyChords;
use crate::editor::core::key_chords::keyboard_is_free;
use crate::editor::core::keymap::Action;
use crate::editor::core::selection::Selection;
use bevy::prelude::*;
use bevy_egui::EguiContexts;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::{EditRequest, EditRequests};
use treelight_document::values::object::SceneId;

/// What the frame's chord asks for, given the selection; `None` for nothing.
pub fn shortcut(chords: &KeyChords, selected: &[SceneId]) -> Option<EditRequest> {
    if chords.triggered(Action::Undo) {
        return Some(EditRequest::Undo);
    }
    if chords.triggered(Action::Redo) {
        return Some(EditRequest::Redo);
    }
    if selected.is_empty() {
        return None;
    }
    let ids = selected.to_vec();
    if chords.triggered(Action::Delete) {
        return Some(EditRequest::Apply {
            command: EditCommand::Delete { ids },
            continuing: false,
        });
    }
    if chords.triggered(Action::Duplicate) {
        return Some(EditRequest::Apply {
            command: EditCommand::Duplicate {
                ids,
                copies: Vec::new(),
            },
            continuing: false,
        });
    }
    if chords.triggered(Action::Group) {
        return Some(EditRequest::Apply {
            command: EditCommand::Group {
                ids,
                name: "Group".into(),
                group: None,
            },
            continuing: false,
        });
    }
    None
}

/// Turns the frame's shortcuts into requests.
pub fn edit_shortcuts(
    chords: Res<KeyChords>,
    mut contexts: EguiContexts,
    selection: Res<Selection>,
    ids: Query<&SceneId>,
    index: Res<treelight_document::values::object::SceneIndex>,
    mut clipboard: ResMut<EditClipboard>,
    mut requests: ResMut<EditRequests>,
) {
    if !keyboard_is_free(&mut contexts) {
        return;
    }
    let selected = selection.ids(&ids);
    if chords.triggered(Action::Copy) && !selected.is_empty() {
        clipboard.0 = selected.clone();
    }
    if chords.triggered(Action::Paste)
        && let Some(r) = clipboard.paste(&index)
    {
        requests.0.push(r);
    }
    if let Some(r) = shortcut(&chords, &selected) {
        requests.0.push(r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn press(held: &[KeyCode], key: KeyCode) -> KeyChords {
        use bevy::input::ButtonState;
        let mut chords = KeyChords::default();
        for k in held {
            chords.take(*k, ButtonState::Pressed, false);
        }
        chords.take(key, ButtonState::Pressed, false);
        // The modifiers are let go before the frame looks: the chord keeps them.
        for k in held {
            chords.take(*k, ButtonState::Released, false);
        }
        chords.next_frame();
        chords
    }

    #[test]
    fn the_keys_map_to_their_requests() {
        let id = &[SceneId(4)][..];
        let ctrl = [KeyCode::ControlLeft];
        let ctrl_shift = [KeyCode::ControlLeft, KeyCode::ShiftRight];
        assert_eq!(
            shortcut(&press(&ctrl, KeyCode::KeyZ), id),
            Some(EditRequest::Undo)
        );
        assert_eq!(
            shortcut(&press(&ctrl_shift, KeyCode::KeyZ), id),
            Some(EditRequest::Redo)
        );
        assert_eq!(
            shortcut(&press(&ctrl, KeyCode::KeyY), id),
            Some(EditRequest::Redo)
        );
        assert!(matches!(
            shortcut(&press(&[], KeyCode::Delete), id),
            Some(EditRequest::Apply {
                command: EditCommand::Delete { .. },
                ..
            })
        ));
        assert!(matches!(
            shortcut(&press(&ctrl, KeyCode::KeyD), id),
            Some(EditRequest::Apply {
                command: EditCommand::Duplicate { .. },
                ..
            })
        ));
        assert!(matches!(
            shortcut(&press(&ctrl, KeyCode::KeyG), id),
            Some(EditRequest::Apply {
                command: EditCommand::Group { .. },
                ..
            })
        ));
        // Nothing selected: nothing to delete; a plain D is no shortcut.
        assert_eq!(shortcut(&press(&[], KeyCode::Delete), &[]), None);
        assert_eq!(shortcut(&press(&[], KeyCode::KeyD), id), None);
    }
}
