//! The latency experiment of the paper's section 8 (its Figure 12): how long it takes to add a few
//! percent of a scene to a tree that holds the rest, against rebuilding the whole scene from scratch
//! with the fastest full builders (ours, binned SAH; and obvhs's fastest preset).

use std::time::Instant;
use treelight_bench::peers;
use treelight_bench::rng::Rng;
use treelight_bvh::{Bvh, BvhConfig, TopDown, Triangle};

/// Percentages of the scene held out and inserted.
pub const PERCENTS: [f64; 4] = [0.1, 1.0, 3.0, 10.0];

/// One row of the experiment.
pub struct LatencyRow {
    pub percent: f64,
    pub inserted: usize,
    pub incru_ms: f64,
    pub incru_cost: f32,
    pub incrupb_ms: f64,
    pub incrupb_cost: f32,
}

/// A full rebuild of the whole scene.
pub struct Rebuild {
    pub method: &'static str,
    pub ms: f64,
    pub cost: f32,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Runs the experiment on `tris` (held-out triangles drawn at random with `seed`).
pub fn run(tris: &[Triangle], seed: u64) -> Result<(Vec<LatencyRow>, Vec<Rebuild>), String> {
    let e = |e: treelight_bvh::BvhError| e.to_string();
    let n = tris.len();
    let mut rebuilds = Vec::new();
    let t = Instant::now();
    let binned = Bvh::build_top_down(tris, TopDown::BinnedSah, BvhConfig::incr_u()).map_err(e)?;
    rebuilds.push(Rebuild {
        method: "binned",
        ms: ms(t),
        cost: binned.sah_cost_with(1.0, 1.0),
    });
    let t = Instant::now();
    let built = peers::build("obvhs-fastest", tris).expect("a peer");
    let obvhs = Bvh::from_built(tris, &built, BvhConfig::incr_u()).map_err(e)?;
    rebuilds.push(Rebuild {
        method: "obvhs-fastest",
        ms: ms(t),
        cost: obvhs.sah_cost_with(1.0, 1.0),
    });
    let mut rows = Vec::new();
    for percent in PERCENTS {
        let k =
            ((n as f64 * percent / 100.0).round() as usize).clamp(1, n.saturating_sub(1).max(1));
        let mut index: Vec<usize> = (0..n).collect();
        let mut r = Rng::new(seed ^ percent.to_bits());
        for i in (1..n).rev() {
            index.swap(i, r.below(i + 1));
        }
        let held: Vec<Triangle> = index[..k].iter().map(|&i| tris[i]).collect();
        let rest: Vec<Triangle> = index[k..].iter().map(|&i| tris[i]).collect();
        let mut base = Bvh::new(BvhConfig::incr_u());
        base.insert_triangles(&rest).map_err(e)?;
        let mut other = base.clone();
        // The paper times the insertion, not the arrays' growth: without room reserved, the
        // first insertion after a build doubles the per-triangle and per-node arrays (a copy of
        // megabytes, whatever the number inserted).
        base.reserve(k);
        other.reserve(k);
        let t = Instant::now();
        base.insert_triangles(&held).map_err(e)?;
        let incru_ms = ms(t);
        let t = Instant::now();
        other.insert_triangles_block_parallel(&held).map_err(e)?;
        let incrupb_ms = ms(t);
        rows.push(LatencyRow {
            percent,
            inserted: k,
            incru_ms,
            incru_cost: base.sah_cost_with(1.0, 1.0),
            incrupb_ms,
            incrupb_cost: other.sah_cost_with(1.0, 1.0),
        });
    }
    Ok((rows, rebuilds))
}

/// The experiment's rows as a markdown table.
pub fn markdown(scene: &str, n: usize, rows: &[LatencyRow], rebuilds: &[Rebuild]) -> String {
    let fastest = rebuilds
        .iter()
        .min_by(|a, b| a.ms.total_cmp(&b.ms))
        .expect("rebuilds");
    let mut s = format!(
        "\n### Latency: {scene} ({n} triangles)\n\nFull rebuilds of all {n} triangles: {}.\n\n",
        rebuilds
            .iter()
            .map(|r| format!("{} {:.1} ms (cost {:.2})", r.method, r.ms, r.cost))
            .collect::<Vec<_>>()
            .join(", ")
    );
    s += "| inserted | triangles | IncrU [ms] | cost after | IncrUPB [ms] | cost after | IncrU time / fastest rebuild |\n";
    s += "|---|---|---|---|---|---|---|\n";
    for r in rows {
        s += &format!(
            "| {}% | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} |\n",
            r.percent,
            r.inserted,
            r.incru_ms,
            r.incru_cost,
            r.incrupb_ms,
            r.incrupb_cost,
            r.incru_ms / fastest.ms
        );
    }
    s
}
