//! `treelight-bench`: the paper's Table 1 for our scenes, every tree costed by the same Eq. 1 code and
//! traced by the same traversal, so only the tree differs between rows.

mod latency;
mod plots;

use treelight_bench::scenes;
use treelight_bench::{peers, rng, sweep};

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use rng::Rng;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;
use treelight_bvh::glam::Vec3;
use treelight_bvh::{
    Aabb, BatchBvh, Bvh, BvhConfig, PostMoves, PostPass, Ray, TopDown, TreeletSweep, Triangle,
};

const METHODS: &[&str] = &[
    "sah",
    "binned",
    "median",
    "incr",
    "incru",
    "incrup",
    "incrupb",
    "incru-post",
    "obvhs-fastest",
    "obvhs-medium",
    "obvhs-slowest",
    "bvh",
];
const ORDERS: &[&str] = &["as-is", "random", "view"];

/// Table 1 of "Incremental BVH construction for ray tracing" for our scenes and methods.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Scene: an .obj/.ply/.gltf/.glb file, `hairball:N`, `scatter:N:FILE` or `subdivide:K:FILE`. Repeatable.
    #[arg(long, required = true)]
    scene: Vec<String>,
    /// Triangle orders (comma list): as-is, random, view.
    #[arg(long, default_value = "as-is", value_delimiter = ',')]
    order: Vec<String>,
    /// Methods (comma list): sah, binned, median, incr, incru, incrup, incrupb, incru-post, and the
    /// peers obvhs-fastest, obvhs-medium, obvhs-slowest (obvhs presets) and bvh (the `bvh` crate),
    /// all with one triangle per leaf; a peer's build time includes converting its tree.
    #[arg(
        long,
        default_value = "sah,median,incr,incru,incrup,incrupb",
        value_delimiter = ','
    )]
    method: Vec<String>,
    /// Thread counts (comma list); every row is measured with each.
    #[arg(long, default_value = "1", value_delimiter = ',')]
    threads: Vec<usize>,
    /// Seed of generated scenes and of the random order.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Camera for primary rays and the view order: `ex,ey,ez,tx,ty,tz` (eye, target). Derived from
    /// the scene bounds when absent.
    #[arg(long)]
    camera: Option<String>,
    /// Primary-ray image size.
    #[arg(long, default_value = "512x384")]
    resolution: String,
    /// Ambient-occlusion rays per primary hit.
    #[arg(long, default_value_t = 8)]
    ao_rays: u32,
    /// AO ray length as a fraction of the scene's diagonal.
    #[arg(long, default_value_t = 0.05)]
    ao_length: f32,
    /// Write one CSV row per scene, order, method and thread count.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// With one scene, order and method: write the built tree as a TLBVH1 file.
    #[arg(long)]
    export_bvh: Option<PathBuf>,
    /// Also run the latency experiment of the paper's section 8 on each scene: hold out 0.1, 1, 3
    /// and 10% of the triangles, build the rest by IncrU, insert the held-out part (IncrU and
    /// IncrUPB), and compare with full rebuilds (binned SAH, obvhs-fastest); with the first
    /// `--threads` count.
    #[arg(long)]
    latency: bool,
    /// Build each row this many times, all rows in turn round by round, and report the fastest
    /// (costs are the same every time; this machine's timings vary by tens of percent from run to
    /// run, and interleaving keeps a slow spell from landing on one row only).
    #[arg(long, default_value_t = 1)]
    repeat: usize,
    /// Build every incremental row once per k_u in this range (`FROM:TO:STEP`, e.g.
    /// 0.06:0.14:0.005), overriding `--update-fraction`, and summarise each row's draws after the
    /// table: a single k_u's cost is one draw from a rough landscape.
    #[arg(long, value_name = "FROM:TO:STEP")]
    update_fraction_sweep: Option<String>,
    #[command(flatten)]
    tuning: Tuning,
    /// incru-post: fraction of the inner nodes, the most inefficient, re-inserted per round
    /// (engine default 1; `--post-short` 0.23). A comma list makes one incru-post row per fraction,
    /// built in turn with the other rows, so that their times share this machine's spells.
    #[arg(long = "post-fraction", value_delimiter = ',')]
    post_fractions: Vec<f32>,
    /// Write PNG plots to this folder: triangles inserted and SAH cost against time during
    /// construction per scene and order (the paper's Figures 8 and 9; an extra, sampled run of each
    /// method with the first `--threads` count), and with `--latency` its Figure 12.
    #[arg(long, value_name = "DIR")]
    plots: Option<PathBuf>,
}

