//! Global updates: remove an inefficient node and re-insert its two children at better places,
//! driven by the node update cache (paper section 4.3), plus the optional post-pass.

use crate::node::{NONE, NodeKind, NodeRef};
use crate::{Bvh, Inefficiency};

/// Runs `$body` with `$m` bound to the measure `$kind` names, as a closure with that kind fixed:
/// ranking loops are generic over the closure, so the measure is chosen once per ranking instead
/// of once per node.
macro_rules! with_measure {
    ($kind:expr, $m:ident => $body:expr) => {
        match $kind {
            Inefficiency::Comb => {
                let $m = |a, l, r| measure(Inefficiency::Comb, a, l, r);
                $body
            }
            Inefficiency::Area => {
                let $m = |a, l, r| measure(Inefficiency::Area, a, l, r);
                $body
            }
            Inefficiency::Sum => {
                let $m = |a, l, r| measure(Inefficiency::Sum, a, l, r);
                $body
            }
            Inefficiency::Min => {
                let $m = |a, l, r| measure(Inefficiency::Min, a, l, r);
                $body
            }
        }
    };
}

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
    fn stored_area(&self, r: NodeRef) -> f32 {
        match r.kind() {
            NodeKind::Inner => self.inner[r.index() as usize].aabb.stored_area(),
            NodeKind::Leaf => self.tri_box[r.index() as usize].stored_area(),
            _ => self.aabb(r).area(),
        }
    }

    /// Runs a batch of updates if the node update cache holds N_u nodes.
    pub(crate) fn maybe_update(&mut self) {
        if self.config.global_updates && self.cache.len() >= self.config.update_cache_size as usize
        {
            self.run_update_batch();
        }
    }

    /// Updates the k_u fraction of the cached nodes with the highest inefficiency, then empties the cache.
    pub fn run_update_batch(&mut self) {
        // Both buffers go back with their capacity: batches run every few insertions.
        let mut cache = std::mem::take(&mut self.cache);
        let mut candidates = std::mem::take(&mut self.update_candidates);
        candidates.clear();
        for &i in &cache {
            self.in_cache[i as usize] = false;
        }
        self.rank_cached(&cache, &mut candidates);
        let k = share(self.config.update_fraction, candidates.len());
        worst_first(&mut candidates, k);
        self.reinsert_each(&candidates[..k], Move::Children);
        if self.config.update_treelet >= 3 {
            let size = self.config.update_treelet as usize;
            self.with_treelet_scratch(|bvh, s| {
                for &i in &cache {
                    // Nodes a move of this batch left detached, or a group opened into an
                    // instance, are not the global tree's to restructure.
                    if bvh.inner[i as usize].children[0] != NodeRef::NONE && bvh.in_global_tree(i) {
                        bvh.optimize_treelet(i, size, s);
                    }
                }
            });
        }
        cache.clear();
        self.cache = cache;
        self.update_candidates = candidates;
    }

    /// Moves each node of `nodes` that is still updatable (an earlier move in the same batch may
    /// have made it the root), with recording off: the moves must not queue further updates.
    /// Returns the moves made.
    fn reinsert_each(&mut self, nodes: &[(f32, u32)], kind: Move) -> u32 {
        let recording = std::mem::replace(&mut self.recording, false);
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
        self.recording = recording;
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
        // `n`'s children twice (once as `n`, once as `p`) and `p`'s never: about one move in
        // eleven of a round on Sibenik.
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

    /// The post-pass ("BVH postprocessing", the paper's reference 9): rounds of updates after
    /// construction, then restarts. Each round ranks the chosen fraction of inner nodes by
    /// inefficiency (shrinking by `fraction_decay` per round) and moves each as `moves` says,
    /// keeping only moves that lower the cost, then restructures treelets bottom-up;
    /// rounds stop once one gains less than `min_relative_gain`. Each restart re-clusters the top
    /// of the tree over its small subtrees and runs the rounds again, and is taken back unless it
    /// ends lower than before. Last come the `finish` sweeps of treelets over the large nodes.
    pub fn optimize(&mut self, pass: PostPass) -> PostPassReport {
        self.optimize_observed(pass, |_| {})
    }

    /// [`Bvh::optimize`], calling `observe` with the tree after every round and after each restart
    /// is kept or taken back, so a caller can sample the pass as it goes (the bench's plots) and
    /// still run exactly the rounds one call runs.
    pub fn optimize_observed(
        &mut self,
        pass: PostPass,
        mut observe: impl FnMut(&Bvh),
    ) -> PostPassReport {
        let before = self.update_ops;
        let cost_before = self.sah_cost();
        let saved = self.config.keep_only_improving;
        self.config.keep_only_improving = true;
        let mut rounds = self.optimize_rounds(&pass, cost_before, &mut observe);
        let mut cost = self.sah_cost();
        let mut restarts_kept = 0;
        for r in 0..pass.restarts {
            let snapshot = self.topology_snapshot();
            self.recluster_top(RESTART_CUTS[r as usize % RESTART_CUTS.len()]);
            rounds += self.optimize_rounds(&pass, self.sah_cost(), &mut observe);
            let new_cost = self.sah_cost();
            if new_cost < cost {
                cost = new_cost;
                restarts_kept += 1;
            } else {
                self.restore_topology(snapshot);
            }
            observe(self);
        }
        if pass.finish.iter().any(|s| s.size > 0) || pass.finish_moves > 0.0 {
            let acc_before = self.area_acc;
            for sweep in pass.finish.iter().filter(|s| s.size > 0) {
                self.treelet_pass_above(sweep.size as usize, sweep.min_area);
            }
            if pass.finish_moves > 0.0 {
                self.move_children_above(pass.finish_moves);
            }
            cost = self.cost_since(cost, acc_before, self.cost_scale());
            observe(self);
        }
        self.config.keep_only_improving = saved;
        PostPassReport {
            rounds,
            restarts_kept,
            updates: self.update_ops - before,
            cost_before,
            cost_after: cost,
        }
    }

    /// A children move at every inner node of the global tree (the root aside) whose box has at
    /// least `min_area` times the root's area, in slot order (tree order with instances). Returns
    /// the moves made.
    fn move_children_above(&mut self, min_area: f32) -> u32 {
        if !self.root.is_inner() {
            return 0;
        }
        let floor = min_area * self.inner[self.root.index() as usize].aabb.area();
        let mut nodes = Vec::new();
        if self.has_live_instances() {
            self.collect_inner(self.root, &mut nodes);
        } else {
            // Without instances every live slot with a parent is in the global tree.
            nodes.extend(0..self.inner.len() as u32);
        }
        // Listed before any move, as the moves rewrite slots: a later entry may then name the
        // node an earlier move made in that slot, and that node is moved instead.
        let large: Vec<(f32, u32)> = nodes
            .into_iter()
            .filter(|&i| {
                let n = &self.inner[i as usize];
                n.has_parent() && n.aabb.area() >= floor
            })
            .map(|i| (0.0, i))
            .collect();
        self.reinsert_each(&large, Move::Children)
    }

    /// Every inner node of the global tree but the root, with its inefficiency, into `out`
    /// (`nodes` is scratch space).
    fn rank_global_inner(
        &self,
        nodes: &mut Vec<u32>,
        areas: &mut Vec<f32>,
        out: &mut Vec<(f32, u32)>,
    ) {
        out.clear();
        if self.root.kind() != NodeKind::Inner {
            return;
        }
        if !self.has_live_instances() {
            // Without instances every live slot with a parent is in the global tree: a scan of
            // the flat array, in slot order, instead of a walk of the tree. Each inner box's area
            // is computed once, as its own and its parent's child area both.
            areas.clear();
            areas.extend(self.inner.iter().map(|n| n.aabb.stored_area()));
            with_measure!(self.config.inefficiency, m => self.rank_flat(areas, out, m));
            return;
        }
        nodes.clear();
        self.collect_inner(self.root, nodes);
        out.extend(
            nodes
                .iter()
                .filter(|&&i| self.inner[i as usize].parent != NONE)
                .map(|&i| (self.inefficiency(i), i)),
        );
    }

    /// Every live inner node with a parent, ranked by `m` over the inner areas `areas` (one per
    /// slot): the same values [`Bvh::inefficiency`] gives, bit for bit.
    #[inline(always)]
    fn rank_flat(
        &self,
        areas: &[f32],
        out: &mut Vec<(f32, u32)>,
        m: impl Fn(f32, f32, f32) -> f32,
    ) {
        let child_area = |r: NodeRef| match r.kind() {
            NodeKind::Inner => areas[r.index() as usize],
            _ => self.stored_area(r),
        };
        for (i, n) in self.inner.iter().enumerate() {
            if n.has_parent() {
                let (l, r) = (child_area(n.children[0]), child_area(n.children[1]));
                out.push((m(areas[i], l, r), i as u32));
            }
        }
    }

    /// What one unit of inner area adds to the SAH cost, when moves that keep the triangles and
    /// the root's box can track the cost by the inner area alone: without instances, whose
    /// inner nodes the global sum leaves out.
    fn cost_scale(&self) -> Option<f64> {
        (!self.has_live_instances() && self.root.is_inner())
            .then(|| self.config.c_t as f64 / self.aabb(self.root).area() as f64)
            .filter(|scale| scale.is_finite())
    }

    /// The SAH cost after moves that began at `cost` with the inner-area sum at `acc_before`:
    /// followed from the sum with [`Bvh::cost_scale`]'s `scale` where there is one, so no pass
    /// over the node arrays is needed, and measured otherwise.
    fn cost_since(&self, cost: f32, acc_before: f64, scale: Option<f64>) -> f32 {
        let new_cost = match scale {
            Some(scale) => cost + ((self.area_acc - acc_before) * scale) as f32,
            None => self.sah_cost(),
        };
        debug_assert!(
            (new_cost - self.sah_cost()).abs() <= 1e-4 * new_cost.abs().max(1.0),
            "tracked cost {new_cost} drifted from {}",
            self.sah_cost()
        );
        new_cost
    }

    /// Update rounds (and treelet passes) until one gains less than the pass's threshold, each
    /// followed by `observe`.
    fn optimize_rounds(
        &mut self,
        pass: &PostPass,
        mut cost: f32,
        observe: &mut impl FnMut(&Bvh),
    ) -> u32 {
        let mut nodes = Vec::new();
        let mut areas = Vec::new();
        let mut candidates = Vec::new();
        let mut rounds = 0;
        // Moves and treelets change neither the triangles nor the root's box (a union of the same
        // leaves), so without instances a round's cost follows from the inner area its moves
        // already account in `area_acc`: no pass over the node arrays per round.
        let tracked = self.cost_scale();
        let mut fraction = pass.fraction;
        for round in 0..pass.max_rounds {
            let acc_before = self.area_acc;
            self.rank_global_inner(&mut nodes, &mut areas, &mut candidates);
            let k = share(fraction, candidates.len());
            fraction *= pass.fraction_decay;
            worst_first(&mut candidates, k);
            // The post-pass also orders its top share, most inefficient first.
            candidates[..k].sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
            let kind = match pass.moves {
                PostMoves::Alternating => Move::alternating(round),
                PostMoves::Children => Move::Children,
            };
            self.reinsert_each(&candidates[..k], kind);
            if pass.treelet >= 3 {
                self.treelet_pass(pass.treelet as usize);
            }
            rounds += 1;
            observe(self);
            let new_cost = self.cost_since(cost, acc_before, tracked);
            let gain = (cost - new_cost) / cost.max(f32::MIN_POSITIVE);
            cost = new_cost;
            // Both move kinds must have had their turn before convergence is judged.
            let judged = round >= 1 || pass.moves == PostMoves::Children;
            if judged && gain < pass.min_relative_gain {
                break;
            }
        }
        rounds
    }
}

