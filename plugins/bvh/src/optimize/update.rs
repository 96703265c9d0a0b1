//! Global updates: remove an inefficient node and re-insert its two children at better places,
//! driven by the node update cache (paper section 4.3); the moves and rankings the post-pass and the
//! idle steps share.

use crate::tree::node::{NONE, NodeKind, NodeRef};
use crate::{Bvh, Inefficiency};

/// Runs `$body` with `$m` bound to the measure `$kind` names, as a closure with that kind fixed:
/// ranking loops are generic over the closure, so the measure is chosen once per ranking instead
/// of once per node.
macro_rules! with_measure {
    ($kind:expr, $m:ident => $body:expr) => {{
        use $crate::Inefficiency as Kind;
        use $crate::optimize::update::measure;
        match $kind {
            Kind::Comb => {
                let $m = |a, l, r| measure(Kind::Comb, a, l, r);
                $body
            }
            Kind::Area => {
                let $m = |a, l, r| measure(Kind::Area, a, l, r);
                $body
            }
            Kind::Sum => {
                let $m = |a, l, r| measure(Kind::Sum, a, l, r);
                $body
            }
            Kind::Min => {
                let $m = |a, l, r| measure(Kind::Min, a, l, r);
                $body
            }
        }
    }};
}
pub(crate) use with_measure;

impl Bvh {
    /// Inefficiency of inner node `i` by the configured measure.
    pub fn inefficiency(&self, i: u32) -> f32 {
        let n = &self.inner[i as usize];
        let (l, r) = (
            self.stored_area(n.children[0]),
            self.stored_area(n.children[1]),
        );
        measure(self.config.inefficiency, n.aabb.stored_area(), l, r)
    }

    /// The nodes of `cache` that may be updated, each with its inefficiency, into `out`. Update
    /// batches rank every cached node (IncrUPB caches every bBVH node), so the measure is chosen
    /// once per batch rather than once per node.
    fn rank_cached(&self, cache: &[u32], out: &mut Vec<(f32, u32)>) {
        with_measure!(self.config.inefficiency, m => self.rank_by(cache, out, m));
    }

    #[inline(always)]
    fn rank_by(&self, cache: &[u32], out: &mut Vec<(f32, u32)>, m: impl Fn(f32, f32, f32) -> f32) {
        let flat = !self.has_live_instances();
        for &i in cache {
            let n = &self.inner[i as usize];
            // Without instances a live node with a parent is in the global tree (see
            // `in_global_tree`): no call per node.
            let movable = if flat {
                n.has_parent()
            } else {
                self.updatable(i)
            };
            if movable {
                let (l, r) = (
                    self.stored_area(n.children[0]),
                    self.stored_area(n.children[1]),
                );
                out.push((m(n.aabb.stored_area(), l, r), i));
            }
        }
    }

    /// Area of any node's box, read in vector lanes where the box lies in a node array.
    #[inline]
    pub(crate) fn stored_area(&self, r: NodeRef) -> f32 {
        match r.kind() {
            NodeKind::Inner => self.inner[r.index() as usize].aabb.stored_area(),
            NodeKind::Leaf => self.tri(r.index()).aabb().area(),
            _ => self.aabb(r).area(),
        }
    }

    /// Runs a batch of updates if the node update cache holds N_u nodes (at the end of a
    /// [`Bvh::batch`] when inside one).
    pub(crate) fn maybe_update(&mut self) {
        if self.config.global_updates
            && !self.cache.deferred
            && self.cache.nodes.len() >= self.config.update_cache_size as usize
        {
            self.run_update_batch();
        }
    }

    /// Makes edits whose update batches are left to a later, sliced optimisation (the worker's
    /// `IdleWork` steps): the nodes they touch leave the update cache. For edits whose batch would
    /// hold the tree too long in one piece, such as baking a mesh of a million triangles, whose
    /// every node enters the cache.
    pub fn without_updates<R>(&mut self, edits: impl FnOnce(&mut Self) -> R) -> R {
        let outer = self.cache.deferred;
        let kept = self.cache.nodes.len();
        self.cache.deferred = true;
        let r = edits(self);
        self.cache.deferred = outer;
        for i in self.cache.nodes.drain(kept..) {
            self.cache.queued.set(i as usize, false);
        }
        r
    }

    /// Runs `relay` as a re-laying of what the tree holds, not an edit: a group baked into the tree
    /// or rebuilt by another builder, every ray meeting the same closest hit before and after. The
    /// triangles and instances it writes are still in the change set (their records move), but they
    /// do not make it [`crate::ChangeSet::geometry_changed`]. The caller vouches for that.
    pub fn keeping_geometry<R>(&mut self, relay: impl FnOnce(&mut Self) -> R) -> R {
        self.changes.keeping += 1;
        let r = relay(self);
        self.changes.keeping -= 1;
        r
    }

    /// Makes several edits as one: the update batches they would trigger run once, after the last.
    /// For edits of one object made of several groups (a mesh inserted in chunks), whose first
    /// edits would otherwise pay for updating parts of the tree the next ones replace.
    pub fn batch<R>(&mut self, edits: impl FnOnce(&mut Self) -> R) -> R {
        let outer = self.cache.deferred;
        self.cache.deferred = true;
        let r = edits(self);
        self.cache.deferred = outer;
        self.maybe_update();
        r
    }