/// Settings of the incremental methods; rows built with other than the engine's defaults say so.
#[derive(clap::Args, Debug, Clone, Copy)]
struct Tuning {
    /// k_u: fraction of the node update cache updated per batch (engine default 0.01, the paper's).
    #[arg(long)]
    update_fraction: Option<f32>,
    /// N_u: cached nodes that trigger a batch of updates (engine default 8000, the paper's).
    #[arg(long)]
    update_cache: Option<u32>,
    /// Rounds of clustering of coherent consecutive items: 1 pairs triangles (engine default, the
    /// paper's), 2 also pairs coherent consecutive pairs into subtrees of four (not in the paper).
    #[arg(long)]
    cluster_levels: Option<u32>,
    /// Tree rotations along each insertion's path (not in the paper).
    #[arg(long)]
    rotations: bool,
    /// Treelet restructuring of every cached node in update batches, with this many subtrees (not
    /// in the paper; 0 = off).
    #[arg(long)]
    update_treelet: Option<u32>,
    /// IncrUPB: batches up to this size stay whole while compact, whatever R*_coh says (engine
    /// default 64; 1 is the paper's rule).
    #[arg(long)]
    block_min_batch: Option<u32>,
    /// IncrUPB: a small batch is split when, at the scene's mean density, its box would hold more
    /// than this many foreign triangles per own one (engine default 0.25; `inf` turns it off).
    #[arg(long)]
    block_crowd_max: Option<f32>,
    /// IncrUPB: how each batch's bBVH is built: `median` (engine default) or `sah` (greedy
    /// agglomerative clustering up to 32 triangles, binned SAH above).
    #[arg(long)]
    block_bvh: Option<BlockBvhArg>,
    /// incru-post: restarts of the post-pass (engine default 4).
    #[arg(long)]
    post_restarts: Option<u32>,
    /// incru-post: most update rounds per convergence (engine default 8).
    #[arg(long)]
    post_rounds: Option<u32>,
    /// incru-post: fraction of the inner nodes, the most inefficient, re-inserted per round; one
    /// row's, set from `--post-fraction`.
    #[arg(skip)]
    post_fraction: Option<f32>,
    /// incru-post: subtrees per treelet restructured after each round (engine default 6; 0 = off).
    #[arg(long)]
    post_treelet: Option<u32>,
    /// incru-post: rounds stop early once one lowers the cost by less than this fraction (engine
    /// default 0.001; 0 runs every round `--post-rounds` allows).
    #[arg(long)]
    post_min_gain: Option<f32>,
    /// incru-post: each round's share is the last one's times this (engine default 1).
    #[arg(long)]
    post_decay: Option<f32>,
    /// incru-post: the rounds' moves: `alternating` (engine default: children, then subtrees) or
    /// `children`.
    #[arg(long)]
    post_moves: Option<PostMovesArg>,
    /// incru-post: the engine's short pass (`PostPass::short`: three rounds of children moves over
    /// 23%, 9.2% and 3.7%, then treelet sweeps over the large nodes) as the base that the other
    /// `--post-*` flags change.
    #[arg(long)]
    post_short: bool,
    /// incru-post: treelet sweeps after the rounds, `SIZE@AREA[,SIZE@AREA]` (treelets of SIZE
    /// subtrees at every node with at least AREA times the root's area, e.g. `6@0.003,8@0.01`),
    /// or `off` (engine default off; `--post-short` sets `6@0.003,8@0.01`).
    #[arg(long, value_parser = parse_finish)]
    post_finish: Option<Finish>,
    /// incru-post: after the treelet sweeps, a children move at every node with at least this
    /// share of the root's area (engine default 0 = off; `--post-short` sets 0.003).
    #[arg(long, value_parser = parse_area_fraction)]
    post_finish_moves: Option<f32>,
}

/// The treelet sweeps `--post-finish` names.
#[derive(Debug, Clone, Copy)]
struct Finish {
    sweeps: [TreeletSweep; 2],
}

impl std::fmt::Display for Finish {
    /// As `--post-finish` takes it, for the row label.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let on: Vec<String> = self
            .sweeps
            .iter()
            .filter(|s| s.size > 0)
            .map(|s| format!("{}@{}", s.size, s.min_area))
            .collect();
        if on.is_empty() {
            f.write_str("off")
        } else {
            f.write_str(&on.join(","))
        }
    }
}