/// Subtree sizes (in triangles) below which successive restarts re-cluster: different cuts give
/// different arrangements, so a restart that repeats an earlier one's result is rare.
const RESTART_CUTS: [u32; 4] = [16, 64, 4, 256];

/// Where [`Bvh::optimize_step`] goes on: a sweep position over the inner-node slots, and scratch
/// space, so global updates can be spread over many short calls between edits.
#[derive(Clone, Debug, Default)]
pub struct OptimizeCursor {
    next: u32,
    sweep: u32,
    candidates: Vec<(f32, u32)>,
}

impl OptimizeCursor {
    /// Complete sweeps over the inner-node slots so far.
    pub fn sweeps(&self) -> u32 {
        self.sweep
    }
}

impl Bvh {
    /// A bounded slice of the post-pass: scans the next `scan` inner-node slots after the cursor and
    /// moves the `fraction` most inefficient live nodes among them (children re-insertion on even
    /// sweeps, subtree re-insertion on odd ones), keeping only moves that lower the cost. Its time is
    /// O(scan + moves · search), whatever the tree's size, so a caller holding a lock can release it
    /// between steps. Returns the number of moves tried.
    pub fn optimize_step(&mut self, cursor: &mut OptimizeCursor, scan: u32, fraction: f32) -> u32 {
        let slots = self.inner.len() as u32;
        if slots == 0 || self.root.kind() != NodeKind::Inner {
            return 0;
        }
        let start = cursor.next.min(slots);
        let end = start.saturating_add(scan.max(1)).min(slots);
        let candidates = &mut cursor.candidates;
        candidates.clear();
        for i in start..end {
            // Free slots and the root are skipped here; nodes inside kept-whole groups below.
            if self.inner[i as usize].has_parent() {
                candidates.push((self.inefficiency(i), i));
            }
        }
        let kind = Move::alternating(cursor.sweep);
        if end == slots {
            cursor.next = 0;
            cursor.sweep += 1;
        } else {
            cursor.next = end;
        }
        let k = share(fraction, candidates.len());
        worst_first(candidates, k);
        let saved = std::mem::replace(&mut self.config.keep_only_improving, true);
        let moves = self.reinsert_each(&cursor.candidates[..k], kind);
        self.config.keep_only_improving = saved;
        moves
    }
}

