//! The tree the editor traces: each mesh of a scene inserted as the scene plugin's worker does, by
//! the engine's rule ([`MeshPieces`]: a group of its own, or pieces kept whole for a big mesh; every
//! bBVH built in parallel, then inserted one by one),
//! then the idle updates of the editor's preset and the full-sweep rebuilds of still meshes
//! ([`Refinement`]), through the same engine calls the worker makes, measured after fixed amounts
//! of idle time.

use rayon::prelude::*;
use std::ops::Range;
use std::time::Instant;
use treelight_bvh::glam::Affine3A;
use treelight_bvh::{Bvh, IdleWork, MeshPieces, PieceRule, Preset, Refinement, Triangle};

/// Idle time, in seconds of update steps and rebuilds, after which the tree is measured.
pub const IDLE_CHECKPOINTS: [f64; 4] = [0.0, 0.1, 1.0, 10.0];

/// The tree at one checkpoint.
pub struct IdlePoint {
    /// Idle time asked for, in seconds.
    pub idle_s: f64,
    /// Idle time spent in update steps so far (less than asked once the steps ran out).
    pub spent_s: f64,
    /// Update steps and full-sweep rebuilds so far.
    pub steps: u64,
    /// Meshes rebuilt by full-sweep SAH so far ([`Refinement`]).
    pub refined: u32,
    /// Eq. 1 with c_T = c_I = 1.
    pub sah_cost: f32,
    /// Primary and AO rays per second (millions) through the tree as it is.
    pub rays: (f64, f64),
}

/// One scene's run.
pub struct EditorRun {
    /// Groups inserted.
    pub meshes: usize,
    /// Time to build the bBVHs and insert them.
    pub insert_s: f64,
    /// The tree at each of [`IDLE_CHECKPOINTS`].
    pub points: Vec<IdlePoint>,
}

/// The editor's tree under construction: its meshes inserted as the worker inserts them, then
/// idle work run on demand (updates, and full-sweep rebuilds once they are done), with the idle
/// time it took.
pub struct EditorTree {
    /// The tree.
    pub bvh: Bvh,
    /// Time to build the bBVHs and insert them.
    pub insert_s: f64,
    /// Idle time spent in update steps and rebuilds so far.
    pub spent_s: f64,
    /// Update steps and rebuilds so far.
    pub steps: u64,
    /// Meshes rebuilt by full sweep so far.
    pub refined: u32,
    policy: treelight_bvh::Policy,
    work: IdleWork,
    to_refine: Vec<treelight_bvh::GroupId>,
}

