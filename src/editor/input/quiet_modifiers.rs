//! bevy_egui tells egui the modifier keys' state every frame as a `ModifiersChanged` event, and
//! egui asks for another frame whenever a frame had an event: an editor drawn only when something
//! changes would never rest. Only real changes pass on; egui keeps the state between frames.

use bevy::prelude::*;
use bevy_egui::{EguiInput, EguiPreUpdateSet, egui};
use std::collections::HashMap;

/// Drops each context's `ModifiersChanged` events that repeat the state it has.
pub fn drop_unchanged_modifiers(
    mut inputs: Query<(Entity, &mut EguiInput)>,
    mut last: Local<HashMap<Entity, egui::Modifiers>>,
) {
    for (entity, mut input) in &mut inputs {
        let known = last.entry(entity).or_default();
        input.0.events.retain(|event| match event {
            egui::Event::ModifiersChanged(m) if m == known => false,
            egui::Event::ModifiersChanged(m) => {
                *known = *m;
                true
            }
            _ => true,
        });
    }
}

/// Where the filter runs: after bevy_egui has written the frame's input, before egui reads it.
pub fn register(app: &mut App) {
    app.add_systems(
        PreUpdate,
        drop_unchanged_modifiers
            .after(EguiPreUpdateSet::ProcessInput)
            .before(EguiPreUpdateSet::BeginPass),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_changes_of_the_modifiers_reach_egui() {
        let mut app = App::new();
        app.add_systems(Update, drop_unchanged_modifiers);
        let e = app.world_mut().spawn(EguiInput::default()).id();
        let events = |app: &mut App, mods: Vec<egui::Modifiers>| {
            let mut input = app.world_mut().get_mut::<EguiInput>(e).unwrap();
            input.0.events = mods
                .into_iter()
                .map(egui::Event::ModifiersChanged)
                .collect();
            app.update();
            app.world().get::<EguiInput>(e).unwrap().0.events.len()
        };
        assert_eq!(
            events(&mut app, vec![egui::Modifiers::NONE]),
            0,
            "no change"
        );
        assert_eq!(
            events(&mut app, vec![egui::Modifiers::SHIFT]),
            1,
            "Shift pressed"
        );
        assert_eq!(
            events(&mut app, vec![egui::Modifiers::SHIFT]),
            0,
            "Shift held"
        );
        assert_eq!(
            events(&mut app, vec![egui::Modifiers::NONE]),
            1,
            "Shift released"
        );
    }
}
