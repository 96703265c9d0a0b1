//! IncrUP: the best siblings of a small batch are searched in parallel on the current tree, then
//! linked one by one (paper section 5.1).

use crate::node::{NONE, NodeRef};
use crate::search::SearchScratch;
use crate::triangle::validate_triangles;
use crate::{Bvh, BvhError, Triangle};
use rayon::prelude::*;
use std::cell::RefCell;

thread_local! {
    static SCRATCH: RefCell<SearchScratch> = RefCell::new(SearchScratch::default());
}

impl Bvh {
    /// Inserts world-space triangles with parallel search (IncrUP). Same result contract as
    /// [`Bvh::insert_triangles`]; the tree differs only where searches of one batch interact.
    pub fn insert_triangles_parallel_search(
        &mut self,
        tris: &[Triangle],
    ) -> Result<Vec<u32>, BvhError> {
        validate_triangles(tris)?;
        self.check_room(tris.len())?;
        self.reserve(tris.len());
        let ids: Vec<u32> = tris.iter().map(|t| self.alloc_triangle(*t, NONE)).collect();
        let items = self.cluster_items(&ids);
        let batch = self.config.parallel_search_batch.max(1) as usize;
        let mut targets: Vec<NodeRef> = Vec::with_capacity(batch);
        let mut linked: Vec<NodeRef> = Vec::with_capacity(batch);
        let mut rest = &items[..];
        while !rest.is_empty() {
            if self.root.is_none() {
                self.insert_item(rest[0]);
                rest = &rest[1..];
                continue;
            }
            let (chunk, tail) = rest.split_at(batch.min(rest.len()));
            rest = tail;
            let this = &*self;
            let search = |&item| {
                SCRATCH.with(|s| this.find_best_sibling(&this.aabb(item), &mut s.borrow_mut()))
            };
            if rayon::current_num_threads() > 1 {
                chunk.par_iter().map(search).collect_into_vec(&mut targets);
            } else {
                // The same searches on the same tree, without handing each small batch to the
                // pool: with no second thread that hand-over is all it would add.
                targets.clear();
                targets.extend(chunk.iter().map(search));
            }
            linked.clear();
            for (&item, &x) in chunk.iter().zip(&targets) {
                // A target an earlier item of this batch was linked to has a new parent and a new
                // sibling: its search result is stale, so search again on the tree as it is now.
                let x = if linked.contains(&x) {
                    let mut s = std::mem::take(&mut self.scratch);
                    let x = self.find_best_sibling(&self.aabb(item), &mut s);
                    self.scratch = s;
                    x
                } else {
                    x
                };
                if item.is_inner() {
                    self.record(item.index());
                }
                let p = self.alloc_inner();
                self.link(item, x, p);
                self.rotate_after_insertion(item);
                linked.push(x);
            }
            self.maybe_update();
        }
        Ok(ids)
    }

    /// Pairs coherent consecutive leaves into two-leaf subtrees (section 4.4) without inserting them.
    pub(crate) fn cluster_items(&mut self, ids: &[u32]) -> Vec<NodeRef> {
        let mut items = Vec::with_capacity(ids.len());
        let mut i = 0;
        while i < ids.len() {
            let a = ids[i];
            if self.config.clustering && i + 1 < ids.len() {
                let b = ids[i + 1];
                let c =
                    crate::insert::coherence(&self.tri_box[a as usize], &self.tri_box[b as usize]);
                if c < self.config.coherence_max {
                    items.push(self.make_pair(NodeRef::leaf(a), NodeRef::leaf(b)));
                    i += 2;
                    continue;
                }
            }
            items.push(NodeRef::leaf(a));
            i += 1;
        }
        items
    }
}