impl EditorTree {
    /// Inserts each span of `tris` in `meshes` as a group under `preset`'s policy, by the engine's
    /// rule for the editor's tree ([`MeshPieces`]).
    pub fn insert(
        tris: &[Triangle],
        meshes: &[Range<usize>],
        preset: Preset,
    ) -> Result<Self, String> {
        let policy = preset.policy();
        let mut bvh = Bvh::new(policy.config);
        let start = Instant::now();
        let pieces: Vec<MeshPieces> = meshes
            .par_iter()
            .map(|span| {
                MeshPieces::cut(
                    &tris[span.clone()],
                    PieceRule::default(),
                    &Affine3A::IDENTITY,
                    None,
                )
            })
            .collect();
        let prepared = meshes
            .par_iter()
            .zip(&pieces)
            .flat_map(|(span, p)| (0..p.len()).into_par_iter().map(move |k| (span, p, k)))
            .map(|(span, p, k)| p.build(k, &tris[span.clone()], Affine3A::IDENTITY))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| e.to_string())?;
        // Baked groups big enough are rebuilt by full sweep once the updates are done, as the
        // worker does once the edits pause.
        let mut to_refine = Vec::new();
        for group in prepared {
            let g = bvh.insert_prepared(group).map_err(|e| e.to_string())?;
            let n = bvh
                .group_triangles(g)
                .map_or(0, treelight_bvh::TriangleIds::len);
            if !bvh.is_group_whole(g).unwrap_or(true) && Refinement::is_worth(n) {
                to_refine.push(g);
            }
        }
        let insert_s = start.elapsed().as_secs_f64();
        let mut work = IdleWork::default();
        work.after_edit(&policy.idle, &bvh);
        Ok(Self {
            bvh,
            insert_s,
            spent_s: 0.0,
            steps: 0,
            refined: 0,
            policy,
            work,
            to_refine,
        })
    }

    /// Runs idle work until `idle_s` seconds of it are spent in all, or none is left.
    pub fn idle_until(&mut self, idle_s: f64) -> Result<(), String> {
        while self.spent_s < idle_s {
            let step = Instant::now();
            if self.work.is_pending() {
                self.work.step(&self.policy.idle, &mut self.bvh);
            } else if let Some(g) = self.to_refine.pop() {
                let bvh = &mut self.bvh;
                let ((vertices, corners), transform) = (
                    bvh.group_world_indexed(g).map_err(|e| e.to_string())?,
                    bvh.group_transform(g).map_err(|e| e.to_string())?,
                );
                let rebuilt =
                    Refinement::build(vertices, corners, transform).map_err(|e| e.to_string())?;
                bvh.swap_group(g, rebuilt).map_err(|e| e.to_string())?;
                // As the worker: the updates follow the last rebuild of the series.
                if self.to_refine.is_empty() {
                    self.work.after_edit(&self.policy.idle, bvh);
                }
                self.refined += 1;
            } else {
                return Ok(());
            }
            self.spent_s += step.elapsed().as_secs_f64();
            self.steps += 1;
        }
        Ok(())
    }
}

/// Inserts each span of `tris` in `meshes` as a group under `preset`'s policy, then runs its idle
/// work, measuring the tree with `trace` (clock stopped) at each checkpoint.
pub fn run(
    tris: &[Triangle],
    meshes: &[Range<usize>],
    preset: Preset,
    trace: impl Fn(&Bvh) -> (f64, f64),
) -> Result<EditorRun, String> {
    let mut tree = EditorTree::insert(tris, meshes, preset)?;
    let mut points = Vec::with_capacity(IDLE_CHECKPOINTS.len());
    for idle_s in IDLE_CHECKPOINTS {
        tree.idle_until(idle_s)?;
        points.push(IdlePoint {
            idle_s,
            spent_s: tree.spent_s,
            steps: tree.steps,
            refined: tree.refined,
            sah_cost: tree.bvh.sah_cost_with(1.0, 1.0),
            rays: trace(&tree.bvh),
        });
    }
    Ok(EditorRun {
        meshes: meshes.len(),
        insert_s: tree.insert_s,
        points,
    })
}

/// The runs as a markdown table, one row per scene and checkpoint; `sah` gives a scene's full-sweep
/// SAH cost when that row was built in the same run.
pub fn markdown(
    preset: Preset,
    runs: &[(String, EditorRun)],
    sah: impl Fn(&str) -> Option<f32>,
) -> String {
    let mut out = format!(
        "\n### The editor's tree over idle time (`{preset}` preset, each mesh a group)\n\n\
         | scene | meshes | insertion [ms] | idle [s] | steps (time in them [s]) | meshes rebuilt | SAH cost | cost / SAH | primary [MRays/s] | AO [MRays/s] |\n\
         |---|---|---|---|---|---|---|---|---|---|\n"
    );
    for (scene, run) in runs {
        for p in &run.points {
            out += &format!(
                "| {scene} | {} | {:.1} | {} | {} ({:.3}) | {} | {:.2} | {} | {:.2} | {:.2} |\n",
                run.meshes,
                run.insert_s * 1e3,
                p.idle_s,
                p.steps,
                p.spent_s,
                p.refined,
                p.sah_cost,
                sah(scene).map_or("–".into(), |s| format!("{:.3}", p.sah_cost / s)),
                p.rays.0,
                p.rays.1,
            );
        }
    }
    out
}
