//! Each grouped triangle's corners, by triangle id, in 6 bytes where its group has at most 65,536
//! vertices: a mesh's groups nearly always do (a mesh over 262,144 triangles enters in pieces),
//! so the indices' high halves are kept apart, only as far as the highest id that needs them.

/// The corners of grouped triangles by id: indices into their group's vertices
/// (a group's vertices), split into 16-bit halves.
#[derive(Clone, Default)]
pub(crate) struct Corners {
    /// Each id's corners, their low 16 bits.
    low: Vec<[u16; 3]>,
    /// Their high 16 bits, grown only as far as the highest id whose corners have any (a group of
    /// more than 65,536 vertices); an id past its end has none.
    high: Vec<[u16; 3]>,
    /// Entries of `high` not all zero: once none is, `high` goes at the next trim.
    wide: usize,
}

impl Corners {
    /// Ids with a slot (written or not).
    pub(crate) fn len(&self) -> usize {
        self.low.len()
    }

    /// Whether no id has a slot.
    pub(crate) fn is_empty(&self) -> bool {
        self.low.is_empty()
    }

    /// Triangle `id`'s corners. `id` must have a slot.
    #[inline]
    pub(crate) fn get(&self, id: usize) -> [u32; 3] {
        let low = self.low[id];
        match self.high.get(id) {
            Some(high) => [0, 1, 2].map(|k| u32::from(low[k]) | u32::from(high[k]) << 16),
            None => low.map(u32::from),
        }
    }

    /// Triangle `id`'s corners, if it has a slot.
    pub(crate) fn checked(&self, id: usize) -> Option<[u32; 3]> {
        (id < self.low.len()).then(|| self.get(id))
    }

    /// Writes triangle `id`'s corners, growing the slots past `id` if need be.
    #[inline]
    pub(crate) fn set(&mut self, id: usize, corners: [u32; 3]) {
        if self.low.len() <= id {
            self.low.resize(id + 1, [0; 3]);
        }
        self.low[id] = corners.map(|i| i as u16);
        let high = corners.map(|i| (i >> 16) as u16);
        if high != [0; 3] && self.high.len() <= id {
            self.high.resize(id + 1, [0; 3]);
        }
        if let Some(slot) = self.high.get_mut(id) {
            let (was, is) = (*slot != [0; 3], high != [0; 3]);
            self.wide = self.wide + usize::from(is) - usize::from(was);
            *slot = high;
        }
    }

    /// Makes room for slots up to `len` ids, so that growing to it copies nothing.
    pub(crate) fn reserve_to(&mut self, len: usize) {
        self.low.reserve(len.saturating_sub(self.low.len()));
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        (self.low.capacity() + self.high.capacity()) * size_of::<[u16; 3]>()
    }

    /// Bytes held beyond what the corners need: the arrays' room to grow, and the high halves
    /// past the last id that has any (all of them once none has).
    pub(crate) fn spare_bytes(&self) -> usize {
        let kept = self.low.len() + self.high_kept();
        self.heap_bytes() - kept * size_of::<[u16; 3]>()
    }

    /// Gives back what [`Corners::spare_bytes`] counts.
    pub(crate) fn trim(&mut self) {
        self.low.shrink_to_fit();
        self.high.truncate(self.high_kept());
        self.high.shrink_to_fit();
    }

    /// How many entries of `high` are needed: up to the last not all zero.
    fn high_kept(&self) -> usize {
        if self.wide == 0 {
            return 0;
        }
        self.high
            .iter()
            .rposition(|h| *h != [0; 3])
            .map_or(0, |i| i + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_read_back_as_written_in_either_width() {
        let mut c = Corners::default();
        c.set(3, [1, 2, 65_535]);
        assert_eq!(c.len(), 4);
        assert_eq!(c.get(3), [1, 2, 65_535]);
        assert_eq!(c.get(0), [0, 0, 0]);
        // A narrow tree keeps no high halves.
        assert_eq!(c.heap_bytes(), c.low.capacity() * 6);
        c.set(1, [65_536, 7, u32::MAX]);
        assert_eq!(c.get(1), [65_536, 7, u32::MAX]);
        assert_eq!(c.get(3), [1, 2, 65_535]);
        assert_eq!(c.checked(9), None);
        assert_eq!(c.checked(1), Some([65_536, 7, u32::MAX]));
        // Rewritten narrow, the high halves are spare and go at the trim.
        c.set(1, [4, 5, 6]);
        assert_eq!(c.get(1), [4, 5, 6]);
        assert_eq!(c.spare_bytes(), c.heap_bytes() - 4 * 6);
        c.trim();
        assert_eq!(c.spare_bytes(), 0);
        assert_eq!(c.heap_bytes(), 4 * 6);
        assert_eq!((c.get(1), c.get(3)), ([4, 5, 6], [1, 2, 65_535]));
    }

    #[test]
    fn the_trim_keeps_high_halves_up_to_the_last_wide_id() {
        let mut c = Corners::default();
        for id in 0..10 {
            c.set(id, [id as u32; 3]);
        }
        c.set(2, [70_000, 0, 0]);
        c.set(6, [0, 0, 1 << 20]);
        c.set(6, [0, 0, 1]);
        c.trim();
        assert_eq!(c.high.len(), 3);
        assert_eq!(c.get(2), [70_000, 0, 0]);
        assert_eq!(c.get(6), [0, 0, 1]);
        assert_eq!(c.get(9), [9; 3]);
        assert_eq!(c.spare_bytes(), 0);
    }
}