/// Parses `--post-finish`: `off`, or one or two `SIZE@AREA` sweeps.
fn parse_finish(s: &str) -> Result<Finish, String> {
    let mut sweeps = [TreeletSweep::OFF; 2];
    if s != "off" {
        let parts: Vec<&str> = s.split(',').collect();
        if parts.len() > sweeps.len() {
            return Err(format!(
                "at most {} sweeps, got {}",
                sweeps.len(),
                parts.len()
            ));
        }
        for (sweep, part) in sweeps.iter_mut().zip(parts) {
            let (size, area) = part
                .split_once('@')
                .ok_or_else(|| format!("`{part}` is not SIZE@AREA"))?;
            let size: u32 = size
                .parse()
                .map_err(|e| format!("treelet size `{size}`: {e}"))?;
            if !(3..=8).contains(&size) {
                return Err(format!("treelet size {size} is not in 3-8"));
            }
            let min_area = parse_area_fraction(area)?;
            *sweep = TreeletSweep { size, min_area };
        }
    }
    Ok(Finish { sweeps })
}

/// Parses a share of the root's box area, as `--post-finish` and `--post-finish-moves` take it.
fn parse_area_fraction(area: &str) -> Result<f32, String> {
    let a: f32 = area
        .parse()
        .map_err(|e| format!("area fraction `{area}`: {e}"))?;
    if !(a.is_finite() && a >= 0.0) {
        return Err(format!("area fraction {area} is not a finite number >= 0"));
    }
    Ok(a)
}

/// The post-pass moves `--post-moves` names.
#[derive(clap::ValueEnum, Debug, Clone, Copy)]
enum PostMovesArg {
    Alternating,
    Children,
}

impl From<PostMovesArg> for PostMoves {
    fn from(m: PostMovesArg) -> Self {
        match m {
            PostMovesArg::Alternating => PostMoves::Alternating,
            PostMovesArg::Children => PostMoves::Children,
        }
    }
}

/// The bBVH builders `--block-bvh` names.
#[derive(clap::ValueEnum, Debug, Clone, Copy)]
enum BlockBvhArg {
    Median,
    Sah,
}

impl From<BlockBvhArg> for BatchBvh {
    fn from(b: BlockBvhArg) -> Self {
        match b {
            BlockBvhArg::Median => BatchBvh::Median,
            BlockBvhArg::Sah => BatchBvh::Sah,
        }
    }
}

impl Tuning {
    /// The configuration of an incremental method with these settings.
    fn config(&self, base: BvhConfig) -> BvhConfig {
        BvhConfig {
            update_fraction: self.update_fraction.unwrap_or(base.update_fraction),
            update_cache_size: self.update_cache.unwrap_or(base.update_cache_size),
            cluster_levels: self.cluster_levels.unwrap_or(base.cluster_levels),
            rotations: self.rotations || base.rotations,
            update_treelet: self.update_treelet.unwrap_or(base.update_treelet),
            block_min_batch: self.block_min_batch.unwrap_or(base.block_min_batch),
            block_crowd_max: self.block_crowd_max.unwrap_or(base.block_crowd_max),
            block_bvh: self.block_bvh.map_or(base.block_bvh, BatchBvh::from),
            ..base
        }
    }

    fn post_pass(&self) -> PostPass {
        let base = if self.post_short {
            PostPass::short()
        } else {
            PostPass::default()
        };
        PostPass {
            restarts: self.post_restarts.unwrap_or(base.restarts),
            max_rounds: self.post_rounds.unwrap_or(base.max_rounds),
            fraction: self.post_fraction.unwrap_or(base.fraction),
            treelet: self.post_treelet.unwrap_or(base.treelet),
            min_relative_gain: self.post_min_gain.unwrap_or(base.min_relative_gain),
            fraction_decay: self.post_decay.unwrap_or(base.fraction_decay),
            moves: self.post_moves.map_or(base.moves, PostMoves::from),
            finish: self.post_finish.map_or(base.finish, |f| f.sweeps),
            finish_moves: self.post_finish_moves.unwrap_or(base.finish_moves),
        }
    }

