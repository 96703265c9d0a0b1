//! Every builder on the real scenes in ../shared/scenes/obj: valid, and hits equal brute force.

mod support;
use support::*;
use treelight_bvh::{BlockStream, Bvh, BvhConfig, PostPass, TopDown};

fn check_scene(name: &str) {
    let tris = load_obj(name);
    assert!(tris.len() > 60_000, "{name}: {} triangles", tris.len());
    let b = Bvh::build_top_down(&tris, TopDown::BinnedSah, BvhConfig::default())
        .unwrap()
        .bounds();
    let extent = (b.max - b.min).max_element() * 0.5;
    let center = b.center();
    let rays: Vec<_> = rays(120, 17, extent)
        .into_iter()
        .map(|mut r| {
            r.origin += center;
            r
        })
        .collect();
    let mut builds: Vec<(&str, Bvh)> = vec![
        (
            "sah",
            Bvh::build_top_down(&tris, TopDown::SweepSah, BvhConfig::default()).unwrap(),
        ),
        (
            "binned",
            Bvh::build_top_down(&tris, TopDown::BinnedSah, BvhConfig::default()).unwrap(),
        ),
        (
            "median",
            Bvh::build_top_down(&tris, TopDown::Median, BvhConfig::default()).unwrap(),
        ),
    ];
    let mut incr = Bvh::new(BvhConfig::incr());
    incr.insert_triangles(&tris).unwrap();
    builds.push(("incr", incr));
    let mut incru = Bvh::new(BvhConfig::incr_u());
    incru.insert_triangles(&tris).unwrap();
    // The post-pass on a copy, with a treelet pass and a restart (kept or taken back).
    let mut post = incru.clone();
    post.optimize(PostPass {
        max_rounds: 1,
        fraction: 0.25,
        treelet: 5,
        restarts: 1,
        ..PostPass::default()
    });
    builds.push(("incru", incru));
    builds.push(("incru + post-pass", post));
    let mut incrup = Bvh::new(BvhConfig::incr_u());
    incrup.insert_triangles_parallel_search(&tris).unwrap();
    builds.push(("incrup", incrup));
    // Clusters of up to four coherent consecutive triangles, then the short post-pass on them.
    let mut quads = Bvh::new(BvhConfig {
        cluster_levels: 2,
        ..BvhConfig::incr_u()
    });
    quads.insert_triangles(&tris).unwrap();
    quads.optimize(PostPass::short());
    builds.push(("incru, cluster levels 2, short post-pass", quads));
    let mut incrupb = Bvh::new(BvhConfig::incr_u());
    incrupb.insert_triangles_block_parallel(&tris).unwrap();
    builds.push(("incrupb", incrupb));
    // The streaming front end, fed in uneven chunks; the tree is valid between them.
    let mut streamed = Bvh::new(BvhConfig::incr_u());
    let mut stream = BlockStream::new(10_000);
    for (k, chunk) in tris.chunks(7_777).enumerate() {
        stream.push(&mut streamed, chunk).unwrap();
        if k == 3 {
            streamed
                .validate()
                .unwrap_or_else(|e| panic!("{name} stream after {k} chunks: {e}"));
        }
    }
    stream.flush(&mut streamed).unwrap();
    builds.push(("incrupb stream", streamed));
    for (method, bvh) in &builds {
        bvh.validate()
            .unwrap_or_else(|e| panic!("{name} {method}: {e}"));
        assert_eq!(bvh.triangle_count() as usize, tris.len());
        assert_hits_match(bvh, &rays);
        eprintln!("{name} {method}: cost {:.2}", bvh.sah_cost());
    }
}

#[test]
fn sibenik() {
    check_scene("sibenik.obj");
}

#[test]
fn stanford_bunny() {
    check_scene("stanford-bunny.obj");
}
