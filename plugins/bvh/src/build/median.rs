//! Spatial median: split the centroid bounds in the middle of their longest axis. The reference
//! builder, and, finishing ranges of a few primitives by their SAH-best partition, the builder of
//! IncrUPB's bBVHs.

use super::BuiltTree;
use super::binned::{SMALL, Side, split_small};
use super::prims::Prims;
use crate::Aabb;
use crate::node::{InnerNode, NONE, NodeRef};

/// Spatial median builder, one primitive per leaf.
pub fn build_median(boxes: &[Aabb]) -> BuiltTree {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    build_median_over(&Prims::new(boxes), &mut order, 1)
}

/// A range still to be split, with the bounds of its boxes and centres.
struct Pending {
    start: usize,
    end: usize,
    parent: u32,
    slot: usize,
    side: Side,
}

/// The spatial median tree over the primitives `order` lists, reordering `order` in place; leaves
/// are `NodeRef::leaf(primitive)`. A range of at most `exact` primitives (up to [`SMALL`]) is split
/// by the cheapest of all its partitions instead: near the leaves a median split often leaves a
/// triangle's box overlapping its neighbour's where some other grouping would not, and trying
/// every grouping of four costs a few unions.
///
/// Each split is one branch-free partition pass and one pass measuring both halves, so this costs
/// a fraction of a binned SAH build, whose every node fills and sweeps bins on three axes.
pub(crate) fn build_median_over(prims: &Prims, order: &mut [u32], exact: usize) -> BuiltTree {
    let n = order.len();
    if n <= 1 {
        return BuiltTree {
            nodes: Vec::new(),
            root: order.first().map_or(NodeRef::NONE, |&p| NodeRef::leaf(p)),
        };
    }
    let exact = exact.min(SMALL);
    let mut nodes: Vec<InnerNode> = Vec::with_capacity(n - 1);
    let mut stack = vec![Pending {
        start: 0,
        end: n,
        parent: NONE,
        slot: 0,
        side: Side::of(prims, order),
    }];
    while let Some(r) = stack.pop() {
        let m = r.end - r.start;
        let me = if m == 1 {
            NodeRef::leaf(order[r.start])
        } else {
            let range = &mut order[r.start..r.end];
            let [left, right] = if m <= exact {
                split_small(prims, range)
            } else {
                let cb = &r.side.centroids;
                let axis = cb.largest_axis();
                let mut i = prims.split_at(range, axis, cb.center()[axis]);
                if i == 0 || i == m {
                    // All centres coincide (or round to one side): halve the range as it stands.
                    i = m / 2;
                }
                let (l, r) = range.split_at(i);
                [Side::of(prims, l), Side::of(prims, r)]
            };
            let k = nodes.len() as u32;
            nodes.push(InnerNode {
                aabb: r.side.bounds.aabb(),
                children: [NodeRef::NONE; 2],
                parent: r.parent,
            });
            let mid = r.start + left.count;
            stack.push(Pending {
                start: mid,
                end: r.end,
                parent: k,
                slot: 1,
                side: right,
            });
            stack.push(Pending {
                start: r.start,
                end: mid,
                parent: k,
                slot: 0,
                side: left,
            });
            NodeRef::inner(k)
        };
        if r.parent != NONE {
            nodes[r.parent as usize].children[r.slot] = me;
        }
    }
    BuiltTree {
        nodes,
        root: NodeRef::inner(0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::NodeKind;
    use glam::Vec3;

    /// Checks `tree` over `boxes`: every primitive in one leaf, every box the union of its
    /// children's, parent links agree.
    fn check(tree: &BuiltTree, boxes: &[Aabb]) {
        let n = boxes.len();
        assert_eq!(tree.nodes.len(), n.saturating_sub(1));
        let mut seen = vec![0u32; n];
        if n == 1 {
            assert_eq!(tree.root, NodeRef::leaf(0));
            return;
        }
        for (k, node) in tree.nodes.iter().enumerate() {
            let mut u = Aabb::EMPTY;
            for c in node.children {
                let b = match c.kind() {
                    NodeKind::Inner => {
                        assert_eq!(tree.nodes[c.index() as usize].parent, k as u32);
                        tree.nodes[c.index() as usize].aabb
                    }
                    _ => {
                        seen[c.index() as usize] += 1;
                        boxes[c.index() as usize]
                    }
                };
                u = u.union(&b);
            }
            assert_eq!(u, node.aabb, "a node's box is its children's union");
        }
        assert!(seen.iter().all(|&s| s == 1), "every primitive in one leaf");
        assert_eq!(tree.nodes[tree.root.index() as usize].parent, NONE);
    }

    fn leaves(tree: &BuiltTree, r: NodeRef) -> usize {
        match r.kind() {
            NodeKind::Inner => tree.nodes[r.index() as usize]
                .children
                .iter()
                .map(|&c| leaves(tree, c))
                .sum(),
            _ => 1,
        }
    }

    fn boxes(n: usize, seed: u64) -> Vec<Aabb> {
        let mut rnd = crate::test_random(seed);
        (0..n)
            .map(|_| {
                let c = Vec3::new(rnd(), rnd(), rnd()) * 10.0;
                Aabb::new(c, c + Vec3::new(rnd(), rnd(), rnd()))
            })
            .collect()
    }

    #[test]
    fn trees_are_whole_for_any_size_and_degenerate_boxes() {
        for n in [1usize, 2, 3, 4, 5, 8, 17, 64, 300] {
            let mut b = boxes(n, n as u64);
            if n > 2 {
                // Coinciding centres and a flat box.
                b[0] = b[n - 1];
                b[n / 2].max.y = b[n / 2].min.y;
            }
            for exact in [1, SMALL] {
                let mut order: Vec<u32> = (0..n as u32).collect();
                check(&build_median_over(&Prims::new(&b), &mut order, exact), &b);
            }
            check(&build_median(&b), &b);
        }
        // Every centre in one place: the ranges are halved as they stand.
        let same = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 33];
        check(&build_median(&same), &same);
    }

    #[test]
    fn a_few_primitives_are_split_by_their_cheapest_partition() {
        for n in 3..=SMALL {
            for seed in 0..50u64 {
                let b = boxes(n, 100 + seed);
                let mut order: Vec<u32> = (0..n as u32).collect();
                let tree = build_median_over(&Prims::new(&b), &mut order, SMALL);
                let root = &tree.nodes[tree.root.index() as usize];
                let side = |c: NodeRef| match c.kind() {
                    NodeKind::Inner => (
                        tree.nodes[c.index() as usize].aabb.area(),
                        leaves(&tree, c) as f32,
                    ),
                    _ => (b[c.index() as usize].area(), 1.0),
                };
                let cost = root
                    .children
                    .map(side)
                    .iter()
                    .map(|(a, k)| a * k)
                    .sum::<f32>();
                // Every partition into two non-empty sides, by brute force.
                let best = (1u32..(1 << (n - 1)))
                    .map(|mask| {
                        let (mut l, mut r, mut nl) = (Aabb::EMPTY, Aabb::EMPTY, 0.0);
                        for (k, x) in b.iter().enumerate() {
                            if mask & (1 << k) != 0 {
                                l = l.union(x);
                                nl += 1.0;
                            } else {
                                r = r.union(x);
                            }
                        }
                        l.area() * nl + r.area() * (n as f32 - nl)
                    })
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    cost <= best * (1.0 + 1e-5),
                    "n {n} seed {seed}: {cost} > {best}"
                );
            }
        }
    }
}