    /// What differs from the defaults, for the method column (empty when nothing does).
    fn label(&self, method: &str) -> String {
        if !method.starts_with("incr") {
            return String::new();
        }
        let mut parts = Vec::new();
        if let Some(k) = self.update_fraction {
            parts.push(format!("k_u={k}"));
        }
        if let Some(n) = self.update_cache {
            parts.push(format!("N_u={n}"));
        }
        if let (Some(c), false) = (self.cluster_levels, method == "incrupb") {
            parts.push(format!("cluster levels={c}"));
        }
        if self.rotations {
            parts.push("rotations".to_owned());
        }
        if let Some(t) = self.update_treelet.filter(|&t| t > 0) {
            parts.push(format!("treelets={t}"));
        }
        if let (Some(m), "incrupb") = (self.block_min_batch, method) {
            parts.push(format!("min batch={m}"));
        }
        if let (Some(c), "incrupb") = (self.block_crowd_max, method) {
            parts.push(format!("crowd max={c}"));
        }
        if let (Some(b), "incrupb") = (self.block_bvh, method) {
            // The name `--block-bvh` takes; no variant is skipped, so every one has one.
            if let Some(v) = clap::ValueEnum::to_possible_value(&b) {
                parts.push(format!("bBVH={}", v.get_name()));
            }
        }
        if method == "incru-post" {
            if let Some(r) = self.post_rounds {
                parts.push(format!("rounds={r}"));
            }
            if let Some(f) = self.post_fraction {
                parts.push(format!("fraction={f}"));
            }
            if let Some(t) = self.post_treelet {
                parts.push(format!("post treelets={t}"));
            }
            if let Some(r) = self.post_restarts {
                parts.push(format!("restarts={r}"));
            }
            if let Some(g) = self.post_min_gain {
                parts.push(format!("min gain={g}"));
            }
            if self.post_short {
                parts.push("short".to_owned());
            }
            if let Some(d) = self.post_decay {
                parts.push(format!("decay={d}"));
            }
            if let Some(v) = self
                .post_moves
                .and_then(|m| clap::ValueEnum::to_possible_value(&m))
            {
                parts.push(format!("moves={}", v.get_name()));
            }
            if let Some(f) = self.post_finish {
                parts.push(format!("finish={f}"));
            }
            if let Some(a) = self.post_finish_moves {
                parts.push(format!("finish moves={a}"));
            }
        }
        parts.join(" ")
    }
}

struct Row {
    scene: String,
    triangles: usize,
    order: String,
    method: String,
    settings: String,
    threads: usize,
    build_s: f64,
    sah_cost: f32,
    mtris_s: Option<f64>,
    primary_mrays_s: f64,
    ao_mrays_s: f64,
    update_ops_pct: f64,
    /// Under a k_u sweep: the row's settings but k_u, which its draws share.
    sweep_group: Option<String>,
}

struct Camera {
    eye: Vec3,
    target: Vec3,
}

fn main() {
    let args = Args::parse();
    if let Err(e) = run(&args) {
        eprintln!("treelight-bench: {e}");
        std::process::exit(1);
    }
}

