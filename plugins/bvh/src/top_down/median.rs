//! Spatial median: split the centroid bounds in the middle of their longest axis. The reference
//! builder, and the builder of IncrUPB's bBVHs.

use super::BuiltTree;
use super::prims::{Box3A, Prims};
use crate::Aabb;
use crate::tree::node::{InnerNode, NONE, NodeRef};

/// Spatial median builder, one primitive per leaf.
pub fn build_median(boxes: &[Aabb]) -> BuiltTree {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    build_median_over(&Prims::new(boxes), &mut order)
}

/// The spatial median tree over the primitives `order` lists, reordering `order` in place; leaves
/// are `NodeRef::leaf(primitive)`.
pub(crate) fn build_median_over(prims: &Prims, order: &mut [u32]) -> BuiltTree {
    let mut nodes = vec![InnerNode::UNLINKED; order.len().saturating_sub(1)];
    let root = build_median_into(prims, order, &mut nodes);
    BuiltTree { nodes, root }
}

/// A range of the order still to split, whose inner node is already written (with its box).
struct Task {
    start: u32,
    end: u32,
    node: u32,
    centroids: Box3A,
}

/// [`build_median_over`] writing the tree's `order.len() - 1` inner nodes into `nodes` (so that
/// IncrUPB builds a step's bBVHs into one array); returns the root.
///
/// Each split is one branch-free partition pass and one pass measuring both halves. Slots are
/// numbered in pre-order, computed when a node splits, so every task carries only its range, its
/// slot and its centres' bounds, and a range of two becomes its two leaves without a task. This
/// builder is much of IncrUPB's building side, so it is kept leaner than the binned builder's
/// general top-down loop, whose tasks carry both sides' measures.
pub(crate) fn build_median_into(
    prims: &Prims,
    order: &mut [u32],
    nodes: &mut [InnerNode],
) -> NodeRef {
    let n = order.len();
    debug_assert_eq!(nodes.len(), n.saturating_sub(1));
    if n <= 1 {
        return order.first().map_or(NodeRef::NONE, |&p| NodeRef::leaf(p));
    }
    let (bounds, centroids) = prims.bounds(order);
    nodes[0] = InnerNode {
        aabb: bounds.aabb(),
        children: [NodeRef::leaf(order[0]), NodeRef::leaf(order[n - 1])],
        parent: NONE,
    };
    let mut stack = Vec::with_capacity(32);
    if n > 2 {
        stack.push(Task {
            start: 0,
            end: n as u32,
            node: 0,
            centroids,
        });
    }
    while let Some(t) = stack.pop() {
        let range = &mut order[t.start as usize..t.end as usize];
        let m = range.len();
        let axis = t.centroids.largest_axis();
        let mut i = prims.split_at(range, axis, t.centroids.center()[axis]);
        if i == 0 || i == m {
            // All centres coincide (or round to one side): halve the range as it stands.
            i = m / 2;
        }
        let mid = t.start + i as u32;
        let mut children = [NodeRef::NONE; 2];
        // Slots in pre-order: a subtree of k leaves has k - 1 inner nodes, so the left child
        // takes the slot after its parent and the right one the slot after the left subtree's.
        let slots = [t.node + 1, t.node + i as u32];
        for (slot, (s, e)) in [(t.start, mid), (mid, t.end)].into_iter().enumerate() {
            let half = &order[s as usize..e as usize];
            let k = slots[slot];
            children[slot] = match half.len() {
                1 => NodeRef::leaf(half[0]),
                2 => {
                    // A pair is its two leaves: measured by one union, never split.
                    let [a, b] = [half[0], half[1]];
                    let aabb = prims.boxes[a as usize]
                        .union(&prims.boxes[b as usize])
                        .aabb();
                    nodes[k as usize] = InnerNode {
                        aabb,
                        children: [NodeRef::leaf(a), NodeRef::leaf(b)],
                        parent: t.node,
                    };
                    NodeRef::inner(k)
                }
                _ => {
                    let (bounds, centroids) = prims.bounds(half);
                    nodes[k as usize] = InnerNode {
                        aabb: bounds.aabb(),
                        children: [NodeRef::NONE; 2],
                        parent: t.node,
                    };
                    stack.push(Task {
                        start: s,
                        end: e,
                        node: k,
                        centroids,
                    });
                    NodeRef::inner(k)
                }
            };
        }
        nodes[t.node as usize].children = children;
    }
    NodeRef::inner(0)
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

    /// The primitives under `r`.
    fn leaves(tree: &BuiltTree, r: NodeRef, out: &mut Vec<u32>) {
        match r.kind() {
            NodeKind::Inner => {
                for c in tree.nodes[r.index() as usize].children {
                    leaves(tree, c, out);
                }
            }
            _ => out.push(r.index()),
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
            check(&build_median(&b), &b);
            // Over part of a larger array, in an order not the identity.
            let mut order: Vec<u32> = (0..n as u32).rev().collect();
            check(&build_median_over(&Prims::new(&b), &mut order), &b);
        }
        // Every centre in one place: the ranges are halved as they stand.
        let same = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 33];
        check(&build_median(&same), &same);
    }

    #[test]
    fn every_node_splits_its_centres_at_the_middle_of_their_longest_axis() {
        let b = boxes(500, 9);
        let tree = build_median(&b);
        for node in &tree.nodes {
            let [mut l, mut r] = [Vec::new(), Vec::new()];
            leaves(&tree, node.children[0], &mut l);
            leaves(&tree, node.children[1], &mut r);
            if l.len() + r.len() == 2 {
                // A pair is two leaves whichever way round.
                continue;
            }
            let mut cb = Aabb::EMPTY;
            for &p in l.iter().chain(&r) {
                cb.grow(b[p as usize].center());
            }
            let axis = cb.largest_axis();
            let pivot = cb.center()[axis];
            let below = |p: &u32| b[*p as usize].center()[axis] < pivot;
            assert!(
                l.iter().all(below) && !r.iter().any(below),
                "a median split"
            );
        }
    }
}
