// BVH traversal over treelight_bvh's 4-wide GPU layout (`Bvh::gpu_wide_layout`), with the same
// entry points as traverse.wgsl (`trace`, `closest_hit`, `occluded`), so a kernel takes either file.
//
// A node record holds up to four children's boxes as rows (all minimum x, then all maximum x, ...),
// so one slab test covers the four, and their references, tagged as in the binary layout (inner
// references name wide records). Hit children are visited nearest first: the others wait on the
// stack, farthest deepest.

struct Node {
    min_x: vec4<f32>,
    max_x: vec4<f32>,
    min_y: vec4<f32>,
    max_y: vec4<f32>,
    min_z: vec4<f32>,
    max_z: vec4<f32>,
    refs: vec4<u32>,
}

const STACK_SIZE: u32 = 128u;

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
                let n = nodes[index];
                hit.visited += 1u;
                let tx0 = (n.min_x - vec4<f32>(f.o.x)) * f.inv.x;
                let tx1 = (n.max_x - vec4<f32>(f.o.x)) * f.inv.x;
                let ty0 = (n.min_y - vec4<f32>(f.o.y)) * f.inv.y;
                let ty1 = (n.max_y - vec4<f32>(f.o.y)) * f.inv.y;
                let tz0 = (n.min_z - vec4<f32>(f.o.z)) * f.inv.z;
                let tz1 = (n.max_z - vec4<f32>(f.o.z)) * f.inv.z;
                let enter = max(max(min(tx0, tx1), min(ty0, ty1)), max(min(tz0, tz1), vec4<f32>(0.0)));
                let exit = min(min(max(tx0, tx1), max(ty0, ty1)), min(max(tz0, tz1), vec4<f32>(hit.t)));
                let entered = (enter <= exit * 1.0000004) & (n.refs != vec4<u32>(NONE));
                // Nearest first: a sorting network on the four (distance, reference) pairs, misses
                // at FAR; no indexing by a variable, which would keep the pairs in memory.
                var t0 = select(FAR, enter.x, entered.x);
                var t1 = select(FAR, enter.y, entered.y);
                var t2 = select(FAR, enter.z, entered.z);
                var t3 = select(FAR, enter.w, entered.w);
                var r0 = n.refs.x;
                var r1 = n.refs.y;
                var r2 = n.refs.z;
                var r3 = n.refs.w;
                if t1 < t0 { let t = t0; t0 = t1; t1 = t; let r = r0; r0 = r1; r1 = r; }
                if t3 < t2 { let t = t2; t2 = t3; t3 = t; let r = r2; r2 = r3; r3 = r; }
                if t2 < t0 { let t = t0; t0 = t2; t2 = t; let r = r0; r0 = r2; r2 = r; }
                if t3 < t1 { let t = t1; t1 = t3; t3 = t; let r = r1; r1 = r3; r3 = r; }
                if t2 < t1 { let t = t1; t1 = t2; t2 = t; let r = r1; r1 = r2; r2 = r; }
                if t0 < FAR {
                    // The farther ones wait on the stack, farthest deepest.
                    if t3 < FAR && sp < STACK_SIZE {
                        stack[sp] = r3;
                        sp += 1u;
                    }
                    if t2 < FAR && sp < STACK_SIZE {
                        stack[sp] = r2;
                        sp += 1u;
                    }
                    if t1 < FAR && sp < STACK_SIZE {
                        stack[sp] = r1;
                        sp += 1u;
                    }
                    current = r0;
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