fn run(args: &Args) -> Result<(), String> {
    for m in &args.method {
        if !METHODS.contains(&m.as_str()) {
            return Err(format!(
                "unknown method '{m}' (expected one of {})",
                METHODS.join(", ")
            ));
        }
    }
    for o in &args.order {
        if !ORDERS.contains(&o.as_str()) {
            return Err(format!(
                "unknown order '{o}' (expected one of {})",
                ORDERS.join(", ")
            ));
        }
    }
    let (w, h) = args
        .resolution
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .ok_or("--resolution must look like 512x384")?;
    if args.export_bvh.is_some()
        && (args.scene.len() != 1 || args.method.len() != 1 || args.order.len() != 1)
    {
        return Err("--export-bvh needs exactly one scene, one method and one order".into());
    }
    if args.export_bvh.is_some() && args.post_fractions.len() > 1 {
        return Err("--export-bvh writes one tree; give at most one --post-fraction".into());
    }
    if args.export_bvh.is_some() && args.update_fraction_sweep.is_some() {
        return Err(
            "--export-bvh writes one tree; it cannot follow a --update-fraction-sweep".into(),
        );
    }
    // Without a sweep one variant, the given settings; with one, a k_u per draw for the
    // incremental methods (the others do not read k_u and are built once).
    let draws: Vec<Option<f32>> = match &args.update_fraction_sweep {
        Some(spec) => sweep::parse_range(spec)?.into_iter().map(Some).collect(),
        None => vec![None],
    };
    // Each incru-post row is built once per post-pass fraction given, the engine's when none is.
    let fractions: Vec<Option<f32>> = if args.post_fractions.is_empty() {
        vec![None]
    } else {
        args.post_fractions.iter().copied().map(Some).collect()
    };
    let fractions_of = |m: &str| {
        if m == "incru-post" {
            &fractions[..]
        } else {
            &fractions[..1]
        }
    };
    let draws_of = |m: &str| {
        if m.starts_with("incr") {
            &draws[..]
        } else {
            &draws[..1]
        }
    };
    let variants = |m: &str| draws_of(m).len() * fractions_of(m).len();
    let per_order: usize =
        args.method.iter().map(|m| variants(m)).sum::<usize>() * args.threads.len();
    let jobs = (args.scene.len() * args.order.len() * per_order) as u64;
    let bar = ProgressBar::new(jobs);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed_precise} {msg}").unwrap(),
    );
    // The plots' sampled runs take the first post-pass fraction.
    let plot_tuning = Tuning {
        post_fraction: fractions[0],
        ..args.tuning
    };
    let mut rows = Vec::new();
    let mut latency_tables = String::new();
    let mut plotted = Vec::new();
    if let Some(dir) = &args.plots {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    for spec in &args.scene {
        bar.set_message(format!("loading {spec}"));
        let scene = scenes::load(spec, args.seed)?;
        if scene.triangles.is_empty() {
            return Err(format!("{spec}: no triangles"));
        }
        if args.latency {
            bar.set_message(format!("{} latency experiment", scene.name));
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(args.threads[0])
                .build()
                .map_err(|e| e.to_string())?;
            let (lat, rebuilds) = pool.install(|| latency::run(&scene.triangles, args.seed))?;
            latency_tables +=
                &latency::markdown(&scene.name, scene.triangles.len(), &lat, &rebuilds);
            if let Some(dir) = &args.plots {
                plotted.push(plots::latency(dir, &scene.name, &lat, &rebuilds)?);
            }
        }
        let bounds = scene
            .triangles
            .iter()
            .fold(Aabb::EMPTY, |b, t| b.union(&t.aabb()));
        let camera = match &args.camera {
            Some(c) => parse_camera(c)?,
            None => default_camera(&bounds),
        };
        for order in &args.order {
            let (tris, input_index) = reorder(&scene.triangles, order, &camera, args.seed);
            if let Some(dir) = &args.plots {
                bar.set_message(format!(
                    "{} {order}: sampled runs for the plots",
                    scene.name
                ));
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(args.threads[0])
                    .build()
                    .map_err(|e| e.to_string())?;
                let runs = args
                    .method
                    .iter()
                    .map(|m| pool.install(|| progress(&tris, m, &plot_tuning)))
                    .collect::<Result<Vec<_>, String>>()?;
                plotted.extend(plots::construction(dir, &scene.name, order, &runs)?);
            }
            // Every row's builds are interleaved, round by round, so that a slow spell of this
            // machine slows every method alike and the ratios between rows stay fair.
            let pools = args
                .threads
                .iter()
                .map(|&threads| {
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .map_err(|e| e.to_string())
                })
                .collect::<Result<Vec<_>, String>>()?;
            let cells: Vec<(&String, usize, Tuning)> = args
                .method
                .iter()
                .flat_map(|m| (0..args.threads.len()).map(move |t| (m, t)))
                .flat_map(|(m, t)| {
                    draws_of(m).iter().flat_map(move |d| {
                        fractions_of(m).iter().map(move |&f| {
                            let tuning = Tuning {
                                update_fraction: d.or(args.tuning.update_fraction),
                                post_fraction: f,
                                ..args.tuning
                            };
                            (m, t, tuning)
                        })
                    })
                })
                .collect();
            let mut build_s = vec![f64::INFINITY; cells.len()];
            let rounds = args.repeat.max(1);
            for round in 0..rounds {
                for (cell, (method, t, tuning)) in cells.iter().enumerate() {
                    let (method, t) = (*method, *t);
                    let settings = tuning.label(method);
                    bar.set_message(format!(
                        "{} {order} {method}{}{settings} ×{} (build {}/{rounds})",
                        scene.name,
                        if settings.is_empty() { "" } else { " " },
                        args.threads[t],
                        round + 1,
                    ));
                    let start = Instant::now();
                    let bvh = pools[t].install(|| build(&tris, method, tuning))?;
                    build_s[cell] = build_s[cell].min(start.elapsed().as_secs_f64());
                    if round + 1 < rounds {
                        continue;
                    }
                    // The last round traces each tree as soon as it is built, so a sweep holds one
                    // tree at a time, not one per draw.
                    let (threads, pool, build_s) = (args.threads[t], &pools[t], build_s[cell]);
                    bar.set_message(format!("{} {order} {method} ×{threads}: rays", scene.name));
                    let (primary, ao) = pool.install(|| trace(&bvh, &camera, &bounds, w, h, args));
                    let incremental = method.starts_with("incr");
                    rows.push(Row {
                        scene: scene.name.clone(),
                        triangles: tris.len(),
                        order: order.clone(),
                        method: method.clone(),
                        settings,
                        threads,
                        build_s,
                        sah_cost: bvh.sah_cost_with(1.0, 1.0),
                        mtris_s: incremental.then(|| tris.len() as f64 / build_s / 1e6),
                        primary_mrays_s: primary,
                        ao_mrays_s: ao,
                        update_ops_pct: bvh.update_ops() as f64 / tris.len() as f64 * 100.0,
                        sweep_group: (args.update_fraction_sweep.is_some() && incremental).then(
                            || {
                                Tuning {
                                    update_fraction: None,
                                    ..*tuning
                                }
                                .label(method)
                            },
                        ),
                    });
                    if let Some(path) = &args.export_bvh {
                        let mut f = std::io::BufWriter::new(
                            std::fs::File::create(path)
                                .map_err(|e| format!("{}: {e}", path.display()))?,
                        );
                        bvh.write_tlbvh_mapped(&mut f, Some(&input_index))
                            .map_err(|e| format!("{}: {e}", path.display()))?;
                    }
                    bar.inc(1);
                }
            }
        }
    }
    bar.finish_and_clear();
    print_markdown(&rows);
    if let Some(spec) = &args.update_fraction_sweep {
        print_sweep(spec, &rows);
    }
    print!("{latency_tables}");
    for p in &plotted {
        eprintln!("wrote {}", p.display());
    }
    if let Some(path) = &args.csv {
        write_csv(path, &rows).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(())
}

fn build(tris: &[Triangle], method: &str, tuning: &Tuning) -> Result<Bvh, String> {
    let cfg = tuning.config(BvhConfig::incr_u());
    let e = |e: treelight_bvh::BvhError| e.to_string();
    Ok(match method {
        "sah" => Bvh::build_top_down(tris, TopDown::SweepSah, cfg).map_err(e)?,
        "binned" => Bvh::build_top_down(tris, TopDown::BinnedSah, cfg).map_err(e)?,
        "median" => Bvh::build_top_down(tris, TopDown::Median, cfg).map_err(e)?,
        "incr" | "incru" | "incru-post" => {
            let mut bvh = Bvh::new(if method == "incr" {
                tuning.config(BvhConfig::incr())
            } else {
                cfg
            });
            bvh.insert_triangles(tris).map_err(e)?;
            if method == "incru-post" {
                bvh.optimize(tuning.post_pass());
            }
            bvh
        }
        "incrup" => {
            let mut bvh = Bvh::new(cfg);
            bvh.insert_triangles_parallel_search(tris).map_err(e)?;
            bvh
        }
        "incrupb" => {
            let mut bvh = Bvh::new(cfg);
            bvh.insert_triangles_block_parallel(tris).map_err(e)?;
            bvh
        }
        peer => {
            let built = peers::build(peer, tris).expect("methods are checked up front");
            let bvh = Bvh::from_built(tris, &built, cfg).map_err(e)?;
            // A conversion slip would cost and trace a different tree: refuse it.
            bvh.validate()
                .map_err(|err| format!("{peer}: the converted tree is invalid: {err}"))?;
            bvh
        }
    })
}

/// A construction sampled for the plots: the incremental methods insert the triangles in 40 chunks
/// (the same calls as the table's runs, chunk by chunk) and the post-pass is sampled after each of
/// its rounds, with the clock stopped while the cost is measured; other builders give one point
/// when done.
fn progress(tris: &[Triangle], method: &str, tuning: &Tuning) -> Result<plots::Progress, String> {
    const CHUNKS: usize = 40;
    let e = |e: treelight_bvh::BvhError| e.to_string();
    let mut samples = Vec::new();
    if method.starts_with("incr") {
        let mut bvh = Bvh::new(tuning.config(if method == "incr" {
            BvhConfig::incr()
        } else {
            BvhConfig::incr_u()
        }));
        let mut elapsed = 0.0;
        let mut done = 0;
        for chunk in tris.chunks(tris.len().div_ceil(CHUNKS).max(1)) {
            let t = Instant::now();
            match method {
                "incrup" => bvh.insert_triangles_parallel_search(chunk),
                "incrupb" => bvh.insert_triangles_block_parallel(chunk),
                _ => bvh.insert_triangles(chunk),
            }
            .map_err(e)?;
            elapsed += t.elapsed().as_secs_f64();
            done += chunk.len();
            samples.push((elapsed, done, bvh.sah_cost_with(1.0, 1.0)));
        }
        if method == "incru-post" {
            // One call, as in the table's run, sampled after each round (and each restart), with
            // the clock stopped while the cost is measured.
            let mut t = Instant::now();
            bvh.optimize_observed(tuning.post_pass(), |b| {
                elapsed += t.elapsed().as_secs_f64();
                samples.push((elapsed, done, b.sah_cost_with(1.0, 1.0)));
                t = Instant::now();
            });
        }
    } else {
        let t = Instant::now();
        let bvh = build(tris, method, tuning)?;
        samples.push((
            t.elapsed().as_secs_f64(),
            tris.len(),
            bvh.sah_cost_with(1.0, 1.0),
        ));
    }
    Ok(plots::Progress {
        method: method.to_owned(),
        samples,
    })
}

/// The triangles in the requested order, and for each the index it had in the input.
fn reorder(
    tris: &[Triangle],
    order: &str,
    camera: &Camera,
    seed: u64,
) -> (Vec<Triangle>, Vec<u32>) {
    let mut index: Vec<u32> = (0..tris.len() as u32).collect();
    match order {
        "random" => {
            let mut r = Rng::new(seed);
            for i in (1..index.len()).rev() {
                index.swap(i, r.below(i + 1));
            }
        }
        "view" => {
            // The paper's view-direction priority: the dot product of the view direction and the
            // direction from the camera to the triangle; highest first.
            let view = (camera.target - camera.eye).normalize();
            let priority: Vec<f32> = tris
                .iter()
                .map(|t| view.dot((t.center() - camera.eye).normalize_or_zero()))
                .collect();
            index.sort_by(|&a, &b| priority[b as usize].total_cmp(&priority[a as usize]));
        }
        _ => {}
    }
    (index.iter().map(|&i| tris[i as usize]).collect(), index)
}

fn parse_camera(s: &str) -> Result<Camera, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| "--camera needs six numbers")?;
    if v.len() != 6 {
        return Err("--camera needs six numbers: ex,ey,ez,tx,ty,tz".into());
    }
    Ok(Camera {
        eye: Vec3::new(v[0], v[1], v[2]),
        target: Vec3::new(v[3], v[4], v[5]),
    })
}

