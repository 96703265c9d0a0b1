//! Key chords as typed: each key press with the modifiers held at that press, read from the
//! keyboard's events in order. Reading modifiers at frame time instead loses a quick Ctrl+Z on a
//! slow frame, whose Ctrl is already up again when the frame looks. Chords typed within one frame
//! are handed out one a frame, in order, so each acts on the scene the one before left (a
//! duplicate, then a delete of the selected copy).

use bevy::input::ButtonState;
use bevy::input::keyboard::{KeyboardFocusLost, KeyboardInput};
use bevy::prelude::*;
use bevy_egui::EguiContexts;

/// Modifier keys held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Modifiers {
    /// Either Control key.
    pub ctrl: bool,
    /// Either Shift key.
    pub shift: bool,
    /// Either Alt key.
    pub alt: bool,
}

impl Modifiers {
    /// No modifier.
    pub const NONE: Modifiers = Modifiers {
        ctrl: false,
        shift: false,
        alt: false,
    };
    /// Control alone.
    pub const CTRL: Modifiers = Modifiers {
        ctrl: true,
        shift: false,
        alt: false,
    };
    /// Control and Shift.
    pub const CTRL_SHIFT: Modifiers = Modifiers {
        ctrl: true,
        shift: true,
        alt: false,
    };
}

/// One key pressed, with the modifiers held when it went down.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Chord {
    /// The key (not a modifier).
    pub key: KeyCode,
    /// The modifiers held at its press.
    pub mods: Modifiers,
}

/// The chords typed and not yet handed out, the frame's chord, and the modifiers held now.
#[derive(Resource, Debug, Default)]
pub struct KeyChords {
    held: [bool; 6],
    queue: std::collections::VecDeque<Chord>,
    /// This frame's chord, if one was typed.
    pub current: Option<Chord>,
}

/// Most chords kept waiting (more than anyone types ahead of the frames).
const MAX_WAITING: usize = 64;

/// Left and right of Control, Shift and Alt.
const MODIFIER_KEYS: [KeyCode; 6] = [
    KeyCode::ControlLeft,
    KeyCode::ControlRight,
    KeyCode::ShiftLeft,
    KeyCode::ShiftRight,
    KeyCode::AltLeft,
    KeyCode::AltRight,
];

impl KeyChords {
    /// The modifiers held now (after the frame's events).
    pub fn modifiers(&self) -> Modifiers {
        Modifiers {
            ctrl: self.held[0] || self.held[1],
            shift: self.held[2] || self.held[3],
            alt: self.held[4] || self.held[5],
        }
    }

    /// Takes one keyboard event: a modifier changes what is held, another key's press is a chord.
    pub fn take(&mut self, key: KeyCode, state: ButtonState, repeat: bool) {
        if let Some(i) = MODIFIER_KEYS.iter().position(|k| *k == key) {
            self.held[i] = state == ButtonState::Pressed;
        } else if state == ButtonState::Pressed && !repeat && self.queue.len() < MAX_WAITING {
            self.queue.push_back(Chord {
                key,
                mods: self.modifiers(),
            });
        }
    }

    /// Makes the oldest waiting chord the frame's.
    pub fn next_frame(&mut self) {
        self.current = self.queue.pop_front();
    }

    /// Drops every chord waiting: they were typed into a text field, not at the editor.
    pub fn drop_waiting(&mut self) {
        self.queue.clear();
        self.current = None;
    }

    /// Whether this frame's chord is `key` with exactly `mods` (Alt aside).
    pub fn pressed(&self, key: KeyCode, mods: Modifiers) -> bool {
        self.current
            .is_some_and(|c| c.key == key && c.mods.ctrl == mods.ctrl && c.mods.shift == mods.shift)
    }
}

/// Reads the frame's keyboard events into [`KeyChords`]. While a text field has the keyboard,
/// what is typed is the field's: the chords waiting and those of this frame are dropped, never
/// handed out later as shortcuts (on a slow frame, a Delete typed into the rename box would
/// delete the selected object once the field let go).
pub fn read_chords(
    mut chords: ResMut<KeyChords>,
    mut keys: MessageReader<KeyboardInput>,
    mut lost: MessageReader<KeyboardFocusLost>,
    mut contexts: EguiContexts,
) {
    if lost.read().count() > 0 {
        // Keys released while another window had the keyboard never report their release.
        chords.held = [false; 6];
    }
    let free = keyboard_is_free(&mut contexts);
    for e in keys.read() {
        chords.take(e.key_code, e.state, e.repeat);
    }
    if free {
        chords.next_frame();
    } else {
        chords.drop_waiting();
    }
}

