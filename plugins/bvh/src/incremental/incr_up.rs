//! IncrUP: the best siblings of a small batch are searched in parallel on the current tree, then
//! linked one by one (paper section 5.1).

use crate::tree::node::NodeRef;
use crate::tree::scratch::SearchScratch;
use crate::tree::triangle::validate_triangles;
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
        let ids = self.alloc_triangles(tris);
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
                    let mut s = std::mem::take(&mut self.scratch.search);
                    let x = self.find_best_sibling(&self.aabb(item), &mut s);
                    self.scratch.search = s;
                    x
                } else {
                    x
                };
                if item.is_inner() {
                    self.record(item.index());
                }
                let p = self.alloc_inner();
                self.link(item, x, p);
                linked.push(x);
            }
            self.maybe_update();
        }
        Ok(ids)
    }

    /// Pairs coherent consecutive leaves into two-leaf subtrees (section 4.4) without inserting
    /// them, then, for each further level of `cluster_levels`, coherent consecutive pairs of the
    /// level before into subtrees twice their size. Returns the items to insert, in stream order.
    pub(crate) fn cluster_items(&mut self, ids: &[u32]) -> Vec<NodeRef> {
        let mut items = Vec::with_capacity(ids.len());
        if !self.config.clustering {
            items.extend(ids.iter().map(|&t| NodeRef::leaf(t)));
            return items;
        }
        // Whether each item was made by the last level: a triangle or cluster left alone by one
        // level stays alone, as the paper leaves an incoherent triangle.
        let mut fresh = Vec::with_capacity(ids.len());
        // The first level reads the triangles' boxes straight from their corners.
        let mut i = 0;
        while i < ids.len() {
            let a = ids[i];
            if let Some(&b) = ids.get(i + 1) {
                let c =
                    crate::incremental::insert::coherence(&self.tri(a).aabb(), &self.tri(b).aabb());
                if c < self.config.coherence_max {
                    items.push(self.make_pair(NodeRef::leaf(a), NodeRef::leaf(b)));
                    fresh.push(true);
                    i += 2;
                    continue;
                }
            }
            items.push(NodeRef::leaf(a));
            fresh.push(false);
            i += 1;
        }
        for _ in 1..self.config.cluster_levels {
            // In place: the write index never passes the read index.
            let (mut r, mut w, n) = (0, 0, items.len());
            while r < n {
                let a = items[r];
                if fresh[r] && r + 1 < n && fresh[r + 1] {
                    let b = items[r + 1];
                    let c = crate::incremental::insert::coherence(&self.aabb(a), &self.aabb(b));
                    if c < self.config.coherence_max {
                        items[w] = self.make_pair(a, b);
                        fresh[w] = true;
                        (r, w) = (r + 2, w + 1);
                        continue;
                    }
                }
                items[w] = a;
                fresh[w] = false;
                (r, w) = (r + 1, w + 1);
            }
            items.truncate(w);
            fresh.truncate(w);
            if w == n {
                break;
            }
        }
        items
    }
}

#[cfg(test)]
mod tests {
    use crate::{Bvh, BvhConfig, Triangle};
    use glam::Vec3;

    /// A strip of unit triangles along x, with one far away after the sixth.
    fn strip() -> Vec<Triangle> {
        let mut tris: Vec<Triangle> = (0..9)
            .map(|i| {
                let x = i as f32;
                Triangle::new(
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x + 1.0, 0.0, 0.0),
                    Vec3::new(x, 1.0, 0.0),
                )
            })
            .collect();
        tris[6] = Triangle::new(
            Vec3::splat(100.0),
            Vec3::new(101.0, 100.0, 100.0),
            Vec3::new(100.0, 101.0, 100.0),
        );
        tris
    }

    fn clusters(levels: u32) -> Vec<Vec<u32>> {
        let mut bvh = Bvh::new(BvhConfig {
            cluster_levels: levels,
            ..BvhConfig::incr()
        });
        let ids = bvh.alloc_triangles(&strip());
        let items = bvh.cluster_items(&ids);
        items.iter().map(|&r| bvh.leaves_under(r)).collect()
    }

    #[test]
    fn each_cluster_level_pairs_the_coherent_clusters_of_the_level_before() {
        // Neighbours along the strip are coherent (flat boxes side by side, and so are two pairs
        // side by side: R_coh = 1); triangle 6 is coherent with nothing, so 7 and 8 pair alone.
        let pairs = clusters(1);
        assert_eq!(
            pairs,
            [vec![0, 1], vec![2, 3], vec![4, 5], vec![6], vec![7, 8]]
        );
        assert_eq!(clusters(0), pairs, "0 counts as 1");
        let quads = clusters(2);
        assert_eq!(quads, [vec![0, 1, 2, 3], vec![4, 5], vec![6], vec![7, 8]]);
        // A pair left alone by one level stays alone; nothing more is coherent here.
        assert_eq!(clusters(3), quads);
    }
}
