//! Other libraries' builders, with one triangle per leaf, converted to the engine's layout so that our
//! Eq. 1 code costs them and our traversal traces them: only the tree differs.

use nalgebra::Point3;
use treelight_bvh::{Aabb, BuiltTree, InnerNode, NONE, NodeRef, Triangle};

/// A peer's tree over `tris` (leaf `k` is triangle `k`), or `None` for a name that is not a peer.
pub fn build(method: &str, tris: &[Triangle]) -> Option<BuiltTree> {
    let preset = match method {
        "obvhs-fastest" => obvhs::BvhBuildParams::fastest_build(),
        "obvhs-medium" => obvhs::BvhBuildParams::medium_build(),
        "obvhs-slowest" => obvhs::BvhBuildParams::very_slow_build(),
        "bvh" => return Some(bvh_crate(tris)),
        _ => return None,
    };
    Some(obvhs_tree(tris, preset))
}

fn obvhs_tree(tris: &[Triangle], preset: obvhs::BvhBuildParams) -> BuiltTree {
    let params = obvhs::BvhBuildParams {
        // One triangle per leaf, each in exactly one leaf (pre-splitting would reference a triangle
        // from several leaves, which the engine's layout does not have).
        max_prims_per_leaf: 1,
        pre_split: false,
        ..preset
    };
    let input: Vec<obvhs::triangle::Triangle> = tris
        .iter()
        .map(|t| {
            let v = t.v.map(|p| obvhs_glam::Vec3A::new(p.x, p.y, p.z));
            obvhs::triangle::Triangle {
                v0: v[0],
                v1: v[1],
                v2: v[2],
            }
        })
        .collect();
    let mut core = std::time::Duration::ZERO;
    let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&input, params, &mut core);
    if bvh.nodes.is_empty() {
        return BuiltTree::default();
    }
    convert(|i| {
        let n = &bvh.nodes[i];
        if n.prim_count > 0 {
            PeerNode::Leaf(bvh.primitive_indices[n.first_index as usize])
        } else {
            let first = n.first_index as usize;
            PeerNode::Inner([first, first + 1])
        }
    })
}

/// A peer's node as the conversion reads it: a leaf's triangle, or an inner node's two children.
enum PeerNode {
    Leaf(u32),
    Inner([usize; 2]),
}

/// The engine's layout of a peer's tree whose root is node 0, inner nodes numbered in the order
/// they are reached. Boxes are left empty: [`treelight_bvh::Bvh::from_built`] recomputes them all
/// from the triangles.
fn convert(node: impl Fn(usize) -> PeerNode) -> BuiltTree {
    let mut nodes: Vec<InnerNode> = Vec::new();
    // (their node, our parent, child slot)
    let mut stack = vec![(0usize, NONE, 0usize)];
    while let Some((i, parent, slot)) = stack.pop() {
        let me = match node(i) {
            PeerNode::Leaf(t) => NodeRef::leaf(t),
            PeerNode::Inner([l, r]) => {
                let k = nodes.len() as u32;
                nodes.push(InnerNode {
                    aabb: Aabb::EMPTY,
                    children: [NodeRef::NONE; 2],
                    parent,
                });
                stack.push((r, k, 1));
                stack.push((l, k, 0));
                NodeRef::inner(k)
            }
        };
        if parent == NONE {
            if !me.is_inner() {
                return BuiltTree { nodes, root: me };
            }
        } else {
            nodes[parent as usize].children[slot] = me;
        }
    }
    BuiltTree {
        nodes,
        root: NodeRef::inner(0),
    }
}

/// The `bvh` crate's shape: a triangle's bounds and its node index.
struct Shape {
    aabb: bvh::aabb::Aabb<f32, 3>,
    node: usize,
}

impl bvh::aabb::Bounded<f32, 3> for Shape {
    fn aabb(&self) -> bvh::aabb::Aabb<f32, 3> {
        self.aabb
    }
}

impl bvh::bounding_hierarchy::BHShape<f32, 3> for Shape {
    fn set_bh_node_index(&mut self, i: usize) {
        self.node = i;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

fn bvh_crate(tris: &[Triangle]) -> BuiltTree {
    if tris.is_empty() {
        return BuiltTree::default();
    }
    let mut shapes: Vec<Shape> = tris
        .iter()
        .map(|t| {
            let b = t.aabb();
            Shape {
                aabb: bvh::aabb::Aabb::with_bounds(
                    Point3::new(b.min.x, b.min.y, b.min.z),
                    Point3::new(b.max.x, b.max.y, b.max.z),
                ),
                node: 0,
            }
        })
        .collect();
    let tree = bvh::bvh::Bvh::build(&mut shapes);
    convert(|i| match &tree.nodes[i] {
        bvh::bvh::BvhNode::Leaf { shape_index, .. } => PeerNode::Leaf(*shape_index as u32),
        bvh::bvh::BvhNode::Node {
            child_l_index,
            child_r_index,
            ..
        } => PeerNode::Inner([*child_l_index, *child_r_index]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::hairball;
    use treelight_bvh::glam::Vec3;
    use treelight_bvh::{Bvh, BvhConfig, Ray};

    #[test]
    fn peer_trees_convert_to_valid_trees_with_the_same_hits() {
        let tris = hairball(3000, 5);
        for method in ["obvhs-fastest", "obvhs-medium", "obvhs-slowest", "bvh"] {
            let built = build(method, &tris).unwrap();
            let bvh = Bvh::from_built(&tris, &built, BvhConfig::default()).unwrap();
            bvh.validate().unwrap_or_else(|e| panic!("{method}: {e}"));
            assert_eq!(bvh.triangle_count(), 3000);
            for k in 0..300 {
                let a = k as f32 * 0.37;
                let o = Vec3::new(a.cos(), (a * 1.3).sin(), (a * 0.7).cos()) * 1.5;
                let ray = Ray::new(o, -o + Vec3::new(0.1, -0.05, 0.02) * (k % 7) as f32);
                let (got, want) = (bvh.closest_hit(&ray), bvh.brute_force_closest_hit(&ray));
                assert_eq!(
                    got.map(|h| h.triangle),
                    want.map(|h| h.triangle),
                    "{method}, ray {k}"
                );
            }
        }
        assert!(build("sah", &tris).is_none());
    }

    #[test]
    fn one_triangle_is_a_leaf_root() {
        let tris = hairball(1, 5);
        for method in ["obvhs-fastest", "bvh"] {
            let built = build(method, &tris).unwrap();
            assert_eq!(built.root, NodeRef::leaf(0), "{method}");
        }
    }
}
