//! The WGSL traversal on a real adapter (Mesa's llvmpipe in CI) finds the same primary-hit triangles
//! as the engine's CPU traversal, for the same camera rays, through each layout: the path tracer's
//! (compressed 4-wide records where the traversal reads them), the binary records, the same renumbered depth
//! first, the binary records with boxes in bytes, and the float 4-wide collapse; and the path
//! tracer's records cut into parts across bindings, as a scene larger than one binding is. A ray
//! along an axis that lies in a box's face meets the box, as the engine's does.

mod support;

use support::{
    PinholeView as View, gpu_binary_compressed_hits, gpu_binary_hits, gpu_depth_first_hits,
    gpu_hits, gpu_split_hits, gpu_wide_hits,
};
use treelight_bvh::glam::{Affine3A, Quat, Vec3};
use treelight_bvh::{Bvh, BvhConfig, Triangle};

/// Fraction of pixels where GPU and CPU agree on the hit triangle (ties at equal distance count as agreement).
fn agreement(bvh: &Bvh, view: &View, gpu: &[u32]) -> f64 {
    let mut agree = 0usize;
    for y in 0..view.height {
        for x in 0..view.width {
            let ray = view.ray(x, y);
            let cpu = bvh.closest_hit(&ray);
            let g = gpu[(y * view.width + x) as usize];
            let same = match cpu {
                None => g == u32::MAX,
                Some(h) if h.triangle == g => true,
                Some(h) => bvh
                    .world_triangle(g)
                    .and_then(|t| {
                        treelight_bvh::RayData::new(&ray).hit_triangle(&t, 0.0, f32::INFINITY)
                    })
                    .is_some_and(|(t, _, _)| (t - h.t).abs() <= 1e-4 * h.t.max(1.0)),
            };
            agree += same as usize;
        }
    }
    agree as f64 / (view.width * view.height) as f64
}

