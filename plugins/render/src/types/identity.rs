//! Which slot the views know each object by. A view records, per pixel, the object slot of its
//! first sample's hit (for outlines, the denoiser and temporal reuse). When the scene re-lays a
//! group without restarting the views (a rebuild that changes no hit), the pixels still hold the
//! slot of the group it replaced: the new group is known by that slot until the views restart.

use std::collections::HashMap;

/// Groups known by a slot other than their own, by their own slot.
#[derive(Default, Debug)]
pub(crate) struct SlotIdentities {
    borrowed: HashMap<u32, u32>,
}

impl SlotIdentities {
    /// The slot the views know the group in `slot` by.
    pub(crate) fn of(&self, slot: u32) -> u32 {
        self.borrowed.get(&slot).copied().unwrap_or(slot)
    }

    /// The slot the group in `slot` is known by, where it is not its own.
    pub(crate) fn borrowed(&self, slot: u32) -> Option<u32> {
        self.borrowed.get(&slot).copied()
    }

    /// The group in `new` replaced the one in `old` while the views went on: it is known as that
    /// one was.
    pub(crate) fn relaid(&mut self, new: u32, old: u32) {
        let identity = self.of(old);
        self.borrowed.remove(&old);
        if identity == new {
            self.borrowed.remove(&new);
        } else {
            self.borrowed.insert(new, identity);
        }
    }

    /// The views restart: every pixel records its own hit's slot again.
    pub(crate) fn restart(&mut self) {
        self.borrowed.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_group_relaid_twice_keeps_the_first_slot_until_the_views_restart() {
        let mut ids = SlotIdentities::default();
        assert_eq!(ids.of(3), 3);
        ids.relaid(5, 3);
        assert_eq!((ids.of(5), ids.borrowed(5)), (3, Some(3)));
        // The slot it left is free: nothing is known by it but the group in 5.
        assert_eq!(ids.borrowed(3), None);
        ids.relaid(8, 5);
        assert_eq!((ids.of(8), ids.borrowed(5)), (3, None));
        // Re-laid back into the slot it is known by: its own again.
        ids.relaid(3, 8);
        assert_eq!(
            (ids.of(3), ids.borrowed(3), ids.borrowed(8)),
            (3, None, None)
        );
        ids.relaid(9, 3);
        ids.restart();
        assert_eq!(ids.of(9), 9);
    }
}
