//! One bit a slot: the flags kept beside the tree's arrays (which nodes the update cache holds,
//! which records changed, which nodes a record layout's update names) cost a bit where a `bool`
//! cost a byte, a few bytes a triangle in all.
//! Written here rather than taken from a bitset crate for the room kept to grow and given back
//! ([`Flags::reserve_to`], [`Flags::shrink_to_fit`]), which the tree's figures and trim count.

use std::ops::Range;

/// A growable array of bits, all `false` when grown.
#[derive(Clone, Default, Debug)]
pub(crate) struct Flags {
    words: Vec<u64>,
    len: usize,
}

impl Flags {
    /// Number of flags.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Flag `i`; `false` past the end.
    #[inline]
    pub(crate) fn get(&self, i: usize) -> bool {
        i < self.len && self.words[i / 64] >> (i % 64) & 1 == 1
    }

    /// Sets flag `i` to `value` and returns what it was. `i` must be below [`Flags::len`].
    #[inline]
    pub(crate) fn replace(&mut self, i: usize, value: bool) -> bool {
        assert!(i < self.len, "flag {i} of {}", self.len);
        let (word, bit) = (&mut self.words[i / 64], 1u64 << (i % 64));
        let was = *word & bit != 0;
        if value {
            *word |= bit;
        } else {
            *word &= !bit;
        }
        was
    }

    /// Sets flag `i` to `value`. `i` must be below [`Flags::len`].
    #[inline]
    pub(crate) fn set(&mut self, i: usize, value: bool) {
        self.replace(i, value);
    }

    /// Sets the flags in `range` (below [`Flags::len`]) to `true`.
    pub(crate) fn set_range(&mut self, range: Range<usize>) {
        assert!(range.end <= self.len, "flags {range:?} of {}", self.len);
        for i in range {
            self.words[i / 64] |= 1u64 << (i % 64);
        }
    }

    /// Grows or shrinks to `len` flags, those added set to `value`.
    pub(crate) fn resize(&mut self, len: usize, value: bool) {
        let old = self.len;
        if len < old {
            self.words.truncate(len.div_ceil(64));
            if !len.is_multiple_of(64) {
                // Bits past the end stay clear, so that growing again adds `false`s.
                self.words[len / 64] &= (1u64 << (len % 64)) - 1;
            }
            self.len = len;
            return;
        }
        self.words.resize(len.div_ceil(64), 0);
        self.len = len;
        if value {
            self.set_range(old..len);
        }
    }

    /// Appends one flag.
    pub(crate) fn push(&mut self, value: bool) {
        self.resize(self.len + 1, value);
    }

    /// Makes room for flags up to `len`, so that growing to it copies nothing.
    pub(crate) fn reserve_to(&mut self, len: usize) {
        self.words
            .reserve(len.div_ceil(64).saturating_sub(self.words.len()));
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.words.capacity() * size_of::<u64>()
    }

    /// Heap bytes held beyond the flags' length.
    pub(crate) fn spare_bytes(&self) -> usize {
        (self.words.capacity() - self.words.len()) * size_of::<u64>()
    }

    /// Gives back the room counted by [`Flags::spare_bytes`].
    pub(crate) fn shrink_to_fit(&mut self) {
        self.words.shrink_to_fit();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_behave_as_a_vector_of_bools() {
        // Against a Vec<bool> through pushes, resizes both ways, ranges and single writes that
        // cross word boundaries.
        let (mut f, mut v) = (Flags::default(), Vec::<bool>::new());
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for step in 0..4000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            match x % 6 {
                0 => {
                    let len = (x >> 8) as usize % 300;
                    let value = x & 256 != 0;
                    f.resize(len, value);
                    v.resize(len, value);
                }
                1 => {
                    f.push(x & 512 != 0);
                    v.push(x & 512 != 0);
                }
                2 if !v.is_empty() => {
                    let a = (x >> 8) as usize % v.len();
                    let b = a + (x >> 20) as usize % (v.len() - a + 1);
                    f.set_range(a..b);
                    v[a..b].fill(true);
                }
                _ if !v.is_empty() => {
                    let i = (x >> 8) as usize % v.len();
                    let value = x & 1024 != 0;
                    assert_eq!(f.replace(i, value), v[i], "step {step}");
                    v[i] = value;
                }
                _ => {}
            }
            assert_eq!(f.len(), v.len());
            for (i, &b) in v.iter().enumerate() {
                assert_eq!(f.get(i), b, "step {step}, flag {i}");
            }
            assert!(!f.get(v.len()));
        }
    }

    #[test]
    fn room_is_counted_and_given_back() {
        let mut f = Flags::default();
        f.reserve_to(10_000);
        assert!(f.heap_bytes() >= 10_000 / 8);
        f.resize(100, true);
        assert_eq!(f.spare_bytes(), f.heap_bytes() - 2 * 8);
        f.shrink_to_fit();
        assert_eq!((f.heap_bytes(), f.spare_bytes()), (16, 0));
        assert!(f.get(99) && !f.get(100));
    }
}
