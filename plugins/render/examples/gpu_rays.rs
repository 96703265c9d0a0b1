//! Rays per second on the adapter in use, through the WGSL traversal: primary rays, and from their
//! hits shadow rays (to a square light above the camera, any hit), diffuse-bounce rays (cosine
//! distributed, closest hit at any distance) and ambient-occlusion rays (short, any hit), over the
//! trees `--trees` names (default `incru`: IncrU, baked; `sah`: full-sweep SAH; `editor`: the tree
//! the editor traces, `treelight_bench::editor_tree` after its idle work), through each GPU layout:
//! the binary records in the tree's order and renumbered depth first
//! (`Bvh::gpu_depth_first_layout`), and their 4-wide collapse (`Bvh::gpu_wide_layout`). Then the
//! bytes an incremental upload writes when a 10k-triangle mesh joins the largest scene, next to the
//! scene's full size.
//!
//! `cargo run --release -p treelight_render --example gpu_rays -- [--resolution 512] [--ao-rays 8]
//!  [--repeats 5] [--trees incru,sah,editor] SCENE...` where SCENE is a file or a generator of
//! `treelight-bench` (`hairball:N`, `scatter:N:FILE`, `subdivide:K:FILE`).

#[path = "../tests/support/mod.rs"]
mod support;

use std::time::Instant;
use support::{
    Gpu, PinholeView, arg, depth_first_tree_bytes, scene_args, tree_bytes, wide_tree_bytes,
};
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{Bvh, BvhConfig, Preset, TopDown, Triangle};
use treelight_render::{GpuAoParams, PRIMARY_HITS_WGSL, PRIMARY_HITS_WIDE_WGSL, UploadPlan};

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
            let binary = (tree_bytes(&bvh), bvh.gpu_root());
            let layouts = [
                ("binary", binary, PRIMARY_HITS_WGSL),
                (
                    "binary, depth first",
                    depth_first_tree_bytes(&bvh),
                    PRIMARY_HITS_WGSL,
                ),
                ("4-wide", wide_tree_bytes(&bvh), PRIMARY_HITS_WIDE_WGSL),
            ];
            for (layout, ([n, t, i], root), source) in layouts {
                let buffers = [
                    gpu.storage("nodes", &n),
                    gpu.storage("triangles", &t),
                    gpu.storage("instances", &i),
                ];
                let camera = gpu.uniform(&view.uniform(root));
                let ao = gpu.uniform(bytemuck::bytes_of(&GpuAoParams {
                    rays: ao_rays,
                    length: diag.length() * 0.05,
                    ..GpuAoParams::default()
                }));
                let out = gpu.zeroed((resolution * resolution * 4) as u64);
                let groups = (resolution.div_ceil(8), resolution.div_ceil(8));
                let primary = gpu.pipeline(source, "primary_hits");
                let occlusion = gpu.pipeline(source, "ambient_occlusion");
                let diffuse = gpu.pipeline(source, "diffuse_bounces");
                let shadow = gpu.pipeline(source, "shadow_rays");
                let [nb, tb, ib] = &buffers;
                // One warm-up dispatch each (shader compilation, first touch of the buffers), then the
                // best of the timed repeats.
                let time = |pipeline: &wgpu::ComputePipeline, bind: &[&wgpu::Buffer]| {
                    gpu.dispatch(pipeline, bind, groups);
                    (0..repeats)
                        .map(|_| {
                            let t = Instant::now();
                            gpu.dispatch(pipeline, bind, groups);
                            t.elapsed().as_secs_f64()
                        })
                        .fold(f64::INFINITY, f64::min)
                };
                let t_primary = time(&primary, &[nb, tb, ib, &camera, &out]);
                let hits = support::words(&gpu.read(&out))
                    .iter()
                    .filter(|&&h| h != u32::MAX)
                    .count();
                let pixels = (resolution * resolution) as f64;
                // Each secondary kernel traces its primary rays again: subtract them to rate its own.
                let secondary = hits as f64 * ao_rays as f64;
                let rate = |pipeline: &wgpu::ComputePipeline| {
                    let t = time(pipeline, &[nb, tb, ib, &camera, &out, &ao]);
                    secondary / (t - t_primary).max(1e-9) / 1e6
                };
                let (shadow_rate, diffuse_rate, ao_rate) =
                    (rate(&shadow), rate(&diffuse), rate(&occlusion));
                println!(
                    "| {} | {} | {tree} | {:.2} | {layout} | {:.2} | {:.2} | {:.2} | {:.2} | {} |",
                    scene.name,
                    scene.triangles.len(),
                    bvh.sah_cost_with(1.0, 1.0),
                    pixels / t_primary / 1e6,
                    shadow_rate,
                    diffuse_rate,
                    ao_rate,
                    ao_rays
                );
            }
            if largest
                .as_ref()
                .is_none_or(|l| l.triangle_count() < bvh.triangle_count())
            {
                largest = Some(bvh);
            }
        }
    }
    if let Some(mut bvh) = largest {
        // A 10k-triangle mesh joins the scene: what the incremental upload writes.
        bvh.take_changes();
        let full: u64 = tree_bytes(&bvh).iter().map(|b| b.len() as u64).sum();
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
        let plan = UploadPlan::new(&bvh, &changes, [u64::MAX; 3]);
        println!(
            "\nAdding a 10000-triangle mesh to a {}-triangle scene uploads {} bytes \
             ({:.2}% of the scene's {} bytes): {} node records, {} triangles.",
            bvh.triangle_count() - 10_000,
            plan.upload_bytes(),
            plan.upload_bytes() as f64 / full as f64 * 100.0,
            full,
            changes.inner_count(),
            changes.written_triangles.len()
        );
    }
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