fn default_camera(bounds: &Aabb) -> Camera {
    let c = bounds.center();
    let diag = (bounds.max - bounds.min).length();
    Camera {
        eye: c + Vec3::new(0.3, 0.35, 1.0).normalize() * diag * 0.9,
        target: c,
    }
}

/// Primary rays through every pixel, then `ao_rays` hemisphere rays per hit; returns MRays/s of each.
fn trace(bvh: &Bvh, cam: &Camera, bounds: &Aabb, w: u32, h: u32, args: &Args) -> (f64, f64) {
    let forward = (cam.target - cam.eye).normalize();
    let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
    let up = right.cross(forward);
    let tan = (50f32.to_radians() * 0.5).tan();
    let aspect = w as f32 / h as f32;
    let ray_of = |x: u32, y: u32| {
        let sx = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0) * tan * aspect;
        let sy = (1.0 - (y as f32 + 0.5) / h as f32 * 2.0) * tan;
        Ray::new(cam.eye, (forward + right * sx + up * sy).normalize())
    };
    let start = Instant::now();
    let hits: Vec<Option<(Vec3, Vec3)>> = (0..w * h)
        .into_par_iter()
        .map(|p| {
            let ray = ray_of(p % w, p / w);
            bvh.closest_hit(&ray).map(|hit| {
                let n = bvh
                    .world_triangle(hit.triangle)
                    .map_or(Vec3::Y, |t| t.normal().normalize_or(Vec3::Y));
                let n = if n.dot(ray.dir) > 0.0 { -n } else { n };
                (ray.at(hit.t), n)
            })
        })
        .collect();
    let primary = (w * h) as f64 / start.elapsed().as_secs_f64() / 1e6;
    let len = (bounds.max - bounds.min).length() * args.ao_length;
    let start = Instant::now();
    let ao_count: u64 = hits
        .par_iter()
        .enumerate()
        .map(|(p, hit)| {
            let Some((point, n)) = hit else { return 0 };
            let mut r = Rng::new(p as u64);
            let mut blocked = 0u32;
            for _ in 0..args.ao_rays {
                // Cosine-weighted direction around the normal.
                let (u1, u2) = (r.f32(), r.f32());
                let (rad, phi) = (u1.sqrt(), std::f32::consts::TAU * u2);
                let t = n.any_orthonormal_vector();
                let b = n.cross(t);
                let d = t * rad * phi.cos() + b * rad * phi.sin() + n * (1.0 - u1).sqrt();
                let ray = Ray::new(point + n * len * 1e-4, d).with_range(0.0, len);
                blocked += bvh.any_hit(&ray).is_some() as u32;
            }
            std::hint::black_box(blocked);
            args.ao_rays as u64
        })
        .sum();
    let ao = ao_count as f64 / start.elapsed().as_secs_f64().max(1e-9) / 1e6;
    (primary, ao)
}

