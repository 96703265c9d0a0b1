//! When the editor's UI systems run in egui's pass: the set they all belong to and its steps in
//! order, so that each feature registers its own systems and still runs where the frame needs it.

use bevy::prelude::*;

/// The systems that draw the editor's UI and act on it, in egui's pass.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub struct EditorUi;

/// The steps of [`EditorUi`], run in this order.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UiStep {
    /// What the panels draw from is brought up to date.
    Prepare,
    /// The window is drawn: menu bar, dock, status bar.
    Draw,
    /// What floats over the window: notices.
    Overlay,
    /// What the menus asked for is acted on, or handed to the feature that does it.
    Menus,
    /// The file dialogs: requests taken, dialogs shown, files chosen handed on.
    Files,
    /// What the user did in the viewport (and the panorama chosen for the sky) is acted on.
    Viewport,
}

/// Orders the steps.
pub fn configure_ui_steps(app: &mut App) {
    app.configure_sets(
        bevy_egui::EguiPrimaryContextPass,
        (
            UiStep::Prepare,
            UiStep::Draw,
            UiStep::Overlay,
            UiStep::Menus,
            UiStep::Files,
            UiStep::Viewport,
        )
            .chain()
            .in_set(EditorUi),
    );
}
