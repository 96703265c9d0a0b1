//! Rays per second on the adapter in use, through the WGSL traversal: primary rays, and from their
//! hits shadow rays (to a square light above the camera, any hit), diffuse-bounce rays (cosine
//! distributed, closest hit at any distance) and ambient-occlusion rays (short, any hit), over the
//! trees `--trees` names (default `incru`: IncrU, baked; `sah`: full-sweep SAH; `editor`: the tree
//! the editor traces, `treelight_bench::editor_tree` after its idle work), through each GPU layout:
//! the path tracer's (compressed 4-wide records where the traversal reads them: `WideRecords`), the
//! binary records in the tree's order and renumbered depth first (`Bvh::gpu_depth_first_layout`),
//! the binary records with their boxes in bytes (`GpuCompressedBinaryNode`), and the float 4-wide
//! collapse (`Bvh::gpu_wide_layout`). Then the
//! bytes an incremental upload writes when a 10k-triangle mesh joins the largest scene, next to the
//! scene's full size.
//!
//! `cargo run --release -p treelight_render --example gpu_rays -- [--resolution 512] [--ao-rays 8]
//!  [--repeats 5] [--trees incru,sah,editor] [--layouts wide,binary,depth-first,binary-compressed,wide-float]
//!  SCENE...` where SCENE is a file or a generator of
//! `treelight-bench` (`hairball:N`, `scatter:N:FILE`, `subdivide:K:FILE`). A scene's trees and
//! layouts take turns within each repeat (each kernel once per tree and layout), and each kernel's
//! time is the median over the repeats: a machine whose speed drifts (a shared one, a software
//! adapter) slows them all alike.

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::Instant;
use support::{
    Gpu, PinholeView, arg, binary_compressed_tree_bytes, binary_tree_bytes, depth_first_tree_bytes,
    scene_args, traced_root, tree_bytes, wide_tree_bytes,
};
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{Bvh, BvhConfig, Preset, TopDown, Triangle};
use treelight_render::{
    BufferKind, GpuAoParams, PRIMARY_HITS_BINARY_COMPRESSED_WGSL, PRIMARY_HITS_BINARY_WGSL,
    PRIMARY_HITS_WGSL, PRIMARY_HITS_WIDE_WGSL, UploadPlan, part_bindings,
};

