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
    Aabb, Bvh, BvhConfig, IdleUpdates, Insertion, Policy, Preset, Ray, TopDown, Triangle,
};

const METHODS: &[&str] = &[
    "sah",
    "binned",
    "median",
    "incr",
    "incru",
    "incrup",
    "incrupb",
    "obvhs-fastest",
    "obvhs-medium",
    "obvhs-slowest",
    "bvh",
];
const ORDERS: &[&str] = &["as-is", "random", "view"];
/// The preset the editor's scene plugin runs under, which `--editor` measures.
const EDITOR_PRESET: Preset = Preset::Balanced;

/// Table 1 of "Incremental BVH construction for ray tracing" for our scenes, methods and presets.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Scene: .obj/.ply/.gltf/.glb file, `hairball:N`, `scatter:N:FILE` or `subdivide:K:FILE`. Repeatable.
    #[arg(long, required = true)]
    scene: Vec<String>,
    /// Triangle orders (comma list): as-is, random, view.
    #[arg(long, default_value = "as-is", value_delimiter = ',')]
    order: Vec<String>,
    /// The paper's methods and references (sah, binned, median, incr, incru, incrup, incrupb) and
    /// peers (obvhs-fastest, obvhs-medium, obvhs-slowest, bvh), comma list. Without it and without
    /// --preset: sah,median,incr,incru,incrup,incrupb.
    #[arg(long, value_delimiter = ',')]
    method: Vec<String>,
    /// The engine's presets (fast, balanced, best), comma list: each row is a whole policy.
    #[arg(long, value_delimiter = ',')]
    preset: Vec<Preset>,
    /// Thread counts (comma list); every row is measured with each.
    #[arg(long, default_value = "1", value_delimiter = ',')]
    threads: Vec<usize>,
    /// Seed of generated scenes and of the random order.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Camera `ex,ey,ez,tx,ty,tz` (eye, target) for rays and the view order; from the bounds if absent.
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
    /// Also run the paper's section 8 latency experiment on each scene.
    #[arg(long)]
    latency: bool,
    /// Also measure the editor's tree: each mesh a group, then idle updates for 0, 0.1, 1 and 10 s.
    #[arg(long)]
    editor: bool,
    /// Build each row N times, rows interleaved round by round, and report the fastest.
    #[arg(long, default_value_t = 1)]
    repeat: usize,
    /// Build the paper's incremental methods once per k_u in `FROM:TO:STEP` and summarise the draws.
    #[arg(long, value_name = "FROM:TO:STEP")]
    update_fraction_sweep: Option<String>,
    #[command(flatten)]
    tuning: Tuning,
    /// Write PNG plots (the paper's Figures 8 and 9, and 12 with `--latency`) to this folder.
    #[arg(long, value_name = "DIR")]
    plots: Option<PathBuf>,
}

/// The paper's parameters for its incremental methods (presets carry their own); rows built with
/// other than the engine's defaults say so.
#[derive(clap::Args, Debug, Clone, Copy)]
struct Tuning {
    /// k_u: fraction of the node update cache updated per batch (default 0.01, the paper's).
    #[arg(long)]
    update_fraction: Option<f32>,
    /// N_u: cached nodes that trigger a batch of updates (default 8000, the paper's).
    #[arg(long)]
    update_cache: Option<u32>,
    /// Rounds of clustering: 1 pairs triangles (the paper's), 2 also pairs coherent pairs.
    #[arg(long)]
    cluster_levels: Option<u32>,
}

impl Tuning {
    /// The configuration of an incremental method with these settings.
    fn config(&self, base: BvhConfig) -> BvhConfig {
        BvhConfig {
            update_fraction: self.update_fraction.unwrap_or(base.update_fraction),
            update_cache_size: self.update_cache.unwrap_or(base.update_cache_size),
            cluster_levels: self.cluster_levels.unwrap_or(base.cluster_levels),
            ..base
        }
    }