    /// Updates the k_u fraction of the cached nodes with the highest inefficiency, then empties the cache.
    pub fn run_update_batch(&mut self) {
        // Both buffers go back with their capacity: batches run every few insertions.
        let mut cache = std::mem::take(&mut self.cache.nodes);
        let mut candidates = std::mem::take(&mut self.scratch.update_candidates);
        candidates.clear();
        // Freed nodes left the cache (their flag is down); a slot freed and recorded again has
        // two entries: the first is kept. All flags are down after.
        let queued = &mut self.cache.queued;
        cache.retain(|&i| queued.replace(i as usize, false));
        self.rank_cached(&cache, &mut candidates);
        let k = share(self.config.update_fraction, candidates.len());
        worst_first(&mut candidates, k);
        self.reinsert_each(&candidates[..k], Move::Children);
        cache.clear();
        self.cache.nodes = cache;
        self.scratch.update_candidates = candidates;
    }

    /// Moves each node of `nodes` that is still updatable (an earlier move in the same batch may
    /// have made it the root), with recording off: the moves must not queue further updates.
    /// Returns the moves made.
    pub(crate) fn reinsert_each(&mut self, nodes: &[(f32, u32)], kind: Move) -> u32 {
        let recording = std::mem::replace(&mut self.cache.recording, false);
        let mut moves = 0;
        for &(_, i) in nodes {
            if self.updatable(i) {
                match kind {
                    Move::Children => self.reinsert_children(i),
                    Move::Subtree => self.reinsert_subtree(i),
                };
                moves += 1;
            }
        }
        self.cache.recording = recording;
        moves
    }

    /// Whether inner node `i` may be updated: live, in the global tree, not the root.
    fn updatable(&self, i: u32) -> bool {
        let n = &self.inner[i as usize];
        n.has_parent() && self.in_global_tree(i)
    }

    /// Removes inner node `n` and its parent, then inserts `n`'s two children separately with the
    /// search, reusing the two freed inner nodes for them. With `keep_only_improving`, a move that
    /// raises the total inner area is undone. Returns whether the move was kept.
    pub(crate) fn reinsert_children(&mut self, n: u32) -> bool {
        let [a, b] = self.inner[n as usize].children;
        let old_area = self.inner[n as usize].aabb.area() as f64;
        let sibling = self.sibling(NodeRef::inner(n));
        let before = self.area_acc;
        let p = self.unlink(NodeRef::inner(n));
        debug_assert_ne!(p, NONE);
        self.set_parent(a, NONE);
        self.set_parent(b, NONE);
        // `n` has left the tree; `area_acc` tracks the tree's inner area, which the post-pass reads.
        self.area_acc -= old_area;
        // The larger child first: it constrains the best position of the smaller one.
        let (first, second) = if self.aabb(a).area() >= self.aabb(b).area() {
            (a, b)
        } else {
            (b, a)
        };
        // Seeded with the old arrangement: the first child next to `n`'s old sibling, the second
        // next to the first, which is where they were. The first link makes the node over the
        // first child and the old sibling, `p`'s old role, and the second the node over both
        // children, `n`'s: so a move that puts them back leaves every slot holding what it held.
        // With the slots the other way round, a ranked list made before the round would name
        // `n`'s children twice (once as `n`, once as `p`) and `p`'s never.
        self.insert_node_from(first, p, sibling);
        self.insert_node_from(second, n, first);
        self.update_ops += 1;
        let delta = self.area_acc - before;
        if !self.config.keep_only_improving || delta <= 0.0 {
            return true;
        }
        // Undo: take both out again, which frees the two slots the links used (`n` and `p`,
        // whichever each went to), and put `n` back over them, under `p`, next to its old sibling.
        self.unlink(second);
        self.unlink(first);
        self.set_pair(n, a, b);
        self.area_acc += self.inner[n as usize].aabb.area() as f64;
        self.link(NodeRef::inner(n), sibling, p);
        false
    }

    /// Moves the subtree under `n` to its best position (Meister and Bittner's re-insertion): a
    /// different move from [`Bvh::reinsert_children`], and one that escapes its local minima.
    /// Undone like it when it raises the cost. Returns whether the move was kept.
    pub(crate) fn reinsert_subtree(&mut self, n: u32) -> bool {
        let sibling = self.sibling(NodeRef::inner(n));
        let before = self.area_acc;
        let p = self.unlink(NodeRef::inner(n));
        debug_assert_ne!(p, NONE);
        self.insert_node_from(NodeRef::inner(n), p, sibling);
        self.update_ops += 1;
        if !self.config.keep_only_improving || self.area_acc - before <= 0.0 {
            return true;
        }
        let p = self.unlink(NodeRef::inner(n));
        self.link(NodeRef::inner(n), sibling, p);
        false
    }

