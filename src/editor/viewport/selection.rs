//! What belongs to the edited scene, what is selected, and how clicks and boxes in the viewport
//! change the selection. The outliner and the viewport share the one [`Selection`].

use crate::editor::core::selection::{ClickModifiers, Selection};
use bevy::prelude::*;
use treelight_render::Outlined;

use treelight_document::edit::history::apply_edit_requests;
use treelight_document::scene::outbox::DocumentEvent;
use treelight_document::values::object::{SceneIndex, SceneObject};

/// What a click in the viewport selects, given what the ray hit (`hit`, a scene object or `None`
/// for empty space), the modifiers, whether it repeats the last click on the same spot, and
/// `parent_of` (a scene object's parent when that is a scene object too).
///
/// A plain click selects what was hit; clicking again on the same spot, or Alt-clicking, walks up
/// from the selected ancestor of the hit to its parent; Ctrl/Shift-click toggles the hit (or its
/// selected ancestor); a click on nothing clears the selection unless Ctrl/Shift is held.
pub fn click(
    selection: &mut Selection,
    hit: Option<Entity>,
    modifiers: ClickModifiers,
    same_spot: bool,
    parent_of: impl Fn(Entity) -> Option<Entity>,
) {
    let Some(hit) = hit else {
        if !modifiers.toggle {
            selection.clear();
        }
        return;
    };
    // The hit itself or the ancestor of it that is selected (after a walk up).
    let mut chain = vec![hit];
    while let Some(p) = parent_of(*chain.last().unwrap()) {
        chain.push(p);
    }
    let selected_in_chain = chain.iter().position(|e| selection.contains(*e));
    if modifiers.toggle {
        selection.toggle(selected_in_chain.map_or(hit, |i| chain[i]));
        return;
    }
    let walk_up = modifiers.parent || same_spot;
    let target = match (walk_up, selected_in_chain) {
        // Up one level from what is selected; past the top, back to the hit.
        (true, Some(i)) if selection.entities().len() == 1 => {
            chain.get(i + 1).copied().unwrap_or(hit)
        }
        (true, None) if modifiers.parent => chain.get(1).copied().unwrap_or(hit),
        _ => hit,
    };
    selection.set(Some(target));
}

/// Drops selected entities that are gone or no longer scene objects.
pub fn drop_stale_selection(
    mut selection: ResMut<Selection>,
    objects: Query<(), With<SceneObject>>,
) {
    if selection.entities().iter().any(|e| !objects.contains(*e)) {
        selection.retain(|e| objects.contains(*e));
    }
}

/// Escape clears the selection (not while a text field has the keyboard, where it ends the edit,
/// nor during a gizmo drag, which it cancels).
pub fn clear_selection_on_escape(
    chords: Res<crate::editor::core::key_chords::KeyChords>,
    mut contexts: bevy_egui::EguiContexts,
    mut selection: ResMut<Selection>,
) {
    if !chords.triggered(crate::editor::core::keymap::Action::Cancel) || selection.is_empty() {
        return;
    }
    if !crate::editor::core::key_chords::keyboard_is_free(&mut contexts) {
        return;
    }
    selection.clear();
}

/// The meshes a selection outlines, each with how: those of the selected objects and of everything
/// under them, the active object's as [`Outlined::Active`].
pub fn outlined_meshes(
    selection: &Selection,
    children: impl Fn(Entity) -> Vec<Entity>,
    is_mesh: impl Fn(Entity) -> bool,
) -> std::collections::HashMap<Entity, Outlined> {
    let mut out = std::collections::HashMap::new();
    let active = selection.active();
    for &top in selection.entities() {
        let how = if Some(top) == active {
            Outlined::Active
        } else {
            Outlined::Selected
        };
        let mut stack = vec![top];
        while let Some(e) = stack.pop() {
            if is_mesh(e) {
                let v = out.entry(e).or_insert(how);
                if how == Outlined::Active {
                    *v = how;
                }
            }
            stack.extend(children(e));
        }
    }
    out
}

/// Keeps [`Outlined`] on exactly the meshes the selection outlines, so every path-traced view draws
/// their silhouettes (complete in each frame, from the primary hits it traces anyway).
pub fn outline_selected_meshes(
    mut commands: Commands,
    selection: Res<Selection>,
    children: Query<&Children>,
    meshes: Query<(), With<Mesh3d>>,
    outlined: Query<(Entity, &Outlined)>,
) {
    let want = outlined_meshes(
        &selection,
        |e| children.get(e).map_or_else(|_| Vec::new(), |c| c.to_vec()),
        |e| meshes.contains(e),
    );
    // `try_`: an edit later in the frame (an undo typed in the same frame) may despawn the mesh
    // before these commands apply; that must not take the editor down.
    for (e, how) in &outlined {
        if !want.contains_key(&e) {
            commands.entity(e).try_remove::<Outlined>();
        } else if want[&e] != *how {
            commands.entity(e).try_insert(want[&e]);
        }
    }
    for (&e, &how) in &want {
        if !outlined.contains(e) {
            commands.entity(e).try_insert(how);
        }
    }
}