    /// What differs from the defaults, for the method column (empty when nothing does); a
    /// preset's row says it is one.
    fn label(&self, method: &str) -> String {
        if Preset::from_name(method).is_some() {
            return "preset".to_owned();
        }
        if !is_paper_incremental(method) {
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
    let ((w, h), methods) = checked_args(args)?;
    // Without a sweep one variant, the given settings; with one, a k_u per draw for the
    // incremental methods (the others do not read k_u and are built once).
    let draws: Vec<Option<f32>> = match &args.update_fraction_sweep {
        Some(spec) => sweep::parse_range(spec)?.into_iter().map(Some).collect(),
        None => vec![None],
    };
    let draws_of = |m: &str| {
        if is_paper_incremental(m) {
            &draws[..]
        } else {
            &draws[..1]
        }
    };
    let per_order: usize =
        methods.iter().map(|m| draws_of(m).len()).sum::<usize>() * args.threads.len();
    let jobs = (args.scene.len() * args.order.len() * per_order) as u64;
    let bar = ProgressBar::new(jobs);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed_precise} {msg}").unwrap(),
    );
    let mut rows = Vec::new();
    let mut latency_tables = String::new();
    let mut editor_runs = Vec::new();
    let mut plotted = Vec::new();
    if let Some(dir) = &args.plots {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    // One pool per thread count; the latency experiment, the editor's tree and the plots' sampled
    // runs use the first.
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
    for spec in &args.scene {
        bar.set_message(format!("loading {spec}"));
        let scene = scenes::load(spec, args.seed)?;
        if scene.triangles.is_empty() {
            return Err(format!("{spec}: no triangles"));
        }
        if args.latency {
            bar.set_message(format!("{} latency experiment", scene.name));
            let pool = &pools[0];
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
        if args.editor {
            bar.set_message(format!("{} the editor's tree", scene.name));
            let pool = &pools[0];
            let run = pool.install(|| {
                treelight_bench::editor_tree::run(
                    &scene.triangles,
                    &scene.meshes,
                    EDITOR_PRESET,
                    |bvh| trace(bvh, &camera, &bounds, w, h, args),
                )
            })?;
            editor_runs.push((scene.name.clone(), run));
        }
        for order in &args.order {
            let (tris, input_index) = reorder(&scene.triangles, order, &camera, args.seed);
            if let Some(dir) = &args.plots {
                bar.set_message(format!(
                    "{} {order}: sampled runs for the plots",
                    scene.name
                ));
                let pool = &pools[0];
                let runs = methods
                    .iter()
                    .map(|m| pool.install(|| progress(&tris, m, &args.tuning)))
                    .collect::<Result<Vec<_>, String>>()?;
                plotted.extend(plots::construction(dir, &scene.name, order, &runs)?);
            }
            let table = Table {
                args,
                pools: &pools,
                bar: &bar,
                camera: &camera,
                bounds: &bounds,
                resolution: (w, h),
            };
            table.rows(
                &scene.name,
                order,
                (&tris, &input_index),
                &methods,
                &draws,
                &mut rows,
            )?;
        }
    }
    bar.finish_and_clear();
    print_markdown(&rows);
    if let Some(spec) = &args.update_fraction_sweep {
        print_sweep(spec, &rows);
    }
    if !editor_runs.is_empty() {
        print!(
            "{}",
            treelight_bench::editor_tree::markdown(EDITOR_PRESET, &editor_runs, |scene| {
                rows.iter()
                    .find(|r| r.scene == scene && r.method == "sah")
                    .map(|r| r.sah_cost)
            })
        );
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

/// The arguments checked: the resolution, and the rows to build (the methods, then the presets,
/// named by the preset; the default methods apply only when neither is given).
fn checked_args(args: &Args) -> Result<((u32, u32), Vec<String>), String> {
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
    let resolution = args
        .resolution
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .ok_or("--resolution must look like 512x384")?;
    let methods: Vec<String> = if args.method.is_empty() && args.preset.is_empty() {
        DEFAULT_METHODS.iter().map(|m| (*m).to_owned()).collect()
    } else {
        args.method
            .iter()
            .cloned()
            .chain(args.preset.iter().map(|p| p.name().to_owned()))
            .collect()
    };
    if args.export_bvh.is_some()
        && (args.scene.len() != 1 || methods.len() != 1 || args.order.len() != 1)
    {
        return Err(
            "--export-bvh needs exactly one scene, one method or preset and one order".into(),
        );
    }
    if args.export_bvh.is_some() && args.update_fraction_sweep.is_some() {
        return Err(
            "--export-bvh writes one tree; it cannot follow a --update-fraction-sweep".into(),
        );
    }
    Ok((resolution, methods))
}

/// What building a scene's rows in one order shares.
struct Table<'a> {
    args: &'a Args,
    pools: &'a [rayon::ThreadPool],
    bar: &'a ProgressBar,
    camera: &'a Camera,
    bounds: &'a Aabb,
    resolution: (u32, u32),
}

impl Table<'_> {
    /// Builds every method (and each draw of a sweep) on each thread count, `repeat` rounds,
    /// keeping each cell's fastest build, and traces the last round's trees into `rows`. Every
    /// row's builds are interleaved, round by round, so that a slow spell of this machine slows
    /// every method alike and the ratios between rows stay fair.
    fn rows(
        &self,
        scene: &str,
        order: &str,
        (tris, input_index): (&[Triangle], &[u32]),
        methods: &[String],
        draws: &[Option<f32>],
        rows: &mut Vec<Row>,
    ) -> Result<(), String> {
        let (w, h) = self.resolution;
        let draws_of = |m: &str| {
            if is_paper_incremental(m) {
                draws
            } else {
                &draws[..1]
            }
        };
        let cells: Vec<(&String, usize, Tuning)> = methods
            .iter()
            .flat_map(|m| (0..self.args.threads.len()).map(move |t| (m, t)))
            .flat_map(|(m, t)| {
                draws_of(m).iter().map(move |d| {
                    let tuning = Tuning {
                        update_fraction: d.or(self.args.tuning.update_fraction),
                        ..self.args.tuning
                    };
                    (m, t, tuning)
                })
            })
            .collect();
        let mut build_s = vec![f64::INFINITY; cells.len()];
        let rounds = self.args.repeat.max(1);
        for round in 0..rounds {
            for (cell, (method, t, tuning)) in cells.iter().enumerate() {
                let (method, t) = (*method, *t);
                let settings = tuning.label(method);
                self.bar.set_message(format!(
                    "{} {order} {method}{}{settings} ×{} (build {}/{rounds})",
                    scene,
                    if settings.is_empty() { "" } else { " " },
                    self.args.threads[t],
                    round + 1,
                ));
                let start = Instant::now();
                let bvh = self.pools[t].install(|| build(tris, method, tuning))?;
                build_s[cell] = build_s[cell].min(start.elapsed().as_secs_f64());
                if round + 1 < rounds {
                    continue;
                }
                // The last round traces each tree as soon as it is built, so a sweep holds one
                // tree at a time, not one per draw.
                let (threads, pool, build_s) =
                    (self.args.threads[t], &self.pools[t], build_s[cell]);
                self.bar
                    .set_message(format!("{} {order} {method} ×{threads}: rays", scene));
                let (primary, ao) =
                    pool.install(|| trace(&bvh, self.camera, self.bounds, w, h, self.args));
                let incremental = is_incremental(method);
                rows.push(Row {
                    scene: scene.to_owned(),
                    triangles: tris.len(),
                    order: order.to_owned(),
                    method: method.clone(),
                    settings,
                    threads,
                    build_s,
                    sah_cost: bvh.sah_cost_with(1.0, 1.0),
                    mtris_s: incremental.then(|| tris.len() as f64 / build_s / 1e6),
                    primary_mrays_s: primary,
                    ao_mrays_s: ao,
                    update_ops_pct: bvh.update_ops() as f64 / tris.len() as f64 * 100.0,
                    sweep_group: (self.args.update_fraction_sweep.is_some()
                        && is_paper_incremental(method))
                    .then(|| {
                        Tuning {
                            update_fraction: None,
                            ..*tuning
                        }
                        .label(method)
                    }),
                });
                if let Some(path) = &self.args.export_bvh {
                    let mut f = std::io::BufWriter::new(
                        std::fs::File::create(path)
                            .map_err(|e| format!("{}: {e}", path.display()))?,
                    );
                    bvh.write_tlbvh_mapped(&mut f, Some(input_index))
                        .map_err(|e| format!("{}: {e}", path.display()))?;
                }
                self.bar.inc(1);
            }
        }
        Ok(())
    }
}

/// The rows built when neither `--method` nor `--preset` is given.
const DEFAULT_METHODS: [&str; 6] = ["sah", "median", "incr", "incru", "incrup", "incrupb"];

/// The paper's incremental methods, which `--update-fraction` and its sweep tune.
fn is_paper_incremental(method: &str) -> bool {
    method.starts_with("incr")
}

/// Rows that build by insertion, whose stream rate is reported: the paper's methods and presets.
fn is_incremental(method: &str) -> bool {
    is_paper_incremental(method) || Preset::from_name(method).is_some()
}

/// The whole policy of an insertion row: one of the paper's incremental methods with the given
/// tuning (no post-pass, no idle updates), or a preset as the engine defines it.
fn policy_of(method: &str, tuning: &Tuning) -> Option<Policy> {
    if let Some(preset) = Preset::from_name(method) {
        return Some(preset.policy());
    }
    let (base, insertion) = match method {
        "incr" => (BvhConfig::incr(), Insertion::Sequential),
        "incru" => (BvhConfig::incr_u(), Insertion::Sequential),
        "incrup" => (BvhConfig::incr_u(), Insertion::ParallelSearch),
        "incrupb" => (BvhConfig::incr_u(), Insertion::BlockParallel),
        _ => return None,
    };
    Some(Policy {
        config: tuning.config(base),
        insertion,
        post_pass: None,
        idle: IdleUpdates::OFF,
    })
}

fn build(tris: &[Triangle], method: &str, tuning: &Tuning) -> Result<Bvh, String> {
    let e = |e: treelight_bvh::BvhError| e.to_string();
    if let Some(policy) = policy_of(method, tuning) {
        return policy.build(tris).map_err(e);
    }
    let cfg = tuning.config(BvhConfig::incr_u());
    Ok(match method {
        "sah" => Bvh::build_top_down(tris, TopDown::SweepSah, cfg).map_err(e)?,
        "binned" => Bvh::build_top_down(tris, TopDown::BinnedSah, cfg).map_err(e)?,
        "median" => Bvh::build_top_down(tris, TopDown::Median, cfg).map_err(e)?,
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

/// A construction sampled for the plots: insertion rows insert the triangles in 40 chunks (the
/// same calls as the table's runs, chunk by chunk), a preset's post-pass is sampled after each of
/// its rounds and its idle updates once at their end, with the clock stopped while the cost is
/// measured; other builders give one point when done.
fn progress(tris: &[Triangle], method: &str, tuning: &Tuning) -> Result<plots::Progress, String> {
    const CHUNKS: usize = 40;
    let e = |e: treelight_bvh::BvhError| e.to_string();
    let mut samples = Vec::new();
    if let Some(policy) = policy_of(method, tuning) {
        let mut bvh = Bvh::new(policy.config);
        let mut elapsed = 0.0;
        let mut done = 0;
        for chunk in tris.chunks(tris.len().div_ceil(CHUNKS).max(1)) {
            let t = Instant::now();
            policy.insert(&mut bvh, chunk).map_err(e)?;
            elapsed += t.elapsed().as_secs_f64();
            done += chunk.len();
            samples.push((elapsed, done, bvh.sah_cost_with(1.0, 1.0)));
        }
        if let Some(pass) = policy.post_pass {
            // One call, as in the table's run, sampled after each round (and each restart).
            let mut t = Instant::now();
            bvh.optimize_observed(pass, |b| {
                elapsed += t.elapsed().as_secs_f64();
                samples.push((elapsed, done, b.sah_cost_with(1.0, 1.0)));
                t = Instant::now();
            });
        }
        if policy.idle.sweeps_after_edit > 0 {
            let t = Instant::now();
            policy.idle.run_to_end(&mut bvh);
            elapsed += t.elapsed().as_secs_f64();
            samples.push((elapsed, done, bvh.sah_cost_with(1.0, 1.0)));
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
