//! The other GPU layouts hold the same tree. The 4-wide one (`Bvh::gpu_wide_layout`): every node has
//! two to four children whose boxes hold what lies under them. The depth-first one
//! (`Bvh::gpu_depth_first_layout`): every live node once, siblings adjacent, the root first. A
//! traversal of either's records finds the same closest hits as brute force, through baked
//! triangles, groups kept whole and shared instances. The path tracer's (`WideRecords`): each record
//! holds its node's children, an inner child without a record expanded into its two, each box as
//! decoded holding the engine's and at most a step wider on each side; so does the binary record
//! with its boxes in bytes.

mod support;

use proptest::prelude::*;
use support::{Rng, rays, soup};
use treelight_bvh::glam::{Affine3A, Quat, Vec3};
use treelight_bvh::{
    Aabb, Bvh, DepthFirstLayout, GpuCompressedBinaryNode, GpuCompressedNode, GpuInstance, GpuNode,
    GpuWideNode, NodeKind, NodeRef, Ray, RayData, Triangle, WideLayout, WideRecords,
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

/// `c` as decoded holds each of `w`'s child boxes exactly or a little wider (under 2/255 of the
/// record's extent on the axis, the coarsest step it can have, per side), with the same references.
fn check_compressed(w: &GpuWideNode, c: &GpuCompressedNode) {
    assert_eq!(w.refs, c.refs);
    let rows = [(w.min_x, w.max_x), (w.min_y, w.max_y), (w.min_z, w.max_z)];
    for (axis, (lo, hi)) in rows.into_iter().enumerate() {
        let used: Vec<usize> = (0..4).filter(|&k| w.refs[k] != NodeRef::NONE.0).collect();
        let bottom = used.iter().map(|&k| lo[k]).fold(f32::INFINITY, f32::min);
        let top = used
            .iter()
            .map(|&k| hi[k])
            .fold(f32::NEG_INFINITY, f32::max);
        let slack = (top - bottom) * 2.0 / 255.0 + f32::MIN_POSITIVE * 256.0;
        for &k in &used {
            let [a, b] = c.child_bounds(k, axis);
            assert!(
                a <= lo[k] && b >= hi[k],
                "child {k} axis {axis}: [{a}, {b}] does not hold [{}, {}]",
                lo[k],
                hi[k]
            );
            assert!(
                lo[k] - a <= slack && b - hi[k] <= slack,
                "child {k} axis {axis}: [{a}, {b}] loose around [{}, {}] (record {bottom}..{top})",
                lo[k],
                hi[k]
            );
        }
    }
}

/// The same for a binary record: `c` as decoded holds `n`'s two boxes, at most a step wider.
fn check_binary_compressed(n: &GpuNode, c: &GpuCompressedBinaryNode) {
    assert_eq!((n.a_ref, n.b_ref), (c.a_ref, c.b_ref));
    for axis in 0..3 {
        let want = [
            [n.a_min[axis], n.a_max[axis]],
            [n.b_min[axis], n.b_max[axis]],
        ];
        let bottom = want[0][0].min(want[1][0]);
        let top = want[0][1].max(want[1][1]);
        let slack = (top - bottom) * 2.0 / 255.0 + f32::MIN_POSITIVE * 256.0;
        for (k, [want_lo, want_hi]) in want.into_iter().enumerate() {
            let [lo, hi] = c.child_bounds(k, axis);
            assert!(
                lo <= want_lo && hi >= want_hi,
                "child {k} axis {axis}: [{lo}, {hi}] does not hold [{want_lo}, {want_hi}]"
            );
            assert!(
                want_lo - lo <= slack && hi - want_hi <= slack,
                "child {k} axis {axis}: [{lo}, {hi}] loose around [{want_lo}, {want_hi}]"
            );
        }
    }
}

/// Each record of the path tracer's layout (`WideRecords`): its node's children, an inner child
/// without a record of its own standing in for its two, each box as decoded holding the engine's,
/// an inner reference naming that node's record; and no node without a record under a parent
/// without one.
fn check_wide_nodes(bvh: &Bvh) {
    let layout = WideRecords::of(bvh);
    layout.check(bvh).unwrap();
    let slot_of = |x: u32| (0..layout.capacity()).find(|&s| layout.node_of(s) == Some(x));
    let mut records = 0;
    for s in 0..layout.capacity() {
        let rec = layout.record(bvh, s);
        let Some(x) = layout.node_of(s) else {
            assert_eq!(rec.refs, [NodeRef::NONE.0; 4], "free slot {s}");
            continue;
        };
        let node = bvh.gpu_node(x);
        let mut want = GpuWideNode::default();
        let mut k = 0;
        for c in [node.a_ref, node.b_ref].map(NodeRef) {
            let slots = if c.is_inner() && slot_of(c.index()).is_none() {
                let n = bvh.gpu_node(c.index());
                vec![n.a_ref, n.b_ref]
            } else {
                vec![c.0]
            };
            for r in slots.into_iter().map(NodeRef) {
                let named = if r.is_inner() {
                    NodeRef::inner(
                        slot_of(r.index()).expect("an expanded child's inner child has a record"),
                    )
                } else {
                    r
                };
                want.set_child(k, &bvh.aabb(r), named);
                k += 1;
            }
        }
        assert_eq!(rec.refs, want.refs, "record {s} of node {x}");
        check_compressed(&want, &rec);
        records += 1;
    }
    assert!(records > 0);
}

fn wide_node(boxes: &[([f32; 3], [f32; 3])]) -> GpuWideNode {
    let mut n = GpuWideNode::default();
    for (k, (lo, size)) in boxes.iter().enumerate() {
        let (lo, size) = (Vec3::from(*lo), Vec3::from(*size));
        n.set_child(k, &Aabb::new(lo, lo + size), NodeRef::leaf(k as u32));
    }
    n
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, .. ProptestConfig::default() })]

    /// Boxes anywhere from the origin to far away, from flat to huge, two to four per record.
    #[test]
    fn quantized_boxes_hold_their_children(
        scale in prop::sample::select(vec![1e-3f32, 1.0, 1e3, 1e6]),
        far in prop::sample::select(vec![0.0f32, 1.0, 1e4, -1e7]),
        boxes in prop::collection::vec(
            (prop::array::uniform3(-1.0f32..1.0), prop::array::uniform3(prop_oneof![Just(0.0f32), 0.0f32..2.0])),
            2..=4,
        ),
    ) {
        let boxes: Vec<([f32; 3], [f32; 3])> = boxes
            .into_iter()
            .map(|(lo, size)| (lo.map(|v| far + v * scale), size.map(|v| v * scale)))
            .collect();
        let w = wide_node(&boxes);
        check_compressed(&w, &GpuCompressedNode::quantize(&w));
        let corner = |k: usize, max: bool| {
            if max {
                [w.max_x[k], w.max_y[k], w.max_z[k]]
            } else {
                [w.min_x[k], w.min_y[k], w.min_z[k]]
            }
        };
        let n = GpuNode {
            a_min: corner(0, false),
            a_max: corner(0, true),
            b_min: corner(1, false),
            b_max: corner(1, true),
            a_ref: 1,
            b_ref: 2,
            ..GpuNode::default()
        };
        check_binary_compressed(&n, &GpuCompressedBinaryNode::quantize(&n));
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
    check_wide_nodes(&bvh);
    for node in bvh.gpu_nodes() {
        check_binary_compressed(&node, &GpuCompressedBinaryNode::quantize(&node));
    }
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
