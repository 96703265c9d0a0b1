//! Greedy agglomerative clustering for the small bBVHs of IncrUPB: the two clusters whose union box
//! has the least surface area are merged until one is left (Walter et al. 2008, exact form). For
//! the handful of triangles of a typical coherent batch this costs a fraction of a top-down build:
//! no sorting, no binning, no stack. The distances are kept in a matrix whose rows are measured and
//! searched four lanes at a time over a fixed width, so that no loop's trip count and no comparison
//! of two distances is a branch the processor has to guess.

use super::prims::Prims;
use crate::node::{InnerNode, NONE, NodeKind, NodeRef};
use glam::Vec4;

/// Batches of at most this many primitives are clustered.
pub(crate) const AGGLOMERATIVE_MAX: usize = 32;

/// One value per cluster slot, in lanes of four.
#[derive(Clone, Copy)]
#[repr(C, align(16))]
struct Row<const N: usize>([f32; N]);

impl<const N: usize> Row<N> {
    const FAR: Self = Row([f32::INFINITY; N]);

    #[inline(always)]
    fn lanes(&self, c: usize) -> Vec4 {
        Vec4::from_slice(&self.0[4 * c..4 * c + 4])
    }

    /// The smallest value and the first slot holding it.
    #[inline(always)]
    fn min(&self) -> (f32, usize) {
        let mut m = Vec4::INFINITY;
        for c in 0..N / 4 {
            m = m.min(self.lanes(c));
        }
        let v = m.min_element();
        let splat = Vec4::splat(v);
        let mut mask = 0u32;
        for c in 0..N / 4 {
            mask |= self.lanes(c).cmpeq(splat).bitmask() << (4 * c);
        }
        (v, mask.trailing_zeros() as usize)
    }
}

/// Slots no cluster's nearest can be: marks a slot that holds no cluster.
const NOBODY: usize = usize::MAX;

/// The tree over the primitives `order` lists (2 to [`AGGLOMERATIVE_MAX`]), its `order.len() - 1`
/// inner nodes written into `nodes` (a slice of IncrUPB's node array for the step), their parent
/// links local too, the root's being `NONE`; leaves are `NodeRef::leaf(primitive)`. Returns the
/// root.
pub(crate) fn build_agglomerative_into(
    prims: &Prims,
    order: &[u32],
    nodes: &mut [InnerNode],
) -> NodeRef {
    debug_assert!((2..=AGGLOMERATIVE_MAX).contains(&order.len()));
    debug_assert_eq!(nodes.len(), order.len() - 1);
    // The narrowest matrix that fits: its width is every loop's trip count.
    match order.len() {
        0..=8 => cluster::<8>(prims, order, nodes),
        9..=16 => cluster::<16>(prims, order, nodes),
        _ => cluster::<32>(prims, order, nodes),
    }
}

