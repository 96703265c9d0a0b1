//! Named policies: the few whole configurations a user chooses between, each carrying how triangles
//! are inserted, what runs after a bulk build, and the global updates between edits.

use crate::{Bvh, BvhConfig, BvhError, OptimizeCursor, PostPass, Triangle};

/// A named build-and-maintenance policy. [`Preset::policy`] spells it out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Preset {
    /// The fastest build: the paper's IncrUPB (parallel batches, global updates at the paper's
    /// k_u = 0.01) and nothing after it. For scenes that change wholesale, where a tree is traced
    /// for a short while before it is replaced.
    Fast,
    /// The editor's default: IncrUPB insertion, then global updates in bounded idle steps after
    /// every edit, so an edit is traced at once and the tree improves while the user looks at it.
    #[default]
    Balanced,
    /// The best tree: IncrU at k_u = 0.1 with clusters of up to four, then the full post-pass
    /// (rounds of alternating moves with treelets, restarts), then the idle steps. Its build takes
    /// tens of times as long as `Fast`'s; for a scene built once and traced long.
    Best,
}

/// How a policy inserts a batch of triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Insertion {
    /// One item at a time (Incr or IncrU, by [`BvhConfig::global_updates`]):
    /// [`Bvh::insert_triangles`].
    Sequential,
    /// IncrUP: searches in parallel, links in order: [`Bvh::insert_triangles_parallel_search`].
    ParallelSearch,
    /// IncrUPB: bBVHs of coherent batches built in parallel and inserted as subtrees:
    /// [`Bvh::insert_triangles_block_parallel`].
    BlockParallel,
}

/// Global updates spread over idle time in bounded steps ([`Bvh::optimize_step`]): after each
/// edit, `sweeps_after_edit` sweeps over the inner-node slots, `scan` slots per step, moving the
/// `fraction` most inefficient nodes of each step. Each step's time depends on `scan`, not on the
/// tree's size, so a caller holding a lock can release it between steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdleUpdates {
    /// Inner-node slots one step scans.
    pub scan: u32,
    /// Fraction of the scanned nodes (the most inefficient) a step moves.
    pub fraction: f32,
    /// Sweeps over the tree after each edit (0: no idle updates). Sweeps alternate children and
    /// subtree moves, so 2 makes one of each.
    pub sweeps_after_edit: u32,
}

impl IdleUpdates {
    /// No idle updates.
    pub const OFF: Self = Self {
        scan: 4096,
        fraction: 0.05,
        sweeps_after_edit: 0,
    };

    /// Steps of a few milliseconds (a few hundred moves), one sweep of each move kind per edit.
    pub const STEADY: Self = Self {
        scan: 4096,
        fraction: 0.05,
        sweeps_after_edit: 2,
    };

    /// Runs the steps one edit is followed by, to the end: what a tree becomes once its owner has
    /// been idle long enough. Returns the moves tried.
    pub fn run_to_end(&self, bvh: &mut Bvh) -> u64 {
        let mut work = IdleWork::default();
        work.after_edit(self, bvh);
        let mut moves = 0;
        while work.is_pending() {
            moves += work.step(self, bvh) as u64;
        }
        moves
    }
}

/// Idle updates under way: where the steps go on, and how much of the sweeps the last edit asked
/// for is left. An owner that releases the tree between steps (the scene worker) keeps one.
#[derive(Clone, Debug, Default)]
pub struct IdleWork {
    cursor: OptimizeCursor,
    slots_left: u64,
}

impl IdleWork {
    /// After an edit: the sweeps `updates` asks for, over the tree as it is now.
    pub fn after_edit(&mut self, updates: &IdleUpdates, bvh: &Bvh) {
        self.slots_left = updates.sweeps_after_edit as u64 * bvh.inner_capacity() as u64;
    }

    /// Whether steps are left.
    pub fn is_pending(&self) -> bool {
        self.slots_left > 0
    }

    /// One step of `updates`, if any is left; returns the moves tried.
    pub fn step(&mut self, updates: &IdleUpdates, bvh: &mut Bvh) -> u32 {
        if self.slots_left == 0 {
            return 0;
        }
        self.slots_left = self.slots_left.saturating_sub(updates.scan.max(1) as u64);
        bvh.optimize_step(&mut self.cursor, updates.scan, updates.fraction)
    }
}

/// Everything a preset decides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Policy {
    /// The engine's configuration (cost model, update cache, clustering, IncrUPB's batching).
    pub config: BvhConfig,
    /// How triangles are inserted.
    pub insertion: Insertion,
    /// What runs once after a bulk build ([`Policy::build`]), if anything.
    pub post_pass: Option<PostPass>,
    /// The global updates after each edit.
    pub idle: IdleUpdates,
}

