//! Criterion benches of the engine's hot operations on a real scene (sibenik.obj, 73,564 triangles):
//! insertion (whole-scene IncrU build, the target build of IncrU at k_u = 0.1 and the short
//! post-pass with pairs and with clusters of four, and one triangle into the finished tree), the branch-and-bound
//! search alone, removal of a 10k-triangle group, the GPU records of the whole tree, and closest-hit and any-hit traversal.
//!
//! Run: `cargo bench -p treelight_bvh --bench engine` (reads `../shared/scenes/obj/sibenik.obj`).

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use treelight_bvh::glam::{Affine3A, Vec3};
use treelight_bvh::{Bvh, BvhConfig, PostPass, Ray, SearchScratch, Triangle};

// The tests' scene loader, so the benches read the scene exactly as the tests check it.
#[path = "../tests/support/mod.rs"]
mod support;

fn sibenik() -> Vec<Triangle> {
    support::load_obj("sibenik.obj")
}

/// Deterministic rays from points inside the scene's bounds in pseudo-random directions.
fn rays(bvh: &Bvh, n: usize) -> Vec<Ray> {
    let b = bvh.bounds();
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let o = b.min + (b.max - b.min) * Vec3::new(next(), next(), next());
            let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or(Vec3::X);
            Ray::new(o, d)
        })
        .collect()
}

fn engine(c: &mut Criterion) {
    let tris = sibenik();
    let mut tree = Bvh::default();
    tree.insert_triangles(&tris).unwrap();
    let extra = Triangle::new(
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(1.5, 2.0, 3.0),
        Vec3::new(1.0, 2.5, 3.2),
    );

    let mut g = c.benchmark_group("insertion");
    g.sample_size(10);
    g.bench_function("incru_sibenik_73k", |b| {
        b.iter(|| {
            let mut bvh = Bvh::default();
            bvh.insert_triangles(black_box(&tris)).unwrap();
            bvh
        })
    });
    // The Sibenik target: IncrU at k_u = 0.1 and the short post-pass, with the paper's
    // pairs and with clusters of four.
    for levels in [1, 2] {
        let config = BvhConfig {
            update_fraction: 0.1,
            cluster_levels: levels,
            ..BvhConfig::incr_u()
        };
        g.bench_function(
            format!("incru_k_u_0.1_cluster_levels_{levels}_short_pass_sibenik_73k"),
            |b| {
                b.iter(|| {
                    let mut bvh = Bvh::new(config);
                    bvh.insert_triangles(black_box(&tris)).unwrap();
                    bvh.optimize(PostPass::short());
                    bvh
                })
            },
        );
    }
    g.finish();
    // Steady state: the tree's arrays have room (a fresh clone would reallocate them all on the first
    // push, which is not what an editor sees), so insert and remove the same triangle.
    c.bench_function("insertion/one_triangle_in_and_out_of_sibenik", |b| {
        let mut bvh = tree.clone();
        b.iter(|| {
            let ids = bvh
                .insert_triangles(std::slice::from_ref(black_box(&extra)))
                .unwrap();
            bvh.remove_triangles(&ids).unwrap();
        })
    });
    c.bench_function("search/best_sibling_in_sibenik", |b| {
        let mut scratch = SearchScratch::default();
        let boxes: Vec<_> = tris.iter().step_by(97).map(|t| t.aabb()).collect();
        let mut k = 0;
        b.iter(|| {
            k = (k + 1) % boxes.len();
            tree.find_best_sibling(black_box(&boxes[k]), &mut scratch)
        })
    });

    // A 10k-triangle group (a quarter of the scene, moved aside) in the 73k tree.
    let group: Vec<Triangle> = tris[..10_000].to_vec();
    let mut with_group = tree.clone();
    let id = with_group
        .insert_group(&group, Affine3A::from_translation(Vec3::X * 3.0), false)
        .unwrap();
    c.bench_function("removal/group_10k_from_83k", |b| {
        b.iter_batched_ref(
            || with_group.clone(),
            |bvh| bvh.remove_group(black_box(id)).unwrap(),
            BatchSize::LargeInput,
        )
    });

    // What a first upload makes of the whole tree: the path tracer's record layout decided afresh
    // and each of its compressed 4-wide records, and every triangle's record.
    let mut g = c.benchmark_group("export");
    g.throughput(criterion::Throughput::Elements(tree.inner_capacity() as u64));
    g.bench_function("wide_node_records_sibenik", |b| {
        b.iter(|| {
            let layout = treelight_bvh::WideRecords::of(&tree);
            (0..layout.capacity())
                .map(|s| black_box(layout.record(&tree, s)).refs[0])
                .fold(0u32, u32::wrapping_add)
        })
    });
    g.throughput(criterion::Throughput::Elements(
        tree.triangle_capacity() as u64
    ));
    g.bench_function("triangle_records_sibenik", |b| {
        b.iter(|| {
            (0..tree.triangle_capacity())
                .map(|t| black_box(tree.gpu_triangle(t)).v0[0])
                .sum::<f32>()
        })
    });
    g.finish();

    let rays = rays(&tree, 4096);
    let mut g = c.benchmark_group("traversal");
    g.throughput(criterion::Throughput::Elements(rays.len() as u64));
    g.bench_function("closest_hit_4096_rays_sibenik", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| tree.closest_hit(black_box(r)).is_some())
                .count()
        })
    });
    g.bench_function("any_hit_4096_rays_sibenik", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| tree.any_hit(black_box(r)).is_some())
                .count()
        })
    });
    g.finish();
}

criterion_group!(benches, engine);
criterion_main!(benches);