/// Clusters into `nodes`, which holds exactly one node per merge, and returns the root.
fn cluster<const N: usize>(prims: &Prims, order: &[u32], nodes: &mut [InnerNode]) -> NodeRef {
    let m = order.len();
    // The clusters' boxes by axis, so that one cluster is measured against four at once.
    let mut lo = [Row::<N>::FAR; 3];
    let mut hi = [Row::<N>([f32::NEG_INFINITY; N]); 3];
    let mut refs = [NodeRef::NONE; N];
    for (k, &p) in order.iter().enumerate() {
        let b = &prims.boxes[p as usize];
        for axis in 0..3 {
            lo[axis].0[k] = b.min[axis];
            hi[axis].0[k] = b.max[axis];
        }
        refs[k] = NodeRef::leaf(p);
    }
    // The surface area of cluster `x`'s union with each of the first `k` clusters; itself and the
    // slots from `k` on are infinitely far.
    let measure = |lo: &[Row<N>; 3], hi: &[Row<N>; 3], x: usize, k: usize| {
        let xl = [lo[0].0[x], lo[1].0[x], lo[2].0[x]].map(Vec4::splat);
        let xh = [hi[0].0[x], hi[1].0[x], hi[2].0[x]].map(Vec4::splat);
        let (me, count) = (Vec4::splat(x as f32), Vec4::splat(k as f32));
        let mut out = Row::<N>::FAR;
        for c in 0..N / 4 {
            let d: [Vec4; 3] =
                std::array::from_fn(|a| hi[a].lanes(c).max(xh[a]) - lo[a].lanes(c).min(xl[a]));
            let area = 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
            let slot = Vec4::splat(4.0 * c as f32) + Vec4::new(0.0, 1.0, 2.0, 3.0);
            let far = slot.cmpeq(me) | slot.cmpge(count);
            Vec4::select(far, Vec4::INFINITY, area).write_to_slice(&mut out.0[4 * c..4 * c + 4]);
        }
        out
    };
    let mut dist = [Row::<N>::FAR; N];
    // Each cluster's nearest other cluster and their union's area.
    let mut near = [NOBODY; N];
    let mut near_area = Row::<N>::FAR;
    for x in 0..m {
        dist[x] = measure(&lo, &hi, x, m);
        (near_area.0[x], near[x]) = dist[x].min();
    }
    let mut k = m;
    for t in 0..m - 1 {
        let i = near_area.min().1;
        let j = near[i];
        let (a, b) = (i.min(j), i.max(j));
        let mut u = [[0.0f32; 3]; 2];
        for axis in 0..3 {
            u[0][axis] = lo[axis].0[a].min(lo[axis].0[b]);
            u[1][axis] = hi[axis].0[a].max(hi[axis].0[b]);
        }
        nodes[t] = InnerNode {
            aabb: crate::Aabb::new(u[0].into(), u[1].into()),
            children: [refs[a], refs[b]],
            parent: NONE,
        };
        for c in [refs[a], refs[b]] {
            if c.kind() == NodeKind::Inner {
                nodes[c.index() as usize].parent = t as u32;
            }
        }
        // The merged cluster takes `a`'s slot and the last cluster moves into `b`'s (when `b` is
        // the last, the moves copy it onto itself and the slot then dies).
        k -= 1;
        for axis in 0..3 {
            lo[axis].0[a] = u[0][axis];
            hi[axis].0[a] = u[1][axis];
            lo[axis].0[b] = lo[axis].0[k];
            hi[axis].0[b] = hi[axis].0[k];
        }
        refs[a] = NodeRef::inner(t as u32);
        refs[b] = refs[k];
        near[b] = near[k];
        near_area.0[b] = near_area.0[k];
        near[k] = NOBODY;
        near_area.0[k] = f32::INFINITY;
        // Columns move as the rows did; row `a` is written after them, so that the column move
        // does not overwrite its distance to the cluster now in `b` (the matrix stays symmetric).
        dist[b] = dist[k];
        let row_a = measure(&lo, &hi, a, k);
        for (x, row) in dist.iter_mut().enumerate() {
            row.0[b] = row.0[k];
            row.0[k] = f32::INFINITY;
            row.0[a] = row_a.0[x];
        }
        dist[a] = row_a;
        debug_assert!(
            (0..k).all(|x| (0..k).all(|y| dist[x].0[y].to_bits() == dist[y].0[x].to_bits())),
            "the distance matrix is symmetric"
        );
        (near_area.0[a], near[a]) = row_a.min();
        // A union with the merged cluster is no smaller than with either part, so it becomes
        // nobody's new nearest: only the clusters whose nearest was a part look again.
        for x in 0..k {
            let n = near[x];
            if x != a && (n == a || n == b) {
                (near_area.0[x], near[x]) = dist[x].min();
            } else if n == k {
                near[x] = b;
            }
        }
    }
    NodeRef::inner(m as u32 - 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Aabb;
    use crate::build::BuiltTree;
    use glam::Vec3;

    /// The total inner-node area of greedy clustering done the plain way: every step measures every
    /// pair, in f64.
    fn naive_greedy_area(boxes: &[Aabb]) -> f64 {
        let area = |b: &Aabb| {
            let d = (b.max - b.min).as_dvec3();
            2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
        };
        let mut clusters = boxes.to_vec();
        let mut total = 0.0;
        while clusters.len() > 1 {
            let mut best = (f64::INFINITY, 0, 0);
            for i in 0..clusters.len() {
                for j in i + 1..clusters.len() {
                    let a = area(&clusters[i].union(&clusters[j]));
                    if a < best.0 {
                        best = (a, i, j);
                    }
                }
            }
            let (a, i, j) = best;
            total += a;
            clusters[i] = clusters[i].union(&clusters[j]);
            clusters.swap_remove(j);
        }
        total
    }

    fn build_agglomerative(prims: &Prims, order: &[u32]) -> BuiltTree {
        let mut nodes = vec![InnerNode::UNLINKED; order.len() - 1];
        let root = build_agglomerative_into(prims, order, &mut nodes);
        BuiltTree { nodes, root }
    }

    /// Checks the tree `build_agglomerative_into` made over `boxes` and returns its inner area.
    fn built_area(boxes: &[Aabb]) -> f64 {
        let m = boxes.len();
        let prims = Prims::new(boxes);
        let order: Vec<u32> = (0..m as u32).rev().collect();
        let BuiltTree { nodes, root } = build_agglomerative(&prims, &order);
        assert_eq!(nodes.len(), m - 1);
        assert_eq!(nodes[root.index() as usize].parent, NONE);
        let mut leaves = vec![0; m];
        let mut total = 0.0;
        for (k, n) in nodes.iter().enumerate() {
            let mut u = Aabb::EMPTY;
            for c in n.children {
                u = u.union(&match c.kind() {
                    NodeKind::Inner => {
                        assert_eq!(nodes[c.index() as usize].parent, k as u32, "parent link");
                        nodes[c.index() as usize].aabb
                    }
                    _ => {
                        leaves[c.index() as usize] += 1;
                        boxes[c.index() as usize]
                    }
                });
            }
            assert_eq!(u, n.aabb, "node {k} is its children's union, m = {m}");
            let d = (n.aabb.max - n.aabb.min).as_dvec3();
            total += 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        }
        assert!(leaves.iter().all(|&l| l == 1), "each primitive in one leaf");
        total
    }

    #[test]
    fn clustering_merges_the_pair_with_the_smallest_union_each_time() {
        let mut rnd = crate::test_random(0x2545_f491_4f6c_dd1d);
        // Many sets per size: a stale distance surfaces only when the cluster that lost it is
        // the one whose nearest merges away later.
        for m in (2..=AGGLOMERATIVE_MAX).flat_map(|m| std::iter::repeat_n(m, 40)) {
            let boxes: Vec<Aabb> = (0..m)
                .map(|_| {
                    let c = Vec3::new(rnd(), rnd(), rnd()) * 20.0;
                    Aabb::new(c, c + Vec3::new(rnd(), rnd(), rnd()) * 3.0)
                })
                .collect();
            let (got, want) = (built_area(&boxes), naive_greedy_area(&boxes));
            assert!(
                (got - want).abs() <= 1e-5 * want,
                "m = {m}: {got} against {want}"
            );
        }
    }

    #[test]
    fn coinciding_and_flat_boxes_still_give_a_whole_tree() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let flat = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0));
        let point = Aabb::new(Vec3::splat(2.0), Vec3::splat(2.0));
        for m in [2, 3, 8, 9, 16, 17, 32] {
            let boxes: Vec<Aabb> = (0..m).map(|k| [b, flat, point][k % 3]).collect();
            built_area(&boxes);
        }
    }
}
