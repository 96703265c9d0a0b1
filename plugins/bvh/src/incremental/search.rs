//! Branch-and-bound search for the sibling that minimises the SAH cost increase (Bittner et al.
//! 2013, as summarised in the paper's section 4.2), depth first with the nearer child first.
//!
//! The 2013 search pops candidates from a priority queue in order of their bound, which expands
//! the fewest nodes. Popping from a stack instead finds the same minimum, since a subtree is only
//! skipped when its bound cannot beat the best found so far, and the nearer-child-first descent
//! finds a tight best early. It expands a few more nodes, but each step is cheaper and its
//! branches are easier to predict than a heap's sifts.

use crate::tree::aabb::LaneBox;
use crate::tree::node::{NONE, NodeKind, NodeRef};
use crate::tree::scratch::SearchScratch;
use crate::{Aabb, Bvh};

impl Bvh {
    /// The node whose becoming the sibling of a node with box `l` increases the tree's total inner
    /// surface area the least. Exact with respect to the current tree. The tree must not be empty.
    pub fn find_best_sibling(&self, l: &Aabb, scratch: &mut SearchScratch) -> NodeRef {
        // The root is a candidate like any other, and the one every search may fall back on.
        self.find_best_sibling_from(l, self.root, scratch)
    }

    /// [`Bvh::find_best_sibling`] seeded with a candidate: `hint` (a node of the tree) is returned
    /// unless some node is strictly better. A re-insertion passes the position it came from, so
    /// the search only expands subtrees that could beat it instead of every subtree that could
    /// beat the root, and a node with nowhere better to go stays where it was.
    pub(crate) fn find_best_sibling_from(
        &self,
        l: &Aabb,
        hint: NodeRef,
        scratch: &mut SearchScratch,
    ) -> NodeRef {
        let q = LaneBox::new(l);
        let mut best = hint;
        let mut c_best = self.aabb(hint).union_area(l);
        let mut a = self.parent(hint);
        while a != NONE {
            let n = &self.inner[a as usize];
            let (u, s) = q.union_area_and_area(&n.aabb);
            c_best += u - s;
            a = n.parent;
        }
        let s_l = l.area();
        let root = self.root;
        if !root.is_inner() {
            return best;
        }
        let root_box = self.inner[root.index() as usize].aabb;
        // An expanded node's own cost is already counted; `c_i` is the cost it induces on its
        // children, a lower bound for everything below it. Children are costed when their parent
        // is expanded, not when they are popped: a leaf never enters the stack, a good child
        // lowers `c_best` before its sibling is considered, and each box is read once.
        let c_root = root_box.union_area(l) - root_box.area();
        if c_root + s_l >= c_best {
            return best;
        }
        let stack = &mut scratch.stack;
        let mut sp = 0;
        let (mut c_i, mut x) = (c_root, root);
        loop {
            // Each child's bound for its subtree; infinity for a leaf, which is costed here and
            // never expanded.
            let [left, right] = self.inner[x.index() as usize].children;
            macro_rules! cost {
                ($child:expr) => {{
                    let child: NodeRef = $child;
                    if child.kind() != NodeKind::Inner {
                        let c = c_i + q.union_area(&self.aabb(child));
                        if c < c_best {
                            best = child;
                            c_best = c;
                        }
                        f32::INFINITY
                    } else {
                        let (u, a) =
                            q.union_area_and_area(&self.inner[child.index() as usize].aabb);
                        let c = c_i + u;
                        if c < c_best {
                            best = child;
                            c_best = c;
                        }
                        c - a
                    }
                }};
            }
            let kl = cost!(left);
            let kr = cost!(right);
            // Nearer child first. A branch, not a select: the select made the next node's load
            // wait for both children's areas, and was slower despite fewer mispredictions.
            let (k1, n1, k2, n2) = if kr < kl {
                (kr, right, kl, left)
            } else {
                (kl, left, kr, right)
            };
            // The dearer child waits on the stack if it may still pay: written always, kept
            // only then, because as a branch this test was the queue version's least predictable
            // (a third of its mispredictions).
            if sp == stack.len() {
                stack.resize((2 * sp).max(4), (0.0, NodeRef::NONE));
            }
            stack[sp] = (k2, n2);
            sp += (k2 + s_l < c_best) as usize;
            if k1 + s_l < c_best {
                (c_i, x) = (k1, n1);
                continue;
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (k, n) = stack[sp];
                if k + s_l < c_best {
                    (c_i, x) = (k, n);
                    break;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The induced cost of `x` becoming the sibling of a node with box `l`, summed in f64 from `x`
    /// up: the reference the searches are checked against.
    fn induced_cost(bvh: &Bvh, x: NodeRef, l: &Aabb) -> f64 {
        let mut c = bvh.aabb(x).union_area(l) as f64;
        let mut a = bvh.parent(x);
        while a != NONE {
            let b = bvh.inner[a as usize].aabb;
            c += b.union_area(l) as f64 - b.area() as f64;
            a = bvh.inner[a as usize].parent;
        }
        c
    }

    /// Every node of the tree, inner nodes and the leaves of its `tris` triangles: the candidates
    /// the brute force tries.
    fn all_nodes(bvh: &Bvh, tris: usize) -> Vec<NodeRef> {
        let mut inner = Vec::new();
        bvh.collect_inner(bvh.root, &mut inner);
        let mut nodes: Vec<NodeRef> = inner.iter().map(|&i| NodeRef::inner(i)).collect();
        nodes.extend((0..tris as u32).map(NodeRef::leaf));
        nodes
    }

    /// The least induced cost over `nodes`, by brute force.
    fn cheapest_cost(bvh: &Bvh, nodes: &[NodeRef], l: &Aabb) -> f64 {
        nodes
            .iter()
            .map(|&x| induced_cost(bvh, x, l))
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn searches_find_the_cheapest_sibling_of_all_nodes() {
        use crate::{BvhConfig, Triangle};
        use glam::Vec3;
        let mut rnd = crate::test_random(0x5851_f42d_4c95_7f2d);
        let mut v = || Vec3::new(rnd(), rnd(), rnd());
        let tris: Vec<Triangle> = (0..400)
            .map(|_| {
                let c = v() * 30.0;
                Triangle::new(c, c + v() * 2.0, c + v() * 2.0)
            })
            .collect();
        let mut bvh = Bvh::new(BvhConfig::incr_u());
        bvh.insert_triangles(&tris).unwrap();
        let nodes = all_nodes(&bvh, tris.len());
        let mut scratch = SearchScratch::default();
        for q in 0..300 {
            // Boxes from a triangle's size to a tenth of the scene, anywhere in it.
            let lo = v() * 32.0;
            let l = Aabb::new(lo, lo + v() * (0.5 + (q % 4) as f32 * 1.5));
            let best = cheapest_cost(&bvh, &nodes, &l);
            let tolerance = 1e-5 * best.max(1.0);
            let found = bvh.find_best_sibling(&l, &mut scratch);
            assert!(
                induced_cost(&bvh, found, &l) <= best + tolerance,
                "query {q}"
            );
            let hint = nodes[(v().x * nodes.len() as f32) as usize % nodes.len()];
            let seeded = bvh.find_best_sibling_from(&l, hint, &mut scratch);
            assert!(
                induced_cost(&bvh, seeded, &l) <= best + tolerance,
                "seeded query {q}"
            );
        }
        // Seeded with the cheapest node, the search keeps it.
        let l = tris[7].aabb();
        let cheapest = *nodes
            .iter()
            .min_by(|a, b| induced_cost(&bvh, **a, &l).total_cmp(&induced_cost(&bvh, **b, &l)))
            .unwrap();
        let c = induced_cost(&bvh, cheapest, &l);
        let seeded = bvh.find_best_sibling_from(&l, cheapest, &mut scratch);
        assert!(induced_cost(&bvh, seeded, &l) <= c + 1e-5 * c);
    }

    /// Triangles that nearly coincide make every subtree a candidate for a query inside them, so
    /// the search defers a subtree at almost every level: its stack grows past its first
    /// allocation, and the search must still find the exact minimum.
    #[test]
    fn searches_through_overlapping_subtrees_are_exact() {
        use crate::{BvhConfig, Triangle};
        use glam::Vec3;
        let mut rnd = crate::test_random(0x3c6e_f372_fe94_f82b);
        let tris: Vec<Triangle> = (0..300)
            .map(|_| {
                let mut j = || Vec3::new(rnd(), rnd(), rnd()) * 0.01;
                Triangle::new(j(), Vec3::X + j(), Vec3::new(0.0, 1.0, 1.0) + j())
            })
            .collect();
        let mut bvh = Bvh::new(BvhConfig::incr());
        bvh.insert_triangles(&tris).unwrap();
        bvh.validate().unwrap();
        let nodes = all_nodes(&bvh, tris.len());
        let mut scratch = SearchScratch::default();
        for q in 0..200 {
            let lo = Vec3::new(rnd(), rnd(), rnd()) * 0.8;
            let l = Aabb::new(lo, lo + Vec3::splat(0.05 + 0.1 * rnd()));
            let best = cheapest_cost(&bvh, &nodes, &l);
            let found = bvh.find_best_sibling(&l, &mut scratch);
            assert!(
                induced_cost(&bvh, found, &l) <= best + 1e-5 * best.max(1.0),
                "query {q}"
            );
        }
        assert!(scratch.stack.len() > 4, "the stack never grew");
    }
}
