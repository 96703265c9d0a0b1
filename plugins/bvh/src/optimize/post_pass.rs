//! The post-pass ("BVH postprocessing", the paper's reference 9): rounds of global updates over a
//! built tree, restarts that re-cluster its top, and finishing sweeps over its large nodes.

use super::update::{Move, share, with_measure, worst_first};
use crate::Bvh;
use crate::tree::node::{NONE, NodeKind, NodeRef};

impl Bvh {
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
    /// A short pass for a build that must stay fast: three rounds of children moves over the worst
    /// 23%, 9.2% and 3.7% of the inner nodes, then treelets of 6 subtrees at every node with at
    /// least 0.3% of the root's area and of 8 at every node with 1%, then a children move at every
    /// node with 0.3%. It takes about as long as the IncrU build before it and gains most of what
    /// the full pass gains: the rounds' worst nodes gain most per move, and the sweeps reshape the
    /// top, where an insertion-built tree loses most to a top-down one.
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