/// Which re-insertion a global update makes.
#[derive(Clone, Copy)]
enum Move {
    /// Remove the node and its parent, re-insert its two children.
    Children,
    /// Re-insert the node's whole subtree.
    Subtree,
}

impl Move {
    /// Children in even rounds (or sweeps), subtrees in odd ones.
    fn alternating(round: u32) -> Self {
        if round.is_multiple_of(2) {
            Move::Children
        } else {
            Move::Subtree
        }
    }
}

/// How many of `len` candidates `fraction` selects: rounded up, at most all, none for a negative or
/// NaN fraction.
fn share(fraction: f32, len: usize) -> usize {
    ((fraction * len as f32).ceil() as usize).min(len)
}

/// Inefficiency `kind` of a node of area `a` whose children have areas `l` and `r`.
#[inline(always)]
fn measure(kind: Inefficiency, a: f32, l: f32, r: f32) -> f32 {
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
fn worst_first(candidates: &mut [(f32, u32)], k: usize) {
    if k > 0 && k < candidates.len() {
        candidates.select_nth_unstable_by(k - 1, |a, b| b.0.total_cmp(&a.0));
    }
}

/// Settings of the post-pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PostPass {
    /// Most rounds to run.
    pub max_rounds: u32,
    /// Fraction of inner nodes (the most inefficient) tried per round.
    pub fraction: f32,
    /// Stop when a round lowers the cost by less than this fraction.
    pub min_relative_gain: f32,
    /// Subtrees per treelet restructured after each round (0: none; at most 8).
    pub treelet: u32,
    /// Re-clusterings of the top of the tree tried after the rounds converge.
    pub restarts: u32,
    /// Each round's share is the last one's times this (1: every round tries `fraction`). The
    /// worst nodes of a round are mostly those the rounds before could not place better, so a
    /// shrinking share stops paying for moves that put nodes back where they were.
    pub fraction_decay: f32,
    /// Which moves the rounds make.
    pub moves: PostMoves,
    /// Treelet sweeps over the large nodes once the rounds and restarts are done, in order (a
    /// sweep of size 0 is skipped).
    pub finish: [TreeletSweep; 2],
    /// After the sweeps, a children move at every inner node whose box has at least this share of
    /// the root's area (0: none). The sweeps have just reshaped the top, where an insertion-built
    /// tree spends most above a SAH-built one, so its nodes' children may now have better places;
    /// made before the sweeps, the same moves gain only what the sweeps would have.
    pub finish_moves: f32,
}

