//! Every builder yields a valid tree whose ray hits equal brute force.

mod support;
use rayon::prelude::*;
use support::*;
use treelight_bvh::glam::Vec3;
use treelight_bvh::{BlockStream, Bvh, BvhConfig, BvhError, Inefficiency, TopDown, Triangle};

fn all_builds(tris: &[Triangle]) -> Vec<(&'static str, Bvh)> {
    let mut out = Vec::new();
    for (name, b) in [
        ("sah", TopDown::SweepSah),
        ("binned", TopDown::BinnedSah),
        ("median", TopDown::Median),
    ] {
        out.push((
            name,
            Bvh::build_top_down(tris, b, BvhConfig::default()).unwrap(),
        ));
    }
    let mut small = BvhConfig::incr_u();
    small.update_cache_size = 64; // small enough that updates run many times on small inputs
    let quads = BvhConfig {
        cluster_levels: 2,
        ..small
    };
    type Insert = fn(&mut Bvh, &[Triangle]) -> Result<Vec<u32>, BvhError>;
    let seq: Insert = Bvh::insert_triangles;
    let up: Insert = Bvh::insert_triangles_parallel_search;
    let upb: Insert = Bvh::insert_triangles_block_parallel;
    for (name, cfg, insert) in [
        ("incr", BvhConfig::incr(), seq),
        ("incru", small, seq),
        ("incru-cluster-levels-2", quads, seq),
        ("incrup-cluster-levels-2", quads, up),
        ("incrup", small, up),
        ("incrupb", small, upb),
        // The paper's batching rule: batches split down to single triangles where incoherent.
        (
            "incrupb-min1",
            BvhConfig {
                block_min_batch: 1,
                ..small
            },
            upb,
        ),
    ] {
        let mut bvh = Bvh::new(cfg);
        insert(&mut bvh, tris).unwrap();
        out.push((name, bvh));
    }
    for (name, pass) in [
        ("incru-post", treelight_bvh::PostPass::default()),
        ("incru-short-post", treelight_bvh::PostPass::short()),
    ] {
        let mut post = Bvh::new(small);
        post.insert_triangles(tris).unwrap();
        post.optimize(pass);
        out.push((name, post));
    }
    out
}

#[test]
fn builders_match_brute_force_on_soup() {
    let tris = soup(3000, 7);
    let rays = rays(300, 11, 10.0);
    for (name, bvh) in all_builds(&tris) {
        bvh.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(bvh.triangle_count(), 3000, "{name}");
        assert_hits_match(&bvh, &rays);
        assert!(bvh.sah_cost() > 0.0, "{name}");
    }
}

#[test]
fn an_observed_post_pass_is_the_same_pass_seen_round_by_round() {
    let tris = soup(3000, 7);
    let mut plain = Bvh::new(BvhConfig::incr_u());
    plain.insert_triangles(&tris).unwrap();
    let mut observed = plain.clone();
    let pass = treelight_bvh::PostPass {
        restarts: 2,
        ..treelight_bvh::PostPass::default()
    };
    let report = plain.optimize(pass);
    let mut costs = Vec::new();
    let seen = observed.optimize_observed(pass, |b| costs.push(b.sah_cost()));
    assert_eq!(seen, report, "observing changes the pass");
    // One look after every round, restarts' included, and one after each restart's verdict.
    assert_eq!(costs.len() as u32, report.rounds + pass.restarts);
    assert_eq!(*costs.last().unwrap(), report.cost_after);
    assert!(
        costs[0] < report.cost_before,
        "the first look is after a round"
    );
}

