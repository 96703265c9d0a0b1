//! The scene's hierarchy without recursion: how deep an object lies, how tall its subtree is,
//! the subtree in order, and despawning one from the leaves up. Bevy despawns a parent's
//! children and propagates transforms and visibility by recursion, so a hierarchy the user made
//! deep enough would overflow the stack: the document holds every hierarchy to
//! [`MAX_HIERARCHY_DEPTH`] levels, and walks them itself with explicit stacks.

use bevy::prelude::*;

/// The most levels an object may lie below a top-level one (a top-level object is level 1):
/// far more than any assembly has (a glTF file may nest 256), and well within what Bevy's
/// recursive propagation takes on any thread's stack.
pub const MAX_HIERARCHY_DEPTH: usize = 1024;

/// The level `e` lies at: 1 at the top, one more for each parent (walked up, bounded).
pub fn depth_of(world: &World, e: Entity) -> usize {
    let mut depth = 1;
    let mut at = e;
    while let Some(parent) = world.get::<ChildOf>(at).map(ChildOf::parent) {
        depth += 1;
        at = parent;
        // A ring cannot form through the document; this only stops a walk that would not end.
        if depth > 4 * MAX_HIERARCHY_DEPTH + 4 {
            break;
        }
    }
    depth
}

/// `e` and everything under it, parents before their children (pre-order, children in order).
pub fn subtree(world: &World, e: Entity) -> Vec<Entity> {
    let mut out = Vec::new();
    let mut stack = vec![e];
    while let Some(at) = stack.pop() {
        out.push(at);
        if let Some(children) = world.get::<Children>(at) {
            stack.extend(children.iter().rev());
        }
    }
    out
}

/// How many levels `e`'s subtree spans: 1 for an object without children.
pub fn height_of(world: &World, e: Entity) -> usize {
    let mut tallest = 0;
    let mut stack = vec![(e, 1usize)];
    while let Some((at, level)) = stack.pop() {
        tallest = tallest.max(level);
        if let Some(children) = world.get::<Children>(at) {
            stack.extend(children.iter().map(|c| (c, level + 1)));
        }
    }
    tallest
}

/// Despawns `e` and everything under it, the deepest first, so no despawn has children left to
/// take with it by recursion.
pub fn despawn_subtree(world: &mut World, e: Entity) {
    if world.get_entity(e).is_err() {
        return;
    }
    for at in subtree(world, e).into_iter().rev() {
        if let Ok(entity) = world.get_entity_mut(at) {
            entity.despawn();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain of `n` entities, each the child of the one before; returns the top.
    fn chain(world: &mut World, n: usize) -> Entity {
        let top = world.spawn_empty().id();
        let mut at = top;
        for _ in 1..n {
            at = world.spawn(ChildOf(at)).id();
        }
        top
    }

    #[test]
    fn a_chain_deeper_than_the_stack_allows_is_measured_and_despawned() {
        // Run on a small stack: recursion over this chain would overflow it.
        std::thread::Builder::new()
            .stack_size(256 << 10)
            .spawn(|| {
                let mut world = World::new();
                let count = |w: &mut World| w.query::<Entity>().iter(w).count();
                let before = count(&mut world);
                let top = chain(&mut world, 200_000);
                let bottom = *subtree(&world, top).last().unwrap();
                assert_eq!(depth_of(&world, bottom), 4 * MAX_HIERARCHY_DEPTH + 5);
                assert_eq!(height_of(&world, top), 200_000);
                let other = world.spawn_empty().id();
                despawn_subtree(&mut world, top);
                assert_eq!(count(&mut world), before + 1);
                assert!(world.get_entity(other).is_ok());
            })
            .unwrap()
            .join()
            .unwrap();
    }

    #[test]
    fn the_subtree_lists_parents_before_children_in_order() {
        let mut world = World::new();
        let a = world.spawn_empty().id();
        let b = world.spawn(ChildOf(a)).id();
        let c = world.spawn(ChildOf(b)).id();
        let d = world.spawn(ChildOf(a)).id();
        assert_eq!(subtree(&world, a), vec![a, b, c, d]);
        assert_eq!(height_of(&world, a), 3);
        assert_eq!(depth_of(&world, c), 3);
    }
}
