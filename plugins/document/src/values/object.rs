//! Stable ids for scene objects: a number that names an object in commands, the history, tests and
//! scripts, and survives undo (an undone delete comes back with its id). Every [`SceneObject`]
//! gets one when it is spawned; [`SceneIndex`] finds an object's entity by id.

use bevy::ecs::lifecycle::HookContext;
use bevy::ecs::world::DeferredWorld;
use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Marks entities that are part of the edited scene (listed in the outliner), as opposed to the
/// editor's own camera and UI. Each has a stable [`SceneId`].
#[derive(Component, Debug, Default, Clone, Copy)]
#[require(SceneId)]
pub struct SceneObject;

/// A scene object's stable id. Spawned as [`SceneId::NEW`], it is given the next free id.
#[derive(
    Component, Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize,
)]
#[component(on_insert = index_id, on_discard = unindex_id)]
pub struct SceneId(pub u64);

impl SceneId {
    /// Asks for the next free id when inserted.
    pub const NEW: SceneId = SceneId(0);

    /// The largest id an object may have: far beyond what a session makes (one a microsecond for
    /// ten days), and far enough below `u64::MAX` that counting up from it never overflows.
    pub const MAX: SceneId = SceneId(1 << 40);

    /// Whether this is an id an object may have: 1 to [`SceneId::MAX`].
    pub fn is_valid(self) -> bool {
        (1..=Self::MAX.0).contains(&self.0)
    }
}

impl Default for SceneId {
    fn default() -> Self {
        SceneId::NEW
    }
}

impl std::fmt::Display for SceneId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "#{}", self.0)
    }
}

/// Scene objects by id, and the next id to give.
#[derive(Resource, Debug, Default)]
pub struct SceneIndex {
    entities: HashMap<SceneId, Entity>,
    next: u64,
    /// Ids that left the index (deleted objects, which an undo brings back) or that objects not in
    /// the scene hold (a project's kept objects): never given out again.
    retired: std::collections::HashSet<SceneId>,
    /// Where the search for an unused id starts, once the count has reached [`SceneId::MAX`].
    low: u64,
}

impl SceneIndex {
    /// The entity with this id, if it exists.
    pub fn entity(&self, id: SceneId) -> Option<Entity> {
        self.entities.get(&id).copied()
    }

    /// Objects with ids.
    pub fn len(&self) -> usize {
        self.entities.len()
    }

    /// Whether no object has an id.
    pub fn is_empty(&self) -> bool {
        self.entities.is_empty()
    }

    /// Makes every id up to `id` taken, so fresh ones come after it.
    pub fn reserve_through(&mut self, id: SceneId) {
        self.next = self.next.max(id.0.saturating_add(1));
    }

    /// Keeps `id` from being given out: an object that is not in the scene holds it.
    pub fn retire(&mut self, id: SceneId) {
        self.retired.insert(id);
    }

    /// Takes a fresh id: the one after the largest given or named so far, or, once that would
    /// pass [`SceneId::MAX`] (a file or script named an id at the top of the range), the lowest
    /// id never used, so that every id stays one a project can hold.
    pub fn allocate(&mut self) -> SceneId {
        self.next = self.next.max(1);
        if self.next <= SceneId::MAX.0 {
            let id = SceneId(self.next);
            self.next += 1;
            return id;
        }
        loop {
            self.low = self.low.max(1);
            let id = SceneId(self.low);
            self.low += 1;
            if !self.entities.contains_key(&id) && !self.retired.contains(&id) {
                return id;
            }
        }
    }
}

/// Objects whose name, transform, parent, visibility or material an edit has set: what a project
/// writes of a source's nodes (the others come back from the source as they are).
#[derive(Resource, Debug, Default)]
pub struct EditedObjects(pub std::collections::HashSet<SceneId>);

fn index_id(mut world: DeferredWorld, ctx: HookContext) {
    let Some(&id) = world.get::<SceneId>(ctx.entity) else {
        return;
    };
    if !world.contains_resource::<SceneIndex>() {
        return;
    }
    let id = if id == SceneId::NEW {
        let fresh = world.resource_mut::<SceneIndex>().allocate();
        if let Some(mut slot) = world.get_mut::<SceneId>(ctx.entity) {
            *slot = fresh;
        }
        fresh
    } else {
        id
    };
    let mut index = world.resource_mut::<SceneIndex>();
    // An explicit id (an undone delete, a loaded project) is never given out again.
    index.next = index.next.max(id.0.saturating_add(1));
    index.entities.insert(id, ctx.entity);
}

fn unindex_id(mut world: DeferredWorld, ctx: HookContext) {
    let Some(&id) = world.get::<SceneId>(ctx.entity) else {
        return;
    };
    if let Some(mut index) = world.get_resource_mut::<SceneIndex>()
        && index.entities.get(&id) == Some(&ctx.entity)
    {
        index.entities.remove(&id);
        index.retired.insert(id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_objects_get_fresh_ids_and_explicit_ids_are_kept() {
        let mut world = World::new();
        world.init_resource::<SceneIndex>();
        let a = world.spawn(SceneId::NEW).id();
        let b = world.spawn(SceneId(10)).id();
        let c = world.spawn(SceneId::NEW).id();
        let id = |w: &World, e| *w.get::<SceneId>(e).unwrap();
        assert_eq!(id(&world, a), SceneId(1));
        assert_eq!(id(&world, c), SceneId(11));
        let index = world.resource::<SceneIndex>();
        assert_eq!(index.entity(SceneId(10)), Some(b));
        assert_eq!(index.len(), 3);
        world.despawn(b);
        assert_eq!(world.resource::<SceneIndex>().entity(SceneId(10)), None);
        // Its id comes back with it.
        let b2 = world.spawn(SceneId(10)).id();
        assert_eq!(world.resource::<SceneIndex>().entity(SceneId(10)), Some(b2));
    }
}
