//! A group's triangle ids, in its mesh's order, as runs of consecutive ids where those are
//! smaller: a group filled into a fresh tree (or into the slots a removed group left) gets ids in
//! one run, 8 bytes for the whole group against 4 bytes a triangle for the list.

/// A list of triangle ids (a group's, in its mesh's order). Stored as runs of consecutive ids
/// when at most half as many runs as ids, else as the ids themselves: never more than the list.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TriangleIds {
    store: Store,
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Store {
    /// Each run's first id and the list position just past its last id (ascending, so a
    /// position's run is found by binary search).
    Runs(Vec<[u32; 2]>),
    /// The ids themselves.
    List(Vec<u32>),
}

impl Default for Store {
    fn default() -> Self {
        Store::Runs(Vec::new())
    }
}

impl TriangleIds {
    /// The ids in `ids`, in their order (which is kept, runs or not).
    pub(crate) fn new(mut ids: Vec<u32>) -> Self {
        if ids.is_empty() {
            return Self::default();
        }
        let follows = |a: u32, b: u32| a.checked_add(1) == Some(b);
        let runs = 1 + ids.windows(2).filter(|w| !follows(w[0], w[1])).count();
        if 2 * runs > ids.len() {
            ids.shrink_to_fit();
            return Self {
                store: Store::List(ids),
            };
        }
        let mut out: Vec<[u32; 2]> = Vec::with_capacity(runs);
        for (k, &id) in ids.iter().enumerate() {
            match out.last_mut() {
                Some(run) if follows(ids[k - 1], id) => run[1] += 1,
                _ => out.push([id, k as u32 + 1]),
            }
        }
        Self {
            store: Store::Runs(out),
        }
    }

    /// How many ids.
    pub fn len(&self) -> usize {
        match &self.store {
            Store::Runs(runs) => runs.last().map_or(0, |r| r[1] as usize),
            Store::List(ids) => ids.len(),
        }
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The id at position `k`.
    pub fn get(&self, k: usize) -> Option<u32> {
        match &self.store {
            Store::List(ids) => ids.get(k).copied(),
            Store::Runs(runs) => {
                let k = u32::try_from(k).ok()?;
                let i = runs.partition_point(|r| r[1] <= k);
                let run = runs.get(i)?;
                Some(run[0] + (k - runs_start(runs, i)))
            }
        }
    }

    /// The first id, if any.
    pub fn first(&self) -> Option<u32> {
        self.get(0)
    }

    /// The ids in order.
    pub fn iter(&self) -> TriangleIdsIter<'_> {
        TriangleIdsIter {
            ids: self,
            next: 0,
            end: self.len() as u32,
            run: 0,
        }
    }

    /// The ids in order, as a list.
    pub fn to_vec(&self) -> Vec<u32> {
        self.iter().collect()
    }

    /// Keeps the ids `keep` says to, in their order.
    pub(crate) fn retain(&mut self, keep: impl FnMut(&u32) -> bool) {
        *self = Self::new(self.iter().filter(keep).collect());
    }

    /// Heap bytes held (capacity).
    pub(crate) fn heap_bytes(&self) -> usize {
        match &self.store {
            Store::Runs(runs) => runs.capacity() * size_of::<[u32; 2]>(),
            Store::List(ids) => ids.capacity() * size_of::<u32>(),
        }
    }
}

/// The list position where run `i` starts.
#[inline]
fn runs_start(runs: &[[u32; 2]], i: usize) -> u32 {
    if i == 0 { 0 } else { runs[i - 1][1] }
}

/// The ids of a [`TriangleIds`] in order.
#[derive(Clone, Debug)]
pub struct TriangleIdsIter<'a> {
    ids: &'a TriangleIds,
    next: u32,
    end: u32,
    /// The run holding position `next` (runs only).
    run: usize,
}

impl Iterator for TriangleIdsIter<'_> {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        if self.next >= self.end {
            return None;
        }
        let k = self.next;
        self.next += 1;
        match &self.ids.store {
            Store::List(ids) => Some(ids[k as usize]),
            Store::Runs(runs) => {
                while runs[self.run][1] <= k {
                    self.run += 1;
                }
                Some(runs[self.run][0] + (k - runs_start(runs, self.run)))
            }
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = (self.end - self.next) as usize;
        (n, Some(n))
    }
}

impl ExactSizeIterator for TriangleIdsIter<'_> {}

impl<'a> IntoIterator for &'a TriangleIds {
    type Item = u32;
    type IntoIter = TriangleIdsIter<'a>;

    fn into_iter(self) -> TriangleIdsIter<'a> {
        self.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift), so the test needs no crate.
    fn next(state: &mut u64) -> u64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        *state
    }

    #[test]
    fn reads_back_any_list_exactly_and_never_takes_more_than_the_list() {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        for case in 0..2_000 {
            let n = (next(&mut state) % 300) as usize;
            let mut ids = Vec::with_capacity(n);
            let mut id = (next(&mut state) % 1_000) as u32;
            for _ in 0..n {
                ids.push(id);
                // Mostly the next id, sometimes a jump up or down (a reused slot).
                id = match next(&mut state) % (2 + case % 7) {
                    0 => (next(&mut state) % 5_000) as u32,
                    _ => id + 1,
                };
            }
            let stored = TriangleIds::new(ids.clone());
            assert_eq!(stored.len(), ids.len());
            assert_eq!(stored.is_empty(), ids.is_empty());
            assert_eq!(stored.to_vec(), ids);
            assert_eq!(stored.iter().len(), ids.len());
            for (k, &id) in ids.iter().enumerate() {
                assert_eq!(stored.get(k), Some(id));
            }
            assert_eq!(stored.get(ids.len()), None);
            assert_eq!(stored.first(), ids.first().copied());
            assert!(stored.heap_bytes() <= 4 * ids.len(), "{ids:?}");
            let mut kept = stored.clone();
            kept.retain(|&t| t % 3 != 0);
            let expected: Vec<u32> = ids.iter().copied().filter(|t| t % 3 != 0).collect();
            assert_eq!(kept.to_vec(), expected);
            assert_eq!(kept, TriangleIds::new(expected));
        }
    }

    #[test]
    fn a_run_of_ids_costs_one_pair() {
        let ids = TriangleIds::new((70..100_070).collect());
        assert_eq!(ids.heap_bytes(), 8);
        assert_eq!(ids.get(99_999), Some(100_069));
        let split = TriangleIds::new((0..10).chain(50..60).chain(5..15).collect());
        assert_eq!(split.heap_bytes(), 24);
        assert_eq!(split.get(10), Some(50));
        assert_eq!(split.get(20), Some(5));
        // A list that descends is no run: kept as it is.
        let down = TriangleIds::new((0..10).rev().collect());
        assert_eq!(down.heap_bytes(), 40);
        assert_eq!(down.to_vec(), (0..10).rev().collect::<Vec<_>>());
    }

    #[test]
    fn the_last_id_may_be_the_largest() {
        let ids = TriangleIds::new(vec![u32::MAX - 1, u32::MAX, 0, 1]);
        assert_eq!(ids.to_vec(), vec![u32::MAX - 1, u32::MAX, 0, 1]);
    }
}
