// BVH traversal over treelight_bvh's binary GPU layout. Shared by the kernels: scene_parts.wgsl
// declares the nodes, triangles and positions (read through `node_at` and `tri_at`), each kernel
// file the `instances` binding this code reads (WGSL resolves module-scope
// names in any order), and the crate appends this file and traverse_common.wgsl to it.
//
// A node record holds both children's boxes and references. The crate appends one record file:
// binary_float.wgsl (`GpuNode`, float boxes) or binary_compressed.wgsl (`GpuCompressedBinaryNode`,
// boxes in bytes), each defining `Node` (with `a_ref` and `b_ref`) and `child_boxes`.

// Both children's boxes of a record.
struct ChildBoxes {
    a_min: vec3<f32>,
    a_max: vec3<f32>,
    b_min: vec3<f32>,
    b_max: vec3<f32>,
}

const STACK_SIZE: u32 = 96u;

// Closest hit from `root` (a node reference) along o + t d, t in [0, t_max]. With `first`, stops at the
// first hit found (shadow rays).
fn trace(root: u32, world_o: vec3<f32>, world_d: vec3<f32>, t_max: f32, first: bool) -> Hit {
    var hit = Hit(t_max, NONE, 0.0, 0.0, 0u, NONE);
    if root == NONE {
        return hit;
    }
    var f = world_frame(world_o, world_d);
    var stack: array<u32, STACK_SIZE>;
    var sp = 0u;
    var current = root;
    loop {
        if current == END_INSTANCE {
            f = world_frame(world_o, world_d);
        } else {
            let kind = current >> KIND_SHIFT;
            let index = current & INDEX_MASK;
            if kind == KIND_INNER {
                let n = node_at(index);
                hit.visited += 1u;
                let c = child_boxes(n);
                let ta = hit_box(f, c.a_min, c.a_max, hit.t);
                let tb = hit_box(f, c.b_min, c.b_max, hit.t);
                if ta < FAR && tb < FAR {
                    // Visit the nearer child next; the farther one waits on the stack.
                    var near = n.a_ref;
                    var far = n.b_ref;
                    if tb < ta {
                        near = n.b_ref;
                        far = n.a_ref;
                    }
                    if sp < STACK_SIZE {
                        stack[sp] = far;
                        sp += 1u;
                    }
                    current = near;
                    continue;
                } else if ta < FAR {
                    current = n.a_ref;
                    continue;
                } else if tb < FAR {
                    current = n.b_ref;
                    continue;
                }
            } else if kind == KIND_LEAF {
                if test_leaf(f, index, &hit) && first {
                    return hit;
                }
            } else if kind == KIND_INSTANCE {
                if sp < STACK_SIZE {
                    stack[sp] = END_INSTANCE;
                    sp += 1u;
                    f = instance_frame(index, world_o, world_d);
                    current = instances[index].root;
                    continue;
                }
            }
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        current = stack[sp];
    }
    return hit;
}