/// Keeps [`KeyChords`] up to date, early in each frame.
pub struct KeyChordsPlugin;

impl Plugin for KeyChordsPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<KeyChords>()
            .add_systems(PreUpdate, read_chords.after(bevy::input::InputSystems));
    }
}

/// Whether the keys are the editor's this frame: not while an egui text field has the keyboard.
pub fn keyboard_is_free(contexts: &mut EguiContexts) -> bool {
    contexts
        .ctx_mut()
        .map_or(true, |ctx| !ctx.egui_wants_keyboard_input())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chord_typed_within_one_frame_keeps_its_modifiers() {
        let mut c = KeyChords::default();
        // Ctrl+Z, Ctrl+Shift+Z, Delete and Ctrl+D, each key up before the next, all in one frame.
        let events = [
            (KeyCode::ControlLeft, ButtonState::Pressed),
            (KeyCode::KeyZ, ButtonState::Pressed),
            (KeyCode::KeyZ, ButtonState::Released),
            (KeyCode::ShiftLeft, ButtonState::Pressed),
            (KeyCode::KeyZ, ButtonState::Pressed),
            (KeyCode::KeyZ, ButtonState::Released),
            (KeyCode::ShiftLeft, ButtonState::Released),
            (KeyCode::ControlLeft, ButtonState::Released),
            (KeyCode::Delete, ButtonState::Pressed),
            (KeyCode::Delete, ButtonState::Released),
            (KeyCode::ControlRight, ButtonState::Pressed),
            (KeyCode::KeyD, ButtonState::Pressed),
            (KeyCode::ControlRight, ButtonState::Released),
            (KeyCode::KeyD, ButtonState::Released),
        ];
        for (k, s) in events {
            c.take(k, s, false);
        }
        let mut frames = Vec::new();
        loop {
            c.next_frame();
            match c.current {
                Some(chord) => frames.push(chord),
                None => break,
            }
        }
        assert_eq!(
            frames,
            vec![
                Chord {
                    key: KeyCode::KeyZ,
                    mods: Modifiers::CTRL
                },
                Chord {
                    key: KeyCode::KeyZ,
                    mods: Modifiers::CTRL_SHIFT
                },
                Chord {
                    key: KeyCode::Delete,
                    mods: Modifiers::NONE
                },
                Chord {
                    key: KeyCode::KeyD,
                    mods: Modifiers::CTRL
                },
            ]
        );
        assert_eq!(c.modifiers(), Modifiers::NONE);
        assert!(!c.pressed(KeyCode::KeyZ, Modifiers::NONE));
        // A key held down repeats without being typed again.
        c.take(KeyCode::KeyZ, ButtonState::Pressed, true);
        c.next_frame();
        assert_eq!(c.current, None);
    }

    #[test]
    fn keys_typed_while_a_text_field_has_the_keyboard_are_never_handed_out() {
        let mut c = KeyChords::default();
        // A slow frame: Delete then Return typed into the rename box, both in one frame.
        for k in [KeyCode::Delete, KeyCode::Enter] {
            c.take(k, ButtonState::Pressed, false);
            c.take(k, ButtonState::Released, false);
        }
        // The field had the keyboard: what waited is dropped, with the frame's own.
        c.drop_waiting();
        assert_eq!(c.current, None);
        // The next frames, with the keyboard free again, hand out nothing typed before.
        c.next_frame();
        assert_eq!(c.current, None);
        // Held modifiers are still followed.
        c.take(KeyCode::ControlLeft, ButtonState::Pressed, false);
        c.take(KeyCode::KeyZ, ButtonState::Pressed, false);
        c.next_frame();
        assert_eq!(
            c.current,
            Some(Chord {
                key: KeyCode::KeyZ,
                mods: Modifiers::CTRL
            })
        );
    }
}