fn main() {
    let resolution = arg("--resolution", 512);
    let ao_rays = arg("--ao-rays", 8);
    let repeats = arg("--repeats", 5).max(1);
    let trees: Vec<String> = std::env::args()
        .skip_while(|a| a != "--trees")
        .nth(1)
        .unwrap_or_else(|| "incru".into())
        .split(',')
        .map(str::to_owned)
        .collect();
    let wanted: Vec<String> = std::env::args()
        .skip_while(|a| a != "--layouts")
        .nth(1)
        .map_or_else(
            || LAYOUTS.iter().map(|l| l.0.to_owned()).collect(),
            |v| v.split(',').map(str::to_owned).collect(),
        );
    if let Some(w) = wanted.iter().find(|w| !LAYOUTS.iter().any(|l| l.0 == *w)) {
        let keys: Vec<&str> = LAYOUTS.iter().map(|l| l.0).collect();
        eprintln!("unknown layout '{w}' ({})", keys.join(", "));
        std::process::exit(2);
    }
    let specs = scene_args(
        "give at least one scene (a file, or hairball:N, scatter:N:FILE, subdivide:K:FILE)",
    );
    let gpu = Gpu::new();
    println!(
        "| scene | triangles | tree | SAH cost | layout | primary Mrays/s | shadow Mrays/s | diffuse Mrays/s | AO Mrays/s | rays per hit |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut largest: Option<Bvh> = None;
    for spec in &specs {
        let scene = treelight_bench::scenes::load(spec, 1).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(1);
        });
        // Every tree's layouts of this scene, built first so that they take turns below.
        let mut runs: Vec<LayoutRun> = Vec::new();
        let mut ao: Option<wgpu::Buffer> = None;
        let groups = (resolution.div_ceil(8), resolution.div_ceil(8));
        for tree in &trees {
            let bvh = build(tree, &scene).unwrap_or_else(|e| {
                eprintln!("{}: {e}", scene.name);
                std::process::exit(1);
            });
            let b = bvh.bounds();
            let diag = b.max - b.min;
            let view = PinholeView::looking_at(
                b.center() + Vec3::new(0.35, 0.25, 0.6) * diag.length() * 0.9,
                b.center(),
                resolution,
                resolution,
            );
            let ao = &*ao.get_or_insert_with(|| {
                gpu.uniform(bytemuck::bytes_of(&GpuAoParams {
                    rays: ao_rays,
                    length: diag.length() * 0.05,
                    ..GpuAoParams::default()
                }))
            });
            for &(_, layout, bytes, source) in
                LAYOUTS.iter().filter(|l| wanted.iter().any(|w| w == l.0))
            {
                let ([n, t, i, p], root) = bytes(&bvh);
                let mut run = LayoutRun {
                    tree: tree.clone(),
                    cost: bvh.sah_cost_with(1.0, 1.0),
                    layout,
                    buffers: [
                        gpu.storage("nodes", &n),
                        gpu.storage("triangles", &t),
                        gpu.storage("instances", &i),
                        gpu.uniform(&view.uniform(root)),
                        gpu.zeroed((resolution * resolution * 4) as u64),
                        gpu.storage("positions", &p),
                    ],
                    kernels: KERNELS.map(|k| gpu.pipeline(source, k)),
                    hits: 0,
                    times: Default::default(),
                };
                // A warm-up dispatch of each kernel (shader compilation, first touch of the
                // buffers); the primary one last, to count its hits.
                for k in (0..KERNELS.len()).rev() {
                    run.dispatch(&gpu, k, ao, groups);
                }
                run.hits = support::words(&gpu.read(&run.buffers[4]))
                    .iter()
                    .filter(|&&h| h != u32::MAX)
                    .count();
                runs.push(run);
            }
            if largest
                .as_ref()
                .is_none_or(|l| l.triangle_count() < bvh.triangle_count())
            {
                largest = Some(bvh);
            }
        }
        let Some(ao) = ao else { continue };
        // One dispatch of each kernel per repeat, the trees' layouts taking turns.
        for _ in 0..repeats {
            for run in &mut runs {
                for k in 0..KERNELS.len() {
                    let start = Instant::now();
                    run.dispatch(&gpu, k, &ao, groups);
                    run.times[k].push(start.elapsed().as_secs_f64());
                }
            }
        }
        print_rates(&scene, &runs, resolution, ao_rays);
    }
    if let Some(bvh) = largest {
        print_incremental_upload(bvh);
    }
}

/// What the incremental upload writes when a 10k-triangle mesh joins the scene of `bvh`.
fn print_incremental_upload(mut bvh: Bvh) {
    // A 10k-triangle mesh joins the scene: what the incremental upload writes.
    bvh.take_changes();
    let full: u64 = tree_bytes(&bvh).iter().map(|b| b.len() as u64).sum();
    let mut records = treelight_bvh::WideRecords::of(&bvh);
    let (mut positions, _) = treelight_bvh::PositionPool::of(&bvh);
    let b = bvh.bounds();
    let mesh: Vec<Triangle> = treelight_bench::scenes::hairball(10_000, 7)
        .into_iter()
        .map(|t| {
            let s = (b.max - b.min).length() * 0.05;
            let [a, bb, c] = t.v.map(|v| b.center() + v * s);
            Triangle::new(a, bb, c)
        })
        .collect();
    bvh.insert_group(&mesh, Affine3A::IDENTITY, false)
        .expect("the mesh is valid");
    let changes = bvh.take_changes();
    let moved = records.update(&bvh, &changes);
    let pooled = positions.update(&bvh, &changes);
    let plan = UploadPlan::streamed(
        &bvh,
        treelight_render::Layouts {
            records: (&records, &moved),
            positions: (&positions, &pooled),
        },
        &changes,
        [u64::MAX; 4],
        Default::default(),
        u64::MAX,
        &mut |_| {},
    );
    println!(
        "\nAdding a 10000-triangle mesh to a {}-triangle scene uploads {} bytes \
         ({:.2}% of the scene's {} bytes): {} node records, {} triangles.",
        bvh.triangle_count() - 10_000,
        plan.upload_bytes(),
        plan.upload_bytes() as f64 / full as f64 * 100.0,
        full,
        moved.ranges.iter().map(|r| r.len()).sum::<usize>(),
        changes.written_triangles.len()
    );
}

