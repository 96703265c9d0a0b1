//! The editor's key map, in one table: every handler asks whether its [`Action`] was typed this
//! frame, and the menus and Help show the keys from the same table.

use crate::editor::core::key_chords::KeyChords;

use crate::editor::core::key_chords::Modifiers;
use bevy::prelude::KeyCode;

/// What a key does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    /// File → New.
    New,
    /// File → Open….
    Open,
    /// File → Save.
    Save,
    /// File → Save As….
    SaveAs,
    /// File → Quit.
    Quit,
    /// File → Render image….
    RenderImage,
    /// Edit → Undo.
    Undo,
    /// Edit → Redo.
    Redo,
    /// Delete the selection.
    Delete,
    /// Duplicate the selection.
    Duplicate,
    /// Copy the selection.
    Copy,
    /// Paste copies of what was copied.
    Paste,
    /// Group the selection.
    Group,
    /// The gizmo's move handles.
    MoveMode,
    /// The gizmo's rotate handles.
    RotateMode,
    /// The gizmo's scale handles.
    ScaleMode,
    /// Frame the selection.
    Frame,
    /// Frame everything, from above at an angle.
    FrameAll,
    /// Look from the front.
    ViewFront,
    /// Look from the side.
    ViewSide,
    /// Look from the top.
    ViewTop,
    /// Rename the active object in the outliner.
    Rename,
    /// Cancel the drag in progress, else clear the selection.
    Cancel,
}

/// One key (with its modifiers) for an action.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    /// What it does.
    pub action: Action,
    /// The key.
    pub key: KeyCode,
    /// The modifiers held with it, exactly (Alt aside).
    pub mods: Modifiers,
}

const fn bind(action: Action, key: KeyCode, mods: Modifiers) -> Binding {
    Binding { action, key, mods }
}

/// Every key binding, in the order Help lists them.
pub const KEYMAP: &[Binding] = &[
    bind(Action::New, KeyCode::KeyN, Modifiers::CTRL),
    bind(Action::Open, KeyCode::KeyO, Modifiers::CTRL),
    bind(Action::Save, KeyCode::KeyS, Modifiers::CTRL),
    bind(Action::SaveAs, KeyCode::KeyS, Modifiers::CTRL_SHIFT),
    bind(Action::Quit, KeyCode::KeyQ, Modifiers::CTRL),
    bind(Action::RenderImage, KeyCode::F12, Modifiers::NONE),
    bind(Action::Undo, KeyCode::KeyZ, Modifiers::CTRL),
    bind(Action::Redo, KeyCode::KeyZ, Modifiers::CTRL_SHIFT),
    bind(Action::Redo, KeyCode::KeyY, Modifiers::CTRL),
    bind(Action::Delete, KeyCode::Delete, Modifiers::NONE),
    bind(Action::Duplicate, KeyCode::KeyD, Modifiers::CTRL),
    bind(Action::Copy, KeyCode::KeyC, Modifiers::CTRL),
    bind(Action::Paste, KeyCode::KeyV, Modifiers::CTRL),
    bind(Action::Group, KeyCode::KeyG, Modifiers::CTRL),
    bind(Action::MoveMode, KeyCode::KeyW, Modifiers::NONE),
    bind(Action::RotateMode, KeyCode::KeyE, Modifiers::NONE),
    bind(Action::ScaleMode, KeyCode::KeyR, Modifiers::NONE),
    bind(Action::Frame, KeyCode::KeyF, Modifiers::NONE),
    bind(Action::FrameAll, KeyCode::Home, Modifiers::NONE),
    bind(Action::ViewFront, KeyCode::Digit1, Modifiers::NONE),
    bind(Action::ViewSide, KeyCode::Digit3, Modifiers::NONE),
    bind(Action::ViewTop, KeyCode::Digit7, Modifiers::NONE),
    bind(Action::Rename, KeyCode::F2, Modifiers::NONE),
    bind(Action::Cancel, KeyCode::Escape, Modifiers::NONE),
];

