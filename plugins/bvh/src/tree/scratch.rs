//! Working memory the builders and passes keep in the tree between calls, so that their hot loops
//! allocate nothing. Only the tables live here, beside the storage; the algorithms that fill them
//! live with their builders.

use crate::Aabb;
use crate::tree::node::{NONE, NodeRef};

/// Working memory the builders and passes keep between calls, so that their hot loops allocate
/// nothing.
#[derive(Clone, Default)]
pub(crate) struct Scratch {
    /// The insertion search's stack.
    pub(crate) search: SearchScratch,
    /// Ranked candidates of an update batch.
    pub(crate) update_candidates: Vec<(f32, u32)>,
    /// Node slots of the bBVH being grafted (IncrUPB grafts thousands).
    pub(crate) graft_slots: Vec<u32>,
    /// `induced_tree`'s tables, one entry per triangle and per inner node, kept between calls and
    /// reset where they were written: a call costs its group's size, not the tree's.
    pub(crate) induced_local: Vec<u32>,
    pub(crate) induced_marked: Vec<bool>,
    /// Treelet restructuring's tables (8 KiB), made on first use (see
    /// `Bvh::with_treelet_scratch`).
    pub(crate) treelet: Option<Box<TreeletScratch>>,
}

impl Scratch {
    /// Lets every table go; each is made again, empty, at its next use.
    pub(crate) fn trim(&mut self) {
        *self = Scratch::default();
    }

    /// Heap bytes its tables hold.
    pub(crate) fn heap_bytes(&self) -> usize {
        use crate::tree::memory::vec_bytes;
        vec_bytes(&self.search.stack)
            + vec_bytes(&self.update_candidates)
            + vec_bytes(&self.graft_slots)
            + vec_bytes(&self.induced_local)
            + vec_bytes(&self.induced_marked)
            + self
                .treelet
                .as_ref()
                .map_or(0, |_| size_of::<TreeletScratch>())
    }
}

/// Reusable stack, so a search allocates nothing once warmed up.
#[derive(Clone, Default)]
pub struct SearchScratch {
    /// Deferred subtrees and their bounds; only a prefix is live, the rest is room to grow.
    pub(crate) stack: Vec<(f32, NodeRef)>,
}

/// The most subtrees a treelet gathers (the subset tables grow as 2^n, the search as 3^n).
pub(crate) const MAX_TREELET: usize = 8;
pub(crate) const SUBSETS: usize = 1 << MAX_TREELET;

/// Tables for one treelet at a time, reused so restructuring allocates nothing.
#[derive(Clone)]
pub(crate) struct TreeletScratch {
    pub(crate) leaves: [NodeRef; MAX_TREELET],
    pub(crate) leaf_box: [Aabb; MAX_TREELET],
    pub(crate) internal: [u32; MAX_TREELET],
    pub(crate) area: [f32; SUBSETS],
    pub(crate) bounds: [Aabb; SUBSETS],
    pub(crate) cost: [f32; SUBSETS],
    pub(crate) best_sum: [f32; SUBSETS],
    pub(crate) stack: [(u16, u32); MAX_TREELET * 2],
}

impl Default for TreeletScratch {
    fn default() -> Self {
        Self {
            leaves: [NodeRef::NONE; MAX_TREELET],
            leaf_box: [Aabb::EMPTY; MAX_TREELET],
            internal: [NONE; MAX_TREELET],
            area: [0.0; SUBSETS],
            bounds: [Aabb::EMPTY; SUBSETS],
            cost: [0.0; SUBSETS],
            best_sum: [0.0; SUBSETS],
            stack: [(0, NONE); MAX_TREELET * 2],
        }
    }
}