fn print_markdown(rows: &[Row]) {
    let mut scene = "";
    for r in rows {
        if r.scene != scene {
            scene = &r.scene;
            println!("\n### {} ({} triangles)\n", r.scene, r.triangles);
            println!(
                "| order | method | threads | build [s] | SAH cost | cost / SAH | stream [MTris/s] | primary [MRays/s] | AO [MRays/s] | updates [%] |"
            );
            println!("|---|---|---|---|---|---|---|---|---|---|");
        }
        let sah = rows
            .iter()
            .find(|s| s.scene == r.scene && s.method == "sah" && s.threads == r.threads)
            .or_else(|| {
                rows.iter()
                    .find(|s| s.scene == r.scene && s.method == "sah")
            })
            .map(|s| s.sah_cost);
        println!(
            "| {} | {} | {} | {:.3} | {:.2} | {} | {} | {:.2} | {:.2} | {:.2} |",
            r.order,
            if r.settings.is_empty() {
                r.method.clone()
            } else {
                format!("{} ({})", r.method, r.settings)
            },
            r.threads,
            r.build_s,
            r.sah_cost,
            sah.map_or("–".into(), |s| format!("{:.3}", r.sah_cost / s)),
            r.mtris_s.map_or("–".into(), |m| format!("{m:.2}")),
            r.primary_mrays_s,
            r.ao_mrays_s,
            r.update_ops_pct
        );
    }
}

