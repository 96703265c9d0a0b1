//! What is selected: the one [`Selection`] the viewport, the outliner, the inspector and the
//! menus share, and the modifiers a selecting click carries.

use bevy::prelude::*;
use treelight_document::values::object::SceneId;

/// The selected scene entities, in the order they were selected; the last is the active one (the
/// inspector's, and the gizmo's frame in local mode).
#[derive(Resource, Debug, Default, Clone, PartialEq)]
pub struct Selection {
    entities: Vec<Entity>,
}

impl Selection {
    /// A selection of one entity, or none.
    pub fn of(entity: Option<Entity>) -> Self {
        Self {
            entities: entity.into_iter().collect(),
        }
    }

    /// The active entity: the one selected last.
    pub fn active(&self) -> Option<Entity> {
        self.entities.last().copied()
    }

    /// Every selected entity, the active one last.
    pub fn entities(&self) -> &[Entity] {
        &self.entities
    }

    /// The selected objects' ids (of those that have one), the active one last.
    pub fn ids(&self, ids: &Query<&SceneId>) -> Vec<SceneId> {
        self.entities
            .iter()
            .filter_map(|e| ids.get(*e).ok().copied())
            .collect()
    }

    /// Whether `e` is selected.
    pub fn contains(&self, e: Entity) -> bool {
        self.entities.contains(&e)
    }

    /// Whether nothing is selected.
    pub fn is_empty(&self) -> bool {
        self.entities.is_empty()
    }

    /// Selects `e` alone (nothing for `None`).
    pub fn set(&mut self, e: Option<Entity>) {
        self.entities.clear();
        self.entities.extend(e);
    }

    /// Selects exactly `entities`, the last active.
    pub fn set_all(&mut self, entities: impl IntoIterator<Item = Entity>) {
        self.entities.clear();
        for e in entities {
            self.add(e);
        }
    }

    /// Adds `e` and makes it active.
    pub fn add(&mut self, e: Entity) {
        self.entities.retain(|x| *x != e);
        self.entities.push(e);
    }

    /// Adds `e` if it is not selected, else removes it.
    pub fn toggle(&mut self, e: Entity) {
        if self.contains(e) {
            self.entities.retain(|x| *x != e);
        } else {
            self.entities.push(e);
        }
    }

    /// Clears the selection.
    pub fn clear(&mut self) {
        self.entities.clear();
    }

    /// Keeps only the entities `keep` accepts.
    pub fn retain(&mut self, keep: impl FnMut(&Entity) -> bool) {
        self.entities.retain(keep);
    }
}

/// Modifier keys held during a click.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct ClickModifiers {
    /// Ctrl or Shift: add to or toggle in the selection.
    pub toggle: bool,
    /// Alt: select the parent assembly of what is under the pointer.
    pub parent: bool,
}