    /// The other child of `n`'s parent. `n` must not be the root.
    fn sibling(&self, n: NodeRef) -> NodeRef {
        let [a, b] = self.inner[self.parent(n) as usize].children;
        if a == n { b } else { a }
    }
}

/// Which re-insertion a global update makes.
#[derive(Clone, Copy)]
pub(crate) enum Move {
    /// Remove the node and its parent, re-insert its two children.
    Children,
    /// Re-insert the node's whole subtree.
    Subtree,
}

impl Move {
    /// Children in even rounds (or sweeps), subtrees in odd ones.
    pub(crate) fn alternating(round: u32) -> Self {
        if round.is_multiple_of(2) {
            Move::Children
        } else {
            Move::Subtree
        }
    }
}

/// How many of `len` candidates `fraction` selects: rounded up, at most all, none for a negative or
/// NaN fraction.
pub(crate) fn share(fraction: f32, len: usize) -> usize {
    ((fraction * len as f32).ceil() as usize).min(len)
}

/// Inefficiency `kind` of a node of area `a` whose children have areas `l` and `r`.
#[inline(always)]
pub(crate) fn measure(kind: Inefficiency, a: f32, l: f32, r: f32) -> f32 {
    let m_sum = || a / (0.5 * (l + r)).max(f32::MIN_POSITIVE);
    let m_min = || a / l.min(r).max(f32::MIN_POSITIVE);
    match kind {
        Inefficiency::Area => a,
        Inefficiency::Sum => m_sum(),
        Inefficiency::Min => m_min(),
        Inefficiency::Comb => m_sum() * m_min() * a,
    }
}

/// Moves the `k` most inefficient candidates to the front, in no particular order.
pub(crate) fn worst_first(candidates: &mut [(f32, u32)], k: usize) {
    if k > 0 && k < candidates.len() {
        candidates.select_nth_unstable_by(k - 1, |a, b| b.0.total_cmp(&a.0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BvhConfig, Triangle};
    use glam::Vec3;

    /// Each live inner slot's children (as an unordered pair) and parent.
    fn slots(bvh: &Bvh) -> Vec<Option<([NodeRef; 2], u32)>> {
        bvh.inner
            .iter()
            .map(|n| {
                let [a, b] = n.children;
                (n.parent != crate::tree::node::FREE).then_some(([a.min(b), a.max(b)], n.parent))
            })
            .collect()
    }

    /// The tree's shape without its slot numbers: each inner node's triangles, sorted.
    fn shape(bvh: &Bvh) -> Vec<Vec<u32>> {
        let mut inner = Vec::new();
        bvh.collect_inner(bvh.root, &mut inner);
        let mut shape: Vec<Vec<u32>> = inner
            .iter()
            .map(|&i| {
                let mut t = bvh.leaves_under(NodeRef::inner(i));
                t.sort_unstable();
                t
            })
            .collect();
        shape.sort_unstable();
        shape
    }

    /// Two pairs of triangles far apart: moving either pair's children puts them back.
    #[test]
    fn a_children_move_that_changes_nothing_leaves_every_slot_as_it_was() {
        let tri = |x: f32| {
            Triangle::new(
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            )
        };
        let mut bvh = Bvh::new(BvhConfig {
            keep_only_improving: true,
            ..BvhConfig::incr()
        });
        bvh.insert_triangles(&[tri(0.0), tri(0.5), tri(100.0), tri(100.5)])
            .unwrap();
        let before = (slots(&bvh), shape(&bvh));
        let pair = bvh.parent(NodeRef::leaf(0));
        assert_eq!(bvh.parent(NodeRef::leaf(1)), pair);
        bvh.reinsert_children(pair);
        bvh.validate().unwrap();
        assert_eq!((slots(&bvh), shape(&bvh)), before);
    }

    /// On a random tree, every children move either changes the tree's shape or leaves every
    /// slot holding the children and parent it held, so a list of slots ranked before a round
    /// still names the nodes it ranked.
    #[test]
    fn children_moves_change_the_shape_or_no_slot() {
        let mut rnd = crate::test_random(0x2545_f491_4f6c_dd1d);
        let mut v = || Vec3::new(rnd(), rnd(), rnd());
        let tris: Vec<Triangle> = (0..300)
            .map(|_| {
                let c = v() * 20.0;
                Triangle::new(c, c + v(), c + v())
            })
            .collect();
        for keep_only_improving in [false, true] {
            let mut bvh = Bvh::new(BvhConfig {
                keep_only_improving,
                ..BvhConfig::incr()
            });
            bvh.insert_triangles(&tris).unwrap();
            let (mut unchanged, mut changed) = (0, 0);
            for i in 0..bvh.inner.len() as u32 {
                if !bvh.inner[i as usize].has_parent() {
                    continue;
                }
                let before = (slots(&bvh), shape(&bvh));
                bvh.reinsert_children(i);
                bvh.validate().unwrap();
                if shape(&bvh) == before.1 {
                    assert_eq!(slots(&bvh), before.0, "node {i}");
                    unchanged += 1;
                } else {
                    changed += 1;
                }
            }
            assert!(
                unchanged > 0 && changed > 0,
                "{unchanged} unchanged, {changed} changed"
            );
        }
    }
}