/// One line per row of the table that a k_u sweep drew several times: the draws' SAH costs
/// summarised, and their mean build time and stream rate.
fn print_sweep(spec: &str, rows: &[Row]) {
    println!("\n### k_u sweep {spec}\n");
    println!(
        "| scene | order | method | threads | draws | mean SAH cost | ± s.e. | min – max | mean build [s] | mean stream [MTris/s] |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    // Rows are draws of the same setting when they agree on everything but k_u.
    fn setting(r: &Row) -> Option<(&str, &str, &str, &str, usize)> {
        r.sweep_group
            .as_deref()
            .map(|g| (&r.scene[..], &r.order[..], &r.method[..], g, r.threads))
    }
    let mut seen = Vec::new();
    for r in rows {
        let Some(key) = setting(r) else {
            continue;
        };
        if seen.contains(&key) {
            continue;
        }
        seen.push(key);
        let group = key.3;
        let draws: Vec<&Row> = rows.iter().filter(|d| setting(d) == Some(key)).collect();
        let cost = sweep::summarize(&draws.iter().map(|d| d.sah_cost as f64).collect::<Vec<_>>());
        let build = sweep::summarize(&draws.iter().map(|d| d.build_s).collect::<Vec<_>>());
        let stream = sweep::summarize(&draws.iter().filter_map(|d| d.mtris_s).collect::<Vec<_>>());
        let (Some(cost), Some(build)) = (cost, build) else {
            continue;
        };
        println!(
            "| {} | {} | {} | {} | {} | {:.4} | {} | {:.4} – {:.4} | {:.4} | {} |",
            r.scene,
            r.order,
            if group.is_empty() {
                r.method.clone()
            } else {
                format!("{} ({group})", r.method)
            },
            r.threads,
            cost.n,
            cost.mean,
            cost.std_err.map_or("–".into(), |e| format!("{e:.4}")),
            cost.min,
            cost.max,
            build.mean,
            stream.map_or("–".into(), |s| format!("{:.2}", s.mean)),
        );
    }
}

fn write_csv(path: &PathBuf, rows: &[Row]) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "scene,triangles,order,method,settings,threads,build_s,sah_cost,mtris_s,primary_mrays_s,ao_mrays_s,update_ops_pct"
    )?;
    for r in rows {
        writeln!(
            f,
            "\"{}\",{},{},{},\"{}\",{},{:.6},{:.4},{},{:.4},{:.4},{:.4}",
            r.scene.replace('"', "'"),
            r.triangles,
            r.order,
            r.method,
            r.settings,
            r.threads,
            r.build_s,
            r.sah_cost,
            r.mtris_s.map_or(String::new(), |m| format!("{m:.4}")),
            r.primary_mrays_s,
            r.ao_mrays_s,
            r.update_ops_pct
        )?;
    }
    Ok(())
}