impl Preset {
    /// Every preset, fastest first.
    pub const ALL: [Preset; 3] = [Preset::Fast, Preset::Balanced, Preset::Best];

    /// The preset's name as the bench and settings files spell it.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Fast => "fast",
            Preset::Balanced => "balanced",
            Preset::Best => "best",
        }
    }

    /// The preset named `name` ([`Preset::name`]'s spelling).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The whole policy.
    pub fn policy(self) -> Policy {
        match self {
            Preset::Fast => Policy {
                config: BvhConfig::default(),
                insertion: Insertion::BlockParallel,
                post_pass: None,
                idle: IdleUpdates::OFF,
            },
            Preset::Balanced => Policy {
                config: BvhConfig::default(),
                insertion: Insertion::BlockParallel,
                post_pass: None,
                idle: IdleUpdates::STEADY,
            },
            Preset::Best => Policy {
                config: BvhConfig {
                    update_fraction: 0.1,
                    cluster_levels: 2,
                    ..BvhConfig::default()
                },
                insertion: Insertion::Sequential,
                post_pass: Some(PostPass::default()),
                idle: IdleUpdates::STEADY,
            },
        }
    }
}

impl Policy {
    /// Inserts `tris` into `bvh` by this policy's insertion (its configuration is the tree's own).
    pub fn insert(&self, bvh: &mut Bvh, tris: &[Triangle]) -> Result<Vec<u32>, BvhError> {
        match self.insertion {
            Insertion::Sequential => bvh.insert_triangles(tris),
            Insertion::ParallelSearch => bvh.insert_triangles_parallel_search(tris),
            Insertion::BlockParallel => bvh.insert_triangles_block_parallel(tris),
        }
    }

    /// A tree over `tris` as this policy leaves it once idle: the insertion, the post-pass if
    /// any, then the idle steps that follow an edit, run to the end.
    pub fn build(&self, tris: &[Triangle]) -> Result<Bvh, BvhError> {
        let mut bvh = Bvh::new(self.config);
        self.insert(&mut bvh, tris)?;
        if let Some(pass) = self.post_pass {
            bvh.optimize(pass);
        }
        self.idle.run_to_end(&mut bvh);
        Ok(bvh)
    }
}

impl std::fmt::Display for Preset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Preset {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::from_name(s).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|p| p.name()).collect();
            format!(
                "unknown preset '{s}' (expected one of {})",
                names.join(", ")
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for p in Preset::ALL {
            assert_eq!(p.name().parse::<Preset>(), Ok(p));
        }
        let err = "quick".parse::<Preset>().unwrap_err();
        assert!(err.contains("fast, balanced, best"), "{err}");
    }

    #[test]
    fn idle_work_runs_the_sweeps_an_edit_asks_for_then_stops() {
        let mut bvh = Preset::Fast.policy().build(&soup(2000)).unwrap();
        let updates = IdleUpdates {
            scan: 100,
            fraction: 0.05,
            sweeps_after_edit: 2,
        };
        let mut work = IdleWork::default();
        assert!(!work.is_pending());
        assert_eq!(work.step(&updates, &mut bvh), 0, "no edit, no step");
        work.after_edit(&updates, &bvh);
        let (slots, cost) = (bvh.inner_capacity() as u64, bvh.sah_cost());
        let (mut steps, mut moves) = (0, 0);
        while work.is_pending() {
            moves += work.step(&updates, &mut bvh);
            steps += 1;
        }
        assert_eq!(steps, (2 * slots).div_ceil(100));
        assert!(moves > 0);
        // Idle moves are kept only when they lower the cost.
        assert!(bvh.sah_cost() <= cost);
        bvh.validate().unwrap();
    }

    /// `n` small random triangles in a 10-unit cube.
    fn soup(n: usize) -> Vec<Triangle> {
        let mut r = crate::test_random(7);
        (0..n)
            .map(|_| {
                let c = Vec3::new(r(), r(), r()) * 10.0;
                let d = |r: &mut dyn FnMut() -> f32| Vec3::new(r(), r(), r()) * 0.3;
                Triangle::new(c, c + d(&mut r), c + d(&mut r))
            })
            .collect()
    }

    #[test]
    fn each_preset_builds_a_valid_tree_and_best_costs_least() {
        let tris = soup(3000);
        let costs: Vec<f32> = Preset::ALL
            .iter()
            .map(|p| {
                let bvh = p.policy().build(&tris).unwrap();
                bvh.validate().unwrap();
                assert_eq!(bvh.triangle_count(), 3000);
                bvh.sah_cost()
            })
            .collect();
        // Balanced is Fast plus moves that are kept only when they lower the cost.
        assert!(costs[1] <= costs[0], "{costs:?}");
        assert!(costs[2] < costs[0], "{costs:?}");
    }
}