/// Follows the document: what an edit made becomes the selection; a replaced scene ends it.
pub fn follow_document(
    mut events: MessageReader<DocumentEvent>,
    mut selection: ResMut<Selection>,
    index: Res<SceneIndex>,
) {
    for event in events.read() {
        match event {
            DocumentEvent::Made(ids) => {
                selection.set_all(ids.iter().filter_map(|id| index.entity(*id)));
            }
            DocumentEvent::Replaced => selection.clear(),
            _ => {}
        }
    }
}

/// The shared selection and what keeps it valid.
pub struct SelectionPlugin;

impl Plugin for SelectionPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<Selection>().add_systems(
            Update,
            (
                follow_document
                    .after(apply_edit_requests)
                    .before(drop_stale_selection),
                drop_stale_selection,
                clear_selection_on_escape
                    .after(crate::editor::viewport::gizmo::cancel_drag_on_escape),
                outline_selected_meshes
                    .after(drop_stale_selection)
                    .after(clear_selection_on_escape),
            ),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Entities 1 ⊂ 2 ⊂ 3 (3 the top), and 4 alone.
    fn parent_of(e: Entity) -> Option<Entity> {
        match e.index_u32() {
            1 => Some(Entity::from_raw_u32(2).unwrap()),
            2 => Some(Entity::from_raw_u32(3).unwrap()),
            _ => None,
        }
    }

    fn e(i: u32) -> Entity {
        Entity::from_raw_u32(i).unwrap()
    }

    #[test]
    fn a_selection_outlines_its_meshes_and_those_under_it() {
        // 3 holds 2 holds 1; 3 and 1 are meshes, 2 an empty group; 4 a mesh alone; 5 a light.
        let children = |x: Entity| match x.index_u32() {
            3 => vec![e(2)],
            2 => vec![e(1)],
            _ => vec![],
        };
        let is_mesh = |x: Entity| matches!(x.index_u32(), 1 | 3 | 4);
        let mut s = Selection::default();
        assert!(outlined_meshes(&s, children, is_mesh).is_empty());
        s.set_all([e(2)]);
        let o = outlined_meshes(&s, children, is_mesh);
        assert_eq!(o.len(), 1, "the empty group outlines the mesh under it");
        assert_eq!(o[&e(1)], Outlined::Active);
        s.set_all([e(3), e(4)]);
        let o = outlined_meshes(&s, children, is_mesh);
        assert_eq!(o.len(), 3);
        assert_eq!(o[&e(3)], Outlined::Selected);
        assert_eq!(o[&e(1)], Outlined::Selected);
        assert_eq!(
            o[&e(4)],
            Outlined::Active,
            "the last selected is the active one"
        );
        // Selected twice over (the top and a mesh under it): the active mark wins.
        s.set_all([e(3), e(1)]);
        assert_eq!(
            outlined_meshes(&s, children, is_mesh)[&e(1)],
            Outlined::Active
        );
        s.set_all([e(5)]);
        assert!(
            outlined_meshes(&s, children, is_mesh).is_empty(),
            "a light has no mesh"
        );
    }

    #[test]
    fn clicks_select_walk_up_and_toggle() {
        let mut s = Selection::default();
        let plain = ClickModifiers::default();
        click(&mut s, Some(e(1)), plain, false, parent_of);
        assert_eq!(s.entities(), &[e(1)]);
        // Clicking the same spot again walks up to the assembly, then its parent, then back.
        click(&mut s, Some(e(1)), plain, true, parent_of);
        assert_eq!(s.entities(), &[e(2)]);
        click(&mut s, Some(e(1)), plain, true, parent_of);
        assert_eq!(s.entities(), &[e(3)]);
        click(&mut s, Some(e(1)), plain, true, parent_of);
        assert_eq!(s.entities(), &[e(1)]);
        // Alt-click on an unselected part selects its parent at once.
        let alt = ClickModifiers {
            parent: true,
            ..default()
        };
        s.clear();
        click(&mut s, Some(e(1)), alt, false, parent_of);
        assert_eq!(s.entities(), &[e(2)]);
        // Ctrl-click adds, and removes what is selected (an ancestor of the hit counts).
        let ctrl = ClickModifiers {
            toggle: true,
            ..default()
        };
        click(&mut s, Some(e(4)), ctrl, false, parent_of);
        assert_eq!(s.entities(), &[e(2), e(4)]);
        assert_eq!(s.active(), Some(e(4)));
        click(&mut s, Some(e(1)), ctrl, false, parent_of);
        assert_eq!(s.entities(), &[e(4)]);
        // Empty space clears, unless Ctrl is held.
        click(&mut s, None, ctrl, false, parent_of);
        assert_eq!(s.entities(), &[e(4)]);
        click(&mut s, None, plain, false, parent_of);
        assert!(s.is_empty());
    }
}