#[test]
fn a_shrinking_share_tries_each_round_its_own_share_of_the_worst_nodes() {
    let tris = soup(3000, 7);
    let mut bvh = Bvh::new(BvhConfig::incr_u());
    bvh.insert_triangles(&tris).unwrap();
    let inner = bvh.triangle_count() - 1;
    // The rounds alone: the finishing moves are counted in their own test below.
    let short = treelight_bvh::PostPass {
        finish_moves: 0.0,
        ..treelight_bvh::PostPass::short()
    };
    let report = bvh.clone().optimize(short);
    // Each round ranks every inner node but the root and moves its share, rounded up; a move can
    // only make a later node of the same round the root, which is then skipped.
    let mut fraction = short.fraction;
    let mut most = 0u64;
    for _ in 0..short.max_rounds {
        most += (fraction * (inner - 1) as f32).ceil() as u64;
        fraction *= short.fraction_decay;
    }
    assert_eq!(report.rounds, short.max_rounds);
    assert!(
        report.updates <= most && report.updates + 3 >= most,
        "{report:?} against {most}"
    );
    assert!(report.cost_after < report.cost_before, "{report:?}");
    // A constant share tries more for the same rounds.
    let constant = bvh.optimize(treelight_bvh::PostPass {
        fraction_decay: 1.0,
        ..short
    });
    assert!(constant.updates > report.updates + (inner as u64) / 10);
}

#[test]
fn the_short_pass_ends_with_treelet_sweeps_and_moves_that_lower_its_cost() {
    use treelight_bvh::{NONE, PostPass, TreeletSweep};
    let tris = soup(3000, 7);
    let mut built = Bvh::new(BvhConfig::incr_u());
    built.insert_triangles(&tris).unwrap();
    let short = PostPass::short();
    assert!(short.finish.iter().any(|s| s.size > 0) && short.finish_moves > 0.0);
    let mut with = built.clone();
    let mut looks = 0;
    let report = with.optimize_observed(short, |_| looks += 1);
    let mut swept = built.clone();
    let sweeps_only = swept.optimize(PostPass {
        finish_moves: 0.0,
        ..short
    });
    let rounds_only = built.clone().optimize(PostPass {
        finish: [TreeletSweep::OFF; 2],
        finish_moves: 0.0,
        ..short
    });
    // The same rounds, then the sweeps, which only ever lower the cost.
    assert_eq!(sweeps_only.updates, rounds_only.updates);
    assert!(
        sweeps_only.cost_after < rounds_only.cost_after,
        "{sweeps_only:?} against {rounds_only:?}"
    );
    // Then one move for each node (the root aside) that the sweeps left with at least the
    // pass's share of the root's area; moves that do not pay are taken back.
    let floor = short.finish_moves * swept.bounds().area();
    let large = (0..swept.inner_capacity())
        .filter_map(|i| swept.inner_node(i))
        .filter(|n| n.parent != NONE && n.aabb.area() >= floor)
        .count() as u64;
    assert!(large > 10, "only {large} large nodes");
    assert_eq!(report.updates, sweeps_only.updates + large);
    assert!(
        report.cost_after < sweeps_only.cost_after,
        "{report:?} against {sweeps_only:?}"
    );
    // The report's cost, tracked by the inner area, is the tree's; one more look after the
    // sweeps and moves.
    let real = with.sah_cost();
    assert!(
        (report.cost_after - real).abs() <= 1e-4 * real,
        "{report:?} against {real}"
    );
    assert_eq!(looks, report.rounds + 1);
    with.validate().unwrap();
    assert_hits_match(&with, &rays(300, 11, 10.0));
}

/// A rayon pool of `threads` threads.
fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// An IncrU tree filled by `insert` inside a rayon pool of `threads` threads.
fn built_in_pool(threads: usize, insert: impl FnOnce(&mut Bvh) + Send) -> Bvh {
    let mut bvh = Bvh::new(BvhConfig::incr_u());
    pool(threads).install(|| insert(&mut bvh));
    bvh
}

/// Builds with `insert` in pools of one, two and three threads, checks the one-thread tree is
/// valid and the others are the same tree, and returns the one-thread tree.
fn same_tree_on_any_pool(insert: impl Fn(&mut Bvh) + Sync) -> Bvh {
    let one = built_in_pool(1, &insert);
    one.validate().unwrap();
    for threads in [2, 3] {
        let other = built_in_pool(threads, &insert);
        assert_eq!(one.gpu_nodes(), other.gpu_nodes(), "{threads} threads");
        assert_eq!(one.sah_cost(), other.sah_cost(), "{threads} threads");
    }
    one
}

