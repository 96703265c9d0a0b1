//! Runs of records in one GPU buffer shared by many owners (a mesh's shading vertices, a group's
//! positions): the best-fitting free run is taken first (the smallest that holds the request, the
//! lowest of those), freed neighbours merge, and a free run at the end shortens the buffer, so the
//! records in use stay near what the live owners hold after edits.

use std::collections::{BTreeMap, BTreeSet};

/// Free runs and the end of the pool, in records.
#[derive(Clone, Debug)]
pub struct RunAllocator {
    /// Free runs by start, with their lengths.
    by_start: BTreeMap<u32, u32>,
    /// The same runs by (length, start).
    by_len: BTreeSet<(u32, u32)>,
    /// One past the last record any run in use or free covers.
    end: u32,
    /// The records no run may reach past (what the pool's readers can name).
    limit: u32,
}

impl Default for RunAllocator {
    /// A pool whose runs may reach `u32::MAX` records.
    fn default() -> Self {
        Self::with_limit(u32::MAX)
    }
}

impl RunAllocator {
    /// An empty pool whose runs never reach past `limit` records (a record number its readers
    /// cannot name is never handed out).
    pub fn with_limit(limit: u32) -> Self {
        Self {
            by_start: BTreeMap::new(),
            by_len: BTreeSet::new(),
            end: 0,
            limit,
        }
    }

    /// The start of a run of `len` records (a free one that holds it, or new ones at the end);
    /// `None` when the run would reach past the pool's limit.
    pub fn allocate(&mut self, len: u32) -> Option<u32> {
        if len == 0 {
            return Some(0);
        }
        if let Some(&(free, start)) = self.by_len.range((len, 0)..).next() {
            self.by_len.remove(&(free, start));
            self.by_start.remove(&start);
            if free > len {
                self.insert_free(start + len, free - len);
            }
            return Some(start);
        }
        let start = self.end;
        self.end = self.end.checked_add(len).filter(|&end| end <= self.limit)?;
        Some(start)
    }

    /// Gives back the run of `len` records at `start` (one [`RunAllocator::allocate`] gave).
    pub fn free(&mut self, start: u32, len: u32) {
        if len == 0 {
            return;
        }
        let (mut start, mut len) = (start, len);
        if let Some((&before, &l)) = self.by_start.range(..start).next_back()
            && before + l == start
        {
            self.remove_free(before, l);
            start = before;
            len += l;
        }
        if let Some(&l) = self.by_start.get(&(start + len)) {
            self.remove_free(start + len, l);
            len += l;
        }
        if start + len == self.end {
            self.end = start;
        } else {
            self.insert_free(start, len);
        }
    }

    /// Records the runs reach: the pool's length.
    pub fn end(&self) -> u32 {
        self.end
    }

    /// Free records below the end.
    pub fn free_records(&self) -> u64 {
        self.by_start.values().map(|&l| u64::from(l)).sum()
    }

    /// Bytes of the free runs' maps on the heap (by entry: a B-tree's nodes hold about this).
    pub fn heap_bytes(&self) -> usize {
        self.by_start.len() * 2 * size_of::<(u32, u32)>()
    }

    fn insert_free(&mut self, start: u32, len: u32) {
        self.by_start.insert(start, len);
        self.by_len.insert((len, start));
    }

    fn remove_free(&mut self, start: u32, len: u32) {
        self.by_start.remove(&start);
        self.by_len.remove(&(len, start));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pseudo-random numbers below the bound each call gives, from `seed` (a 64-bit LCG).
    fn numbers(mut seed: u64) -> impl FnMut(u64) -> u64 {
        move |n| {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 33) % n
        }
    }

    #[test]
    fn runs_never_overlap_and_the_pool_shrinks_back() {
        // Random allocations and frees, checked against a map of every record's owner.
        let mut next = numbers(3);
        let mut pool = RunAllocator::default();
        let mut live: Vec<(u32, u32)> = Vec::new();
        for step in 0..4000 {
            if live.is_empty() || next(3) > 0 {
                let len = 1 + next(if step % 7 == 0 { 500 } else { 40 }) as u32;
                let start = pool.allocate(len).unwrap();
                live.push((start, len));
            } else {
                let k = next(live.len() as u64) as usize;
                let (start, len) = live.swap_remove(k);
                pool.free(start, len);
            }
            let mut owner = vec![usize::MAX; pool.end() as usize];
            for (k, &(start, len)) in live.iter().enumerate() {
                for r in start..start + len {
                    assert_eq!(owner[r as usize], usize::MAX, "record {r} given twice");
                    owner[r as usize] = k;
                }
            }
            let used: u64 = live.iter().map(|&(_, l)| u64::from(l)).sum();
            assert_eq!(used + pool.free_records(), u64::from(pool.end()));
            if let Some(last) = live.iter().map(|&(s, l)| s + l).max() {
                assert_eq!(pool.end(), last, "a free run at the end is given back");
            }
        }
        for (start, len) in live.drain(..) {
            pool.free(start, len);
        }
        assert_eq!((pool.end(), pool.free_records()), (0, 0));
    }

    #[test]
    fn the_smallest_free_run_that_fits_is_taken() {
        let mut pool = RunAllocator::default();
        let runs: Vec<u32> = [10, 1, 4, 1, 6, 1]
            .iter()
            .map(|&l| pool.allocate(l).unwrap())
            .collect();
        pool.free(runs[0], 10);
        pool.free(runs[2], 4);
        pool.free(runs[4], 6);
        assert_eq!(pool.allocate(5), Some(runs[4]), "the six, not the ten");
        assert_eq!(pool.allocate(4), Some(runs[2]));
        assert_eq!(pool.allocate(u32::MAX), None, "past u32");
    }

    #[test]
    fn no_run_reaches_past_the_limit() {
        let mut pool = RunAllocator::with_limit(10);
        let a = pool.allocate(6).unwrap();
        assert_eq!(pool.allocate(5), None, "6 + 5 records pass 10");
        assert_eq!(pool.end(), 6, "a refused run leaves the pool as it was");
        assert_eq!(pool.allocate(4), Some(6), "up to the limit exactly");
        pool.free(a, 6);
        assert_eq!(
            pool.allocate(6),
            Some(0),
            "a free run below the limit is taken"
        );
        assert_eq!(pool.allocate(1), None);
    }
}