impl Action {
    /// What Help says it does.
    pub fn describe(self) -> &'static str {
        match self {
            Action::New => "New scene",
            Action::Open => "Open a project",
            Action::Save => "Save",
            Action::SaveAs => "Save as",
            Action::Quit => "Quit (asks first about unsaved changes)",
            Action::RenderImage => "Render an image of the view to a file",
            Action::Undo => "Undo",
            Action::Redo => "Redo",
            Action::Delete => "Delete the selection",
            Action::Duplicate => "Duplicate the selection (the copy is selected)",
            Action::Copy => "Copy the selection",
            Action::Paste => "Paste copies of what was copied, in place",
            Action::Group => "Group the selection under a new empty",
            Action::MoveMode => "Gizmo: move",
            Action::RotateMode => "Gizmo: rotate",
            Action::ScaleMode => "Gizmo: scale",
            Action::Frame => "Frame the selection",
            Action::FrameAll => "Frame everything, from above at an angle",
            Action::ViewFront => "Front view",
            Action::ViewSide => "Side view",
            Action::ViewTop => "Top view",
            Action::Rename => "Rename (in the outliner)",
            Action::Cancel => "Cancel the drag, else clear the selection",
        }
    }

    /// Its keys as the menus and Help show them: `Ctrl+Shift+Z, Ctrl+Y`.
    pub fn keys(self) -> String {
        KEYMAP
            .iter()
            .filter(|b| b.action == self)
            .map(|b| chord_text(b.key, b.mods))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Every action, once each, in the table's order.
    pub fn all() -> Vec<Action> {
        let mut out: Vec<Action> = Vec::new();
        for b in KEYMAP {
            if !out.contains(&b.action) {
                out.push(b.action);
            }
        }
        out
    }
}

/// `Ctrl+Shift+Z`.
fn chord_text(key: KeyCode, mods: Modifiers) -> String {
    let mut text = String::new();
    if mods.ctrl {
        text.push_str("Ctrl+");
    }
    if mods.shift {
        text.push_str("Shift+");
    }
    if mods.alt {
        text.push_str("Alt+");
    }
    text.push_str(&key_name(key));
    text
}

/// A key's name on the keycap.
fn key_name(key: KeyCode) -> String {
    match key {
        KeyCode::Delete => "Del".into(),
        KeyCode::Escape => "Esc".into(),
        other => {
            let debug = format!("{other:?}");
            debug
                .strip_prefix("Key")
                .or_else(|| debug.strip_prefix("Digit"))
                .unwrap_or(&debug)
                .to_owned()
        }
    }
}

impl KeyChords {
    /// Whether this frame's chord is one of `action`'s keys.
    pub fn triggered(&self, action: Action) -> bool {
        KEYMAP
            .iter()
            .any(|b| b.action == action && self.pressed(b.key, b.mods))
    }

    /// Takes this frame's chord, so that no later handler acts on it too.
    pub fn consume(&mut self) {
        self.current = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::input::ButtonState;

    #[test]
    fn keys_are_named_from_the_table_and_no_chord_has_two_actions() {
        assert_eq!(Action::Redo.keys(), "Ctrl+Shift+Z, Ctrl+Y");
        assert_eq!(Action::Delete.keys(), "Del");
        assert_eq!(Action::Rename.keys(), "F2");
        assert_eq!(Action::SaveAs.keys(), "Ctrl+Shift+S");
        for (i, a) in KEYMAP.iter().enumerate() {
            for b in &KEYMAP[i + 1..] {
                assert!(
                    !(a.key == b.key && a.mods == b.mods),
                    "{a:?} and {b:?} share a chord"
                );
            }
        }
        assert_eq!(Action::FrameAll.keys(), "Home");
        assert_eq!(Action::ViewTop.keys(), "7");
        assert_eq!(Action::RenderImage.keys(), "F12");
        // Every action has a key.
        assert_eq!(Action::all().len(), 23);
    }

    #[test]
    fn a_chord_triggers_its_action_only() {
        let mut chords = KeyChords::default();
        chords.take(KeyCode::ControlLeft, ButtonState::Pressed, false);
        chords.take(KeyCode::KeyY, ButtonState::Pressed, false);
        chords.next_frame();
        assert!(chords.triggered(Action::Redo));
        assert!(!chords.triggered(Action::Undo));
        chords.consume();
        assert!(!chords.triggered(Action::Redo));
    }
}