#[test]
fn parallel_search_does_not_depend_on_the_thread_count() {
    // Searches of a batch all run on the tree as it stood before the batch, and conflicts are
    // searched again in order, so the tree is the same whoever ran which search.
    let tris = soup(6_000, 21);
    same_tree_on_any_pool(|bvh| {
        bvh.insert_triangles_parallel_search(&tris).unwrap();
    });
}

#[test]
fn block_parallel_insertion_does_not_depend_on_the_thread_count() {
    // More than one buffer and many pipeline steps.
    let tris = std::sync::Arc::new(soup(40_000, 12));
    // The two sides of the pipeline wait for each other: a build that hangs fails the test
    // instead of stalling the suite.
    let (done, finished) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let one = same_tree_on_any_pool(|bvh| {
            bvh.insert_triangles_block_parallel(&tris).unwrap();
        });
        // Several builds at once in a pool of two, as a scene plugin's background tasks give:
        // each build's two sides compete with the others for the threads, none may wait forever
        // for a side that never gets one, and each tree is still the one-thread tree.
        for threads in [2, 3] {
            let trees: Vec<Bvh> = pool(threads).install(|| {
                (0..6)
                    .into_par_iter()
                    .map(|_| {
                        let mut bvh = Bvh::new(BvhConfig::incr_u());
                        bvh.insert_triangles_block_parallel(&tris).unwrap();
                        bvh
                    })
                    .collect()
            });
            for bvh in &trees {
                assert_eq!(one.gpu_nodes(), bvh.gpu_nodes());
            }
        }
        done.send(()).unwrap();
    });
    match finished.recv_timeout(std::time::Duration::from_secs(120)) {
        Ok(()) => {}
        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => panic!("a block-parallel build hung"),
        // The builds' thread panicked: its assertion message is already printed.
        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => panic!("a check failed"),
    }
}

#[test]
fn every_inefficiency_measure_builds_a_valid_tree() {
    let tris = soup(1500, 3);
    for m in [
        Inefficiency::Comb,
        Inefficiency::Area,
        Inefficiency::Sum,
        Inefficiency::Min,
    ] {
        let cfg = BvhConfig {
            inefficiency: m,
            update_cache_size: 50,
            ..BvhConfig::default()
        };
        let mut bvh = Bvh::new(cfg);
        bvh.insert_triangles(&tris).unwrap();
        bvh.validate().unwrap();
        assert!(bvh.update_ops() > 0, "{m:?} ran no updates");
    }
}

#[test]
fn tiny_inputs() {
    let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
    for n in 0..4 {
        let tris = vec![t; n];
        for (name, bvh) in all_builds(&tris) {
            bvh.validate()
                .unwrap_or_else(|e| panic!("{name} with {n}: {e}"));
            assert_eq!(bvh.triangle_count() as usize, n);
            let hit = bvh.closest_hit(&treelight_bvh::Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z));
            assert_eq!(hit.is_some(), n > 0, "{name} with {n}");
        }
    }
}

#[test]
fn duplicates_and_zero_area_triangles() {
    let mut tris = vec![Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y); 200];
    tris.extend((0..100).map(|i| {
        Triangle::new(
            Vec3::splat(i as f32),
            Vec3::splat(i as f32),
            Vec3::splat(i as f32),
        )
    }));
    tris.extend(
        (0..100).map(|i| Triangle::new(Vec3::ZERO, Vec3::X * i as f32, Vec3::X * 2.0 * i as f32)),
    );
    tris.extend(soup(300, 5));
    let rays = rays(200, 2, 10.0);
    for (name, bvh) in all_builds(&tris) {
        bvh.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_hits_match(&bvh, &rays);
    }
}

