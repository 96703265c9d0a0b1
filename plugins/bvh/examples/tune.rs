//! Quick quality/speed check of the incremental builders on an OBJ file:
//! `cargo run --release -p treelight_bvh --example tune -- FILE.obj`
use std::time::Instant;
use treelight_bvh::glam::Vec3;
use treelight_bvh::{Bvh, BvhConfig, Inefficiency, TopDown, Triangle};

fn load(path: &str) -> Vec<Triangle> {
    let (models, _) = tobj::load_obj(
        path,
        &tobj::LoadOptions {
            triangulate: true,
            ..Default::default()
        },
    )
    .expect("load");
    let mut tris = Vec::new();
    for m in models {
        let p = &m.mesh.positions;
        let v = |i: u32| {
            Vec3::new(
                p[3 * i as usize],
                p[3 * i as usize + 1],
                p[3 * i as usize + 2],
            )
        };
        for f in m.mesh.indices.chunks_exact(3) {
            tris.push(Triangle::new(v(f[0]), v(f[1]), v(f[2])));
        }
    }
    tris
}

fn main() {
    let path = std::env::args().nth(1).expect("an OBJ path");
    let tris = load(&path);
    let t = Instant::now();
    let sah = Bvh::build_top_down(&tris, TopDown::SweepSah, BvhConfig::default()).unwrap();
    println!(
        "sah      cost {:7.2} {:6.3}s",
        sah.sah_cost(),
        t.elapsed().as_secs_f64()
    );
    let configs: Vec<(&str, BvhConfig)> = vec![
        ("incr", BvhConfig::incr()),
        (
            "incr-noclust",
            BvhConfig {
                clustering: false,
                ..BvhConfig::incr()
            },
        ),
        ("incru", BvhConfig::incr_u()),
        (
            "incru-area",
            BvhConfig {
                inefficiency: Inefficiency::Area,
                ..BvhConfig::incr_u()
            },
        ),
        (
            "incru-k5",
            BvhConfig {
                update_fraction: 0.05,
                ..BvhConfig::incr_u()
            },
        ),
        (
            "incru-k10",
            BvhConfig {
                update_fraction: 0.10,
                ..BvhConfig::incr_u()
            },
        ),
        (
            "incru-keep",
            BvhConfig {
                keep_only_improving: true,
                ..BvhConfig::incr_u()
            },
        ),
    ];
    for (name, cfg) in configs {
        let mut bvh = Bvh::new(cfg);
        let t = Instant::now();
        bvh.insert_triangles(&tris).unwrap();
        let s = t.elapsed().as_secs_f64();
        println!(
            "{name:12} cost {:7.2} {:6.3}s {:5.2} MTris/s updates {}",
            bvh.sah_cost(),
            s,
            tris.len() as f64 / s / 1e6,
            bvh.update_ops()
        );
        if name == "incru" {
            let t = Instant::now();
            let r = bvh.optimize(treelight_bvh::PostPass::default());
            println!(
                "  post-pass: {:.2} -> {:.2} in {} rounds, {:.3}s",
                r.cost_before,
                r.cost_after,
                r.rounds,
                t.elapsed().as_secs_f64()
            );
        }
    }
    let mut cfg = BvhConfig::incr_u();
    cfg.block_max_batch = 1024;
    let mut bvh = Bvh::new(cfg);
    let t = Instant::now();
    bvh.insert_triangles_block_parallel(&tris).unwrap();
    let s = t.elapsed().as_secs_f64();
    println!(
        "incrupb      cost {:7.2} {:6.3}s {:5.2} MTris/s",
        bvh.sah_cost(),
        s,
        tris.len() as f64 / s / 1e6
    );
}
