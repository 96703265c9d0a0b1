//! The other GPU layouts hold the same tree. The 4-wide one (`Bvh::gpu_wide_layout`): every node has
//! two to four children whose boxes hold what lies under them. The depth-first one
//! (`Bvh::gpu_depth_first_layout`): every live node once, siblings adjacent, the root first. A
//! traversal of either's records finds the same closest hits as brute force, through baked
//! triangles, groups kept whole and shared instances.

mod support;

use support::{Rng, rays, soup};
use treelight_bvh::glam::{Affine3A, Quat, Vec3};
use treelight_bvh::{
    Aabb, Bvh, DepthFirstLayout, GpuInstance, NodeKind, NodeRef, Ray, RayData, Triangle, WideLayout,
};

fn apply(rows: &[[f32; 4]; 3], p: Vec3, w: f32) -> Vec3 {
    let r = |k: usize| Vec3::new(rows[k][0], rows[k][1], rows[k][2]).dot(p) + rows[k][3] * w;
    Vec3::new(r(0), r(1), r(2))
}

fn stored(bvh: &Bvh, t: u32) -> Triangle {
    let g = bvh.gpu_triangle(t);
    Triangle::new(g.v0.into(), g.v1.into(), g.v2.into())
}

/// Closest hit distance through a layout's records (every node visited: no pruning), given the
/// root, the children of an inner record and the instances.
fn closest(
    bvh: &Bvh,
    root: u32,
    children: impl Fn(u32) -> Vec<u32>,
    instances: &[GpuInstance],
    ray: &Ray,
) -> Option<f32> {
    let mut best: Option<f32> = None;
    let mut stack: Vec<(u32, Option<&GpuInstance>)> = vec![(root, None)];
    while let Some((r, inst)) = stack.pop() {
        let r = NodeRef(r);
        match r.kind() {
            NodeKind::None => {}
            NodeKind::Inner => {
                for c in children(r.index()) {
                    if c != NodeRef::NONE.0 {
                        stack.push((c, inst));
                    }
                }
            }
            NodeKind::Leaf => {
                let tri = stored(bvh, r.index());
                let local = match inst {
                    Some(i) => Ray::new(
                        apply(&i.world_to_object, ray.origin, 1.0),
                        apply(&i.world_to_object, ray.dir, 0.0),
                    ),
                    None => *ray,
                };
                if let Some((t, _, _)) = RayData::new(&local).hit_triangle(&tri, 0.0, f32::INFINITY)
                    && best.is_none_or(|b| t < b)
                {
                    best = Some(t);
                }
            }
            NodeKind::Instance => {
                let i = &instances[r.index() as usize];
                stack.push((i.root, Some(i)));
            }
        }
    }
    best
}

fn wide_closest(bvh: &Bvh, w: &WideLayout, ray: &Ray) -> Option<f32> {
    closest(
        bvh,
        w.root,
        |i| w.nodes[i as usize].refs.to_vec(),
        &w.instances,
        ray,
    )
}

fn depth_first_closest(bvh: &Bvh, d: &DepthFirstLayout, ray: &Ray) -> Option<f32> {
    let children = |i: u32| {
        let n = &d.nodes[i as usize];
        vec![n.a_ref, n.b_ref]
    };
    closest(bvh, d.root, children, &d.instances, ray)
}

/// Every wide node: two to four children, and each child's box holds the boxes below it.
fn check_boxes(bvh: &Bvh, w: &WideLayout) {
    fn below(bvh: &Bvh, w: &WideLayout, r: NodeRef) -> Aabb {
        match r.kind() {
            NodeKind::Inner => {
                let n = &w.nodes[r.index() as usize];
                let mut b = Aabb::EMPTY;
                let mut children = 0;
                for k in 0..4 {
                    if n.refs[k] == NodeRef::NONE.0 {
                        continue;
                    }
                    children += 1;
                    let own = Aabb::new(
                        Vec3::new(n.min_x[k], n.min_y[k], n.min_z[k]),
                        Vec3::new(n.max_x[k], n.max_y[k], n.max_z[k]),
                    );
                    let inner = below(bvh, w, NodeRef(n.refs[k]));
                    assert!(
                        own.contains_box(&inner, 1e-4),
                        "{own:?} does not hold {inner:?}"
                    );
                    b = b.union(&own);
                }
                assert!((2..=4).contains(&children), "{children} children");
                b
            }
            // Leaves and instances keep the binary tree's references, and so its boxes.
            _ => bvh.aabb(r),
        }
    }
    if NodeRef(w.root).kind() == NodeKind::Inner {
        below(bvh, w, NodeRef(w.root));
    }
}

#[test]
fn the_wide_layout_finds_the_closest_hits_of_the_binary_tree() {
    let mut bvh = Bvh::default();
    bvh.insert_triangles(&soup(3_000, 11)).unwrap();
    // A group kept whole under a rotation, and two instances sharing its triangles.
    let part = soup(400, 12);
    let g = bvh
        .insert_group(&part, Affine3A::from_translation(Vec3::X * 20.0), true)
        .unwrap();
    let mut r = Rng(5);
    for _ in 0..2 {
        let place = Affine3A::from_scale_rotation_translation(
            Vec3::splat(r.range(0.5, 1.5)),
            Quat::from_rotation_y(r.range(0.0, 6.0)),
            r.vec3(-25.0, 25.0),
        );
        bvh.insert_instance(g, place).unwrap();
    }
    bvh.validate().unwrap();
    let w = bvh.gpu_wide_layout();
    // Fuller nodes: well under the binary tree's count.
    assert!(
        (w.nodes.len() as u32) * 2 < bvh.inner_count(),
        "{} wide nodes for {} binary ones",
        w.nodes.len(),
        bvh.inner_count()
    );
    check_boxes(&bvh, &w);
    let d = bvh.gpu_depth_first_layout();
    // Every live node once, the root first, and both children of a node in adjacent records.
    assert_eq!(d.nodes.len() as u32, bvh.inner_count());
    assert_eq!(d.root, NodeRef::inner(0).0);
    for n in &d.nodes {
        let (a, b) = (NodeRef(n.a_ref), NodeRef(n.b_ref));
        if a.is_inner() && b.is_inner() {
            assert_eq!(b.index(), a.index() + 1, "siblings apart");
        }
    }
    for ray in rays(2_000, 3, 30.0) {
        let expected = bvh.brute_force_closest_hit(&ray).map(|h| h.t);
        for (layout, got) in [
            ("wide", wide_closest(&bvh, &w, &ray)),
            ("depth first", depth_first_closest(&bvh, &d, &ray)),
        ] {
            match (got, expected) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    assert!((a - b).abs() <= 1e-4 * b.max(1.0), "{layout}: {a} vs {b}")
                }
                (a, b) => panic!("{layout} {a:?} vs brute force {b:?} for {ray:?}"),
            }
        }
    }
}