/// Each layout's name and the triangle each of `view`'s pixels meets through it.
fn every_layout(bvh: &Bvh, view: &View) -> [(&'static str, Vec<u32>); 5] {
    [
        (
            "the path tracer's (compressed 4-wide per node)",
            gpu_hits(bvh, view),
        ),
        ("binary", gpu_binary_hits(bvh, view)),
        ("depth first", gpu_depth_first_hits(bvh, view)),
        ("binary compressed", gpu_binary_compressed_hits(bvh, view)),
        ("4-wide", gpu_wide_hits(bvh, view)),
    ]
}

fn sibenik() -> Vec<Triangle> {
    let path = treelight_test_support::shared_scene("obj/sibenik.obj");
    let scene = treelight_import::load_scene(&path).unwrap();
    scene
        .world_triangles()
        .into_iter()
        .map(|[a, b, c]| Triangle::new(a, b, c))
        .collect()
}

#[test]
fn sibenik_primary_hits_match_the_cpu() {
    let tris = sibenik();
    let mut bvh = Bvh::new(BvhConfig::incr_u());
    bvh.insert_triangles(&tris).unwrap();
    assert!(tris.len() > 4 << 14 && bvh.inner_capacity() > 4 << 14);
    let b = bvh.bounds();
    // Inside the nave, looking along it.
    let c = b.center();
    let view = View::looking_at(
        c + Vec3::new(-(b.max.x - b.min.x) * 0.35, -0.2 * (b.max.y - b.min.y), 0.0),
        c,
        128,
        128,
    );
    // Parts of 2^14 records: the nodes and the triangles each lie in five bindings, as a scene
    // five times larger than a binding would on the adapter.
    let split = (
        "the path tracer's, split into parts",
        gpu_split_hits(&bvh, &view, 14),
    );
    for (layout, gpu) in every_layout(&bvh, &view).into_iter().chain([split]) {
        let hits = gpu.iter().filter(|&&g| g != u32::MAX).count();
        assert!(
            hits > 128 * 128 / 2,
            "{layout}: only {hits} pixels hit anything"
        );
        let a = agreement(&bvh, &view, &gpu);
        assert!(
            a >= 0.999,
            "{layout}: GPU and CPU agree on {:.3}% of pixels",
            a * 100.0
        );
    }
}

#[test]
fn instanced_groups_are_traversed_in_object_space() {
    let tris = sibenik();
    let mut bvh = Bvh::default();
    bvh.insert_triangles(&tris[..30_000]).unwrap();
    let g = bvh
        .insert_group(&tris[30_000..], Affine3A::IDENTITY, true)
        .unwrap();
    bvh.set_group_transform(
        g,
        Affine3A::from_rotation_translation(Quat::from_rotation_y(0.4), Vec3::new(3.0, 1.0, -2.0)),
    )
    .unwrap();
    assert!(bvh.is_group_whole(g).unwrap());
    let b = bvh.bounds();
    let view = View::looking_at(
        b.center() + Vec3::new(0.0, 0.2, 1.0) * (b.max - b.min).length(),
        b.center(),
        96,
        96,
    );
    for (layout, gpu) in every_layout(&bvh, &view) {
        let a = agreement(&bvh, &view, &gpu);
        assert!(
            a >= 0.999,
            "{layout}: GPU and CPU agree on {:.3}% of pixels",
            a * 100.0
        );
    }
}

/// A one-pixel view whose only ray leaves `origin` along `direction` exactly (its zero components
/// stay zero: the pixel's offsets along the empty horizontal and vertical are zero).
fn single_ray(origin: Vec3, direction: Vec3) -> View {
    View {
        origin,
        lower_left: direction,
        horizontal: Vec3::ZERO,
        vertical: Vec3::ZERO,
        width: 1,
        height: 1,
    }
}

#[test]
fn a_ray_along_an_axis_in_a_box_face_plane_meets_the_box() {
    // Triangles at z = 0.6 whose boxes end at y = 2 from below and begin there from above, and
    // one far away so the tree has inner boxes; rays along ±z at y = 2 exactly lie in those
    // boxes' faces (their y and x components are zero) and touch the triangles' edges.
    let below = Triangle::new(
        Vec3::new(8.0, 2.0, 0.6),
        Vec3::new(9.0, 2.0, 0.6),
        Vec3::new(8.0, 1.0, 0.6),
    );
    let above = Triangle::new(
        Vec3::new(8.0, 2.0, 0.6),
        Vec3::new(9.0, 2.0, 0.6),
        Vec3::new(8.0, 3.0, 0.6),
    );
    let far = Triangle::new(
        Vec3::splat(50.0),
        Vec3::new(51.0, 50.0, 50.0),
        Vec3::splat(51.0),
    );
    let rays = [
        (Vec3::new(8.25, 2.0, -1.0), Vec3::Z),
        (Vec3::new(8.25, 2.0, 3.0), Vec3::NEG_Z),
        // In the plane x = 8 of both boxes' minimum x.
        (Vec3::new(8.0, 1.5, -1.0), Vec3::Z),
        // Beside the boxes, parallel to them: a miss.
        (Vec3::new(8.25, 3.5, -1.0), Vec3::Z),
    ];
    for tris in [vec![below, far], vec![above, far], vec![below, above, far]] {
        let mut bvh = Bvh::new(BvhConfig::default());
        bvh.insert_triangles(&tris).unwrap();
        for (o, d) in rays {
            let view = single_ray(o, d);
            let ray = view.ray(0, 0);
            let brute = bvh.brute_force_closest_hit(&ray);
            // The two triangles touching along the ray are met at the same distance: either.
            let ties: Vec<u32> = brute.map_or(vec![u32::MAX], |h| {
                (0..tris.len() as u32)
                    .filter(|&t| {
                        treelight_bvh::RayData::new(&ray)
                            .hit_triangle(&tris[t as usize], 0.0, f32::INFINITY)
                            .is_some_and(|(d, _, _)| (d - h.t).abs() <= 1e-6 * h.t)
                    })
                    .collect()
            });
            for (layout, gpu) in every_layout(&bvh, &view) {
                assert!(
                    ties.contains(&gpu[0]),
                    "{layout}: the ray from {o} along {d} over {} triangles met {} (brute force: {ties:?})",
                    tris.len(),
                    gpu[0]
                );
            }
        }
    }
}

#[test]
fn triangles_met_at_the_same_distance_resolve_alike_in_any_tree() {
    // Two overlapping triangles in the plane z = 1, and a wall standing on a floor: rays through
    // the overlap, and along the wall's foot, meet two triangles at exactly the same distance.
    // Inserted in other orders, the triangles land elsewhere in the tree and are visited in
    // another order; the triangle met must stay the same.
    let overlap_a = Triangle::new(
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(2.0, 0.0, 1.0),
        Vec3::new(0.0, 2.0, 1.0),
    );
    let overlap_b = Triangle::new(
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(2.0, 2.0, 1.0),
        Vec3::new(0.0, 2.0, 1.0),
    );
    let floor = Triangle::new(
        Vec3::new(-4.0, -4.0, -3.0),
        Vec3::new(6.0, -4.0, -3.0),
        Vec3::new(-4.0, 6.0, -3.0),
    );
    let wall = Triangle::new(
        Vec3::new(1.0, -4.0, -3.0),
        Vec3::new(1.0, 4.0, -3.0),
        Vec3::new(1.0, 0.0, -1.0),
    );
    let far = Triangle::new(
        Vec3::splat(50.0),
        Vec3::new(51.0, 50.0, 50.0),
        Vec3::splat(51.0),
    );
    let shapes = [overlap_a, overlap_b, floor, wall, far];
    let rays = [
        (Vec3::new(0.5, 0.5, 5.0), Vec3::NEG_Z),
        (Vec3::new(0.25, 1.0, 3.0), Vec3::new(0.125, 0.25, -1.0)),
        // To the wall's foot at (1, 0.5, -3), met by the floor and the wall.
        (Vec3::new(0.0, 0.5, -1.0), Vec3::new(1.0, 0.0, -2.0)),
        (Vec3::new(3.0, -0.5, -2.0), Vec3::new(-2.0, 0.0, -1.0)),
    ];
    let orders: [[usize; 5]; 4] = [
        [0, 1, 2, 3, 4],
        [4, 3, 2, 1, 0],
        [1, 0, 4, 3, 2],
        [2, 4, 0, 3, 1],
    ];
    for (o, d) in rays {
        let view = single_ray(o, d);
        let mut met: Option<(String, usize)> = None;
        for order in orders {
            let tris: Vec<Triangle> = order.iter().map(|&k| shapes[k]).collect();
            let mut bvh = Bvh::new(BvhConfig::default());
            bvh.insert_triangles(&tris).unwrap();
            for (layout, gpu) in every_layout(&bvh, &view) {
                assert_ne!(
                    gpu[0],
                    u32::MAX,
                    "{layout}: the ray from {o} along {d} missed"
                );
                let shape = order[gpu[0] as usize];
                let seen = format!("{layout}, order {order:?}");
                match &met {
                    None => met = Some((seen, shape)),
                    Some((first, s)) => assert_eq!(
                        *s, shape,
                        "the ray from {o} along {d} met shape {s} ({first}) and shape {shape} ({seen})"
                    ),
                }
            }
        }
    }
}