/// One restructuring sweep: a treelet of up to `size` subtrees (3 to 8) at every inner node whose
/// box has at least `min_area` times the root's area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeletSweep {
    /// Subtrees per treelet (0: no sweep).
    pub size: u32,
    /// Smallest box area swept, as a fraction of the root's.
    pub min_area: f32,
}

impl TreeletSweep {
    /// No sweep.
    pub const OFF: Self = Self {
        size: 0,
        min_area: 0.0,
    };
}

/// The moves of the post-pass's rounds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PostMoves {
    /// Children re-insertion in even rounds, subtree re-insertion in odd ones: the two kinds escape
    /// each other's local minima, which a long pass needs.
    #[default]
    Alternating,
    /// Children re-insertion only (the 2013 paper's move): more gain per move in the first rounds,
    /// which is what a short pass lives on.
    Children,
}

impl Default for PostPass {
    fn default() -> Self {
        Self {
            max_rounds: 8,
            fraction: 1.0,
            min_relative_gain: 1e-3,
            treelet: 6,
            restarts: 4,
            fraction_decay: 1.0,
            moves: PostMoves::Alternating,
            finish: [TreeletSweep::OFF; 2],
            finish_moves: 0.0,
        }
    }
}

impl PostPass {
    /// Update rounds only, as in the 2013 paper: no treelets, no restarts.
    pub fn rounds_only() -> Self {
        Self {
            treelet: 0,
            restarts: 0,
            ..Self::default()
        }
    }

