//! What belongs to the edited scene, and what is selected.

use bevy::prelude::*;

/// Marks entities that are part of the edited scene (listed in the outliner), as opposed to the
/// editor's own camera and UI. Each has a stable [`SceneId`](crate::scene_id::SceneId).
#[derive(Component, Debug, Default, Clone, Copy)]
#[require(crate::scene_id::SceneId)]
pub struct SceneObject;

/// The selected scene entity, if any.
#[derive(Resource, Debug, Default, Clone, Copy, PartialEq)]
pub struct Selection(pub Option<Entity>);

/// Clears the selection when its entity is gone.
pub fn drop_stale_selection(
    mut selection: ResMut<Selection>,
    objects: Query<(), With<SceneObject>>,
) {
    if let Some(e) = selection.0
        && objects.get(e).is_err()
    {
        selection.0 = None;
    }
}

/// Escape clears the selection (not while a text field has the keyboard, where it ends the edit).
pub fn clear_selection_on_escape(
    keys: Res<ButtonInput<KeyCode>>,
    mut contexts: bevy_egui::EguiContexts,
    mut selection: ResMut<Selection>,
) {
    if !keys.just_pressed(KeyCode::Escape) || selection.0.is_none() {
        return;
    }
    if !crate::edit::shortcuts::keyboard_is_free(&mut contexts) {
        return;
    }
    selection.0 = None;
}