/// The table's rows of one scene: each run's rays per second by kernel.
fn print_rates(
    scene: &treelight_bench::scenes::Scene,
    runs: &[LayoutRun],
    resolution: u32,
    ao_rays: u32,
) {
    let pixels = (resolution * resolution) as f64;
    for run in runs {
        let [primary, shadow, diffuse, occlusion] = run.times.each_ref().map(|v| median(v));
        // Each secondary kernel traces its primary rays again: subtract them to rate its own.
        let secondary = run.hits as f64 * ao_rays as f64;
        let rate = |t: f64| secondary / (t - primary).max(1e-9) / 1e6;
        println!(
            "| {} | {} | {} | {:.2} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {} |",
            scene.name,
            scene.triangles.len(),
            run.tree,
            run.cost,
            run.layout,
            pixels / primary / 1e6,
            rate(shadow),
            rate(diffuse),
            rate(occlusion),
            ao_rays
        );
    }
}

/// A layout: its `--layouts` key, its name in the table, its buffers (nodes, triangles, instances,
/// positions) and root for a tree, and the kernels' WGSL.
type Layout = (
    &'static str,
    &'static str,
    fn(&Bvh) -> ([Vec<u8>; 4], u32),
    &'static str,
);

const LAYOUTS: [Layout; 5] = [
    (
        "wide",
        "compressed 4-wide per node (the path tracer's)",
        |b| (tree_bytes(b), traced_root(b)),
        PRIMARY_HITS_WGSL,
    ),
    (
        "binary",
        "binary",
        binary_tree_bytes,
        PRIMARY_HITS_BINARY_WGSL,
    ),
    (
        "depth-first",
        "binary, depth first",
        depth_first_tree_bytes,
        PRIMARY_HITS_BINARY_WGSL,
    ),
    (
        "binary-compressed",
        "binary compressed",
        binary_compressed_tree_bytes,
        PRIMARY_HITS_BINARY_COMPRESSED_WGSL,
    ),
    (
        "wide-float",
        "4-wide",
        wide_tree_bytes,
        PRIMARY_HITS_WIDE_WGSL,
    ),
];

/// The kernels timed, in the order of the table's columns.
const KERNELS: [&str; 4] = [
    "primary_hits",
    "shadow_rays",
    "diffuse_bounces",
    "ambient_occlusion",
];

/// One tree in one layout: its buffers (nodes, triangles, instances, camera, output, positions),
/// its kernels'
/// pipelines, its primary hits and each kernel's dispatch times.
struct LayoutRun {
    tree: String,
    cost: f32,
    layout: &'static str,
    buffers: [wgpu::Buffer; 6],
    kernels: [wgpu::ComputePipeline; 4],
    hits: usize,
    times: [Vec<f64>; 4],
}

impl LayoutRun {
    /// Dispatches kernel `k` and waits for it.
    fn dispatch(&self, gpu: &Gpu, k: usize, ao: &wgpu::Buffer, groups: (u32, u32)) {
        let [n, t, i, camera, out, positions] = &self.buffers;
        let mut bind = vec![n, t, i, camera, out];
        if k > 0 {
            // The secondary kernels also read the AO parameters (rays per hit, AO length).
            bind.push(ao);
        }
        let entries = bind
            .into_iter()
            .enumerate()
            .map(|(k, b)| (k as u32, b.as_entire_binding()))
            .chain([(
                part_bindings(BufferKind::Positions)[0],
                positions.as_entire_binding(),
            )])
            .collect();
        gpu.dispatch_indexed(&self.kernels[k], vec![entries], groups);
    }
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The tree named `kind` over `scene`.
fn build(kind: &str, scene: &treelight_bench::scenes::Scene) -> Result<Bvh, String> {
    match kind {
        "incru" => {
            let mut bvh = Bvh::new(BvhConfig::incr_u());
            bvh.insert_triangles(&scene.triangles)
                .map_err(|e| e.to_string())?;
            Ok(bvh)
        }
        "sah" => Bvh::build_top_down(&scene.triangles, TopDown::SweepSah, BvhConfig::default())
            .map_err(|e| e.to_string()),
        "editor" => {
            let mut tree = treelight_bench::editor_tree::EditorTree::insert(
                &scene.triangles,
                &scene.meshes,
                Preset::Balanced,
            )?;
            // Until the idle work is done (each checkpoint of the bench's `--editor` runs).
            tree.idle_until(f64::INFINITY)?;
            Ok(tree.bvh)
        }
        other => Err(format!("unknown tree '{other}' (incru, sah, editor)")),
    }
}