    /// A short pass for a build that must stay fast: three rounds of children moves over the worst
    /// 23%, 9.2% and 3.7% of the inner nodes, then treelets of 6 subtrees at every node with at
    /// least 0.3% of the root's area and of 8 at every node with 1%, then a children move at every
    /// node with 0.3%. After IncrU at k_u = 0.1 it takes Sibenik from 48.76 to 46.16 (46.29
    /// on average over k_u = 0.06-0.14) in about the time the build took; spending the sweeps'
    /// time on wider rounds gains about half as much (BENCHMARKS.md). After a build with
    /// [`BvhConfig::cluster_levels`](crate::BvhConfig::cluster_levels) = 2, whose insertion is
    /// about 1.4x faster, it ends at 46.19 (46.26 on average) in about 0.86x the whole time.
    pub fn short() -> Self {
        Self {
            max_rounds: 3,
            fraction: 0.23,
            min_relative_gain: 0.0,
            treelet: 0,
            restarts: 0,
            fraction_decay: 0.4,
            moves: PostMoves::Children,
            finish: [
                TreeletSweep {
                    size: 6,
                    min_area: 0.003,
                },
                TreeletSweep {
                    size: 8,
                    min_area: 0.01,
                },
            ],
            finish_moves: 0.003,
        }
    }
}

/// What a post-pass did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PostPassReport {
    /// Rounds run, restarts' included.
    pub rounds: u32,
    /// Restarts that lowered the cost and were kept.
    pub restarts_kept: u32,
    /// Moves tried.
    pub updates: u64,
    /// SAH cost before.
    pub cost_before: f32,
    /// SAH cost after.
    pub cost_after: f32,
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
                (n.parent != crate::node::FREE).then_some(([a.min(b), a.max(b)], n.parent))
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