#[test]
fn non_finite_vertices_are_rejected_and_nothing_is_inserted() {
    let mut tris = soup(10, 1);
    tris[7].v[1].y = f32::NAN;
    let mut bvh = Bvh::default();
    bvh.insert_triangles(&soup(5, 2)).unwrap();
    let before = bvh.sah_cost();
    assert_eq!(
        bvh.insert_triangles(&tris),
        Err(BvhError::NonFiniteVertex { index: 7 })
    );
    assert_eq!(
        bvh.insert_triangles_block_parallel(&tris),
        Err(BvhError::NonFiniteVertex { index: 7 })
    );
    assert_eq!(
        bvh.insert_triangles_parallel_search(&tris),
        Err(BvhError::NonFiniteVertex { index: 7 })
    );
    tris[7].v[1].y = f32::INFINITY;
    assert!(bvh.insert_group(&tris, Default::default(), true).is_err());
    tris[7].v[1].y = 1e30;
    assert!(matches!(
        bvh.insert_triangles(&tris),
        Err(BvhError::CoordinateTooLarge { index: 7, .. })
    ));
    assert!(Bvh::build_top_down(&tris, TopDown::SweepSah, BvhConfig::default()).is_err());
    assert_eq!(bvh.triangle_count(), 5);
    assert_eq!(bvh.sah_cost(), before);
    bvh.validate().unwrap();
}

#[test]
fn block_parallel_rejects_an_invalid_vertex_in_any_buffer_on_any_pool() {
    // The input is checked in parallel pieces (with the pass that measures its bounds) before
    // either side starts: an invalid vertex early, in the middle or at the end is reported by its
    // index, and leaves the tree as it was, whatever the pool.
    let mut bvh = Bvh::default();
    bvh.insert_triangles(&soup(50, 3)).unwrap();
    let (count, cost) = (bvh.triangle_count(), bvh.sah_cost());
    for at in [3, 15_000, 39_999] {
        for bad in [f32::NAN, f32::NEG_INFINITY, 1e30] {
            let mut tris = soup(40_000, 4);
            tris[at].v[2].x = bad;
            for threads in [1, 2] {
                let got = pool(threads).install(|| bvh.insert_triangles_block_parallel(&tris));
                let want_index = match got {
                    Err(BvhError::NonFiniteVertex { index }) => index,
                    Err(BvhError::CoordinateTooLarge { index, .. }) => index,
                    other => panic!("{bad} at {at}: {other:?}"),
                };
                assert_eq!(want_index, at, "{bad}");
                assert_eq!((bvh.triangle_count(), bvh.sah_cost()), (count, cost));
            }
        }
    }
    bvh.validate().unwrap();
}

#[test]
fn block_stream_keeps_the_tree_valid_between_chunks() {
    let tris = soup(5000, 9);
    let rays = rays(100, 4, 10.0);
    let mut bvh = Bvh::default();
    let mut stream = BlockStream::new(700);
    let mut inserted = 0;
    for chunk in tris.chunks(333) {
        inserted += stream.push(&mut bvh, chunk).unwrap().len();
        bvh.validate().unwrap();
        assert_eq!(bvh.triangle_count() as usize, inserted);
        assert_eq!(
            inserted + stream.pending(),
            tris.len().min(inserted + stream.pending())
        );
        assert_hits_match(&bvh, &rays[..20]);
    }
    stream.flush(&mut bvh).unwrap();
    assert_eq!(bvh.triangle_count() as usize, tris.len());
    assert_hits_match(&bvh, &rays);
}

#[test]
fn incremental_cost_is_competitive_with_sah_on_soup() {
    // A sanity bound, not a target: IncrU within 30% of full-sweep SAH on an incoherent soup.
    let tris = soup(4000, 21);
    let sah = Bvh::build_top_down(&tris, TopDown::SweepSah, BvhConfig::default())
        .unwrap()
        .sah_cost();
    let median = Bvh::build_top_down(&tris, TopDown::Median, BvhConfig::default())
        .unwrap()
        .sah_cost();
    let mut incru = Bvh::default();
    incru.insert_triangles(&tris).unwrap();
    let c = incru.sah_cost();
    assert!(c < 1.3 * sah, "IncrU {c} vs SAH {sah}");
    assert!(sah <= median * 1.01, "SAH {sah} vs median {median}");
}

/// Boxes of `n` unit squares (as flat boxes) at the given origins.
fn square_boxes(origins: &[Vec3]) -> Vec<treelight_bvh::Aabb> {
    origins
        .iter()
        .map(|&o| treelight_bvh::Aabb::new(o, o + Vec3::new(1.0, 1.0, 0.0)))
        .collect()
}

#[test]
fn small_batches_stay_whole_when_compact_and_are_split_when_scattered() {
    // Eight tiles of a 4×2 patch: R*_coh is above R_max (the ∛ factor), but the patch's box is no
    // larger than its tiles', so a batch below the minimum size stays one bBVH.
    let patch: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new((i % 4) as f32, (i / 4) as f32, 0.0))
        .collect();
    let boxes = square_boxes(&patch);
    let mut order: Vec<u32> = (0..8).collect();
    let batches = treelight_bvh::coherent_batches(&boxes, &mut order, 1.5, 16, 1024, 0.0);
    assert_eq!(batches, vec![0..8]);
    // The paper's rule (minimum 1) splits the same patch by R*_coh alone.
    let batches = treelight_bvh::coherent_batches(&boxes, &mut order, 1.5, 1, 1024, 0.0);
    assert!(batches.len() > 1, "{batches:?}");

    // The same eight tiles scattered over a 1000-unit cube, as a random order brings them:
    // each ends up in its own batch, however small the batch.
    let scattered: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32) * 1000.0)
        .collect();
    let boxes = square_boxes(&scattered);
    let mut order: Vec<u32> = (0..8).collect();
    let batches = treelight_bvh::coherent_batches(&boxes, &mut order, 1.5, 16, 1024, 0.0);
    assert_eq!(batches.len(), 8, "{batches:?}");
}

#[test]
fn crowded_small_batches_are_split_and_flat_ones_never_are() {
    // A row of 16 unit cubes: compact by its area ratio (66 against 96) but not coherent by Eq. 3
    // (the cube-root factor), so the minimum batch size alone keeps it whole. Its box's volume
    // is 16.
    let cubes: Vec<treelight_bvh::Aabb> = (0..16)
        .map(|i| {
            let o = Vec3::new(i as f32, 0.0, 0.0);
            treelight_bvh::Aabb::new(o, o + Vec3::ONE)
        })
        .collect();
    let cut = |boxes: &[treelight_bvh::Aabb], crowding: f32| {
        let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
        treelight_bvh::coherent_batches(boxes, &mut order, 1.5, 16, 1024, crowding)
    };
    // Off, or at a density that puts fewer foreign cubes in its box than it holds: one batch.
    assert_eq!(cut(&cubes, 0.0), vec![0..16]);
    assert_eq!(cut(&cubes, 0.9), vec![0..16]);
    // Denser, it is crowded and split; its halves are coherent by Eq. 3, which the crowding
    // test does not overrule.
    assert_eq!(cut(&cubes, 2.0), vec![0..8, 8..16]);

    // A flat patch of tiles has no volume: never crowded, whatever the density.
    let patch: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new((i % 4) as f32, (i / 4) as f32, 0.0))
        .collect();
    assert_eq!(cut(&square_boxes(&patch), 1e9), vec![0..8]);

    // The factor itself: triangles over volume over the allowed crowd; 0 when it cannot apply.
    let cube = treelight_bvh::Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
    assert_eq!(treelight_bvh::crowding(&cube, 1000, 0.25), 4.0);
    assert_eq!(treelight_bvh::crowding(&cube, 1000, f32::INFINITY), 0.0);
    let flat = treelight_bvh::Aabb::new(Vec3::ZERO, Vec3::new(10.0, 10.0, 0.0));
    assert_eq!(treelight_bvh::crowding(&flat, 1000, 0.25), 0.0);
    assert_eq!(
        treelight_bvh::crowding(&treelight_bvh::Aabb::EMPTY, 1000, 0.25),
        0.0
    );
}

#[test]
fn coherent_batches_tile_the_order_whatever_the_pool() {
    // Squares at geometrically spaced x: each spatial-median split peels only the farthest few
    // off, so the subdivision runs far deeper than it may fork (the explicit stack takes over),
    // and a scattered soup beside it splits evenly. The cut forks on large ranges, and must give
    // the same batches, in the same order, on any pool.
    let mut origins: Vec<Vec3> = (0..300)
        .flat_map(|i| (0..8).map(move |j| Vec3::new(1.3f32.powi(i), j as f32, 0.0)))
        .collect();
    origins.extend(soup(3_000, 77).iter().map(|t| t.aabb().min * 50.0));
    let boxes = square_boxes(&origins);
    // And rows of 16 unit cubes, far from the rest: compact, not coherent by Eq. 3, and with
    // volume, so at this crowding each is crowded and split (see the test above). Their gaps
    // double, so every spatial-median split of several rows falls between rows.
    let mut boxes = boxes;
    boxes.extend((0..10).flat_map(|k| {
        let at = 100.0 * 2f32.powi(k);
        (0..16).map(move |i| {
            let o = Vec3::new(at + i as f32, -1e4 - at, at);
            treelight_bvh::Aabb::new(o, o + Vec3::ONE)
        })
    }));
    let crowding = 2.0;
    let cut_with = |threads: usize, crowding: f32| {
        let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
        let batches = pool(threads).install(|| {
            treelight_bvh::coherent_batches(&boxes, &mut order, 1.5, 16, 1024, crowding)
        });
        (batches, order)
    };
    let cut = |threads: usize| cut_with(threads, crowding);
    let (batches, order) = cut(1);
    assert_eq!(cut(4), (batches.clone(), order.clone()));
    // Without the test each row is one batch; with it, none is.
    let rows_from = origins.len() as u32;
    let row_batches = |(batches, order): &(Vec<std::ops::Range<usize>>, Vec<u32>)| {
        let rows = batches.iter().filter(|b| order[b.start] >= rows_from);
        rows.map(|b| b.len()).collect::<Vec<_>>()
    };
    assert_eq!(row_batches(&cut_with(1, 0.0)), vec![16; 10]);
    let split = row_batches(&(batches.clone(), order.clone()));
    assert!(split.iter().all(|&n| n < 16), "{split:?}");
    // The batches tile the order left to right, and the order is a permutation.
    let mut at = 0;
    for b in &batches {
        assert_eq!(b.start, at, "{batches:?}");
        assert!(b.end > b.start, "empty batch in {batches:?}");
        at = b.end;
    }
    assert_eq!(at, boxes.len());
    let mut sorted = order.clone();
    sorted.sort_unstable();
    assert!(sorted.iter().enumerate().all(|(i, &p)| p == i as u32));
    // Each batch obeys the rule: one primitive, compact and small, or coherent by Eq. 3.
    for b in &batches {
        let members: Vec<_> = order[b.clone()]
            .iter()
            .map(|&p| boxes[p as usize])
            .collect();
        let bounds = members.iter().fold(members[0], |a, m| a.union(m));
        let sum: f32 = members.iter().map(|m| m.area()).sum();
        let n = members.len();
        let e = bounds.extent();
        let uncrowded = e.x * e.y * e.z * crowding <= n as f32 * 1.0001;
        let small = n <= 16 && bounds.area() < 1.5 * sum * 1.0001 && uncrowded;
        let coherent = n <= 1024 && treelight_bvh::batch_coherence(&bounds, sum, n) < 1.5 * 1.0001;
        assert!(
            n == 1 || small || coherent,
            "batch {b:?} of {n} breaks the rule"
        );
    }
    assert!(batches.len() > 100, "{} batches", batches.len());
}
