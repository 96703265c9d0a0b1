// BVH traversal over treelight_bvh's 4-wide GPU layouts, with the same entry points as traverse.wgsl
// (`trace`, `closest_hit`, `occluded`), so a kernel takes either file. The crate appends one record
// file to it: wide_float.wgsl (`Bvh::gpu_wide_layout`, float boxes) or wide_compressed.wgsl
// (`Bvh::gpu_compressed_layout`, boxes in bytes), each defining `Node` and `child_entries`.
//
// A record holds up to four children's boxes and their references, tagged as in the binary layout
// (inner references name wide records). Hit children are visited nearest first: the others wait on
// the stack, farthest deepest.

// Where the ray enters each of a record's four child boxes within [0, t_max], FAR for a miss or an
// empty slot: one slab test over the four boxes as rows.
fn slab_entries(f: Frame, min_x: vec4<f32>, max_x: vec4<f32>, min_y: vec4<f32>, max_y: vec4<f32>,
                min_z: vec4<f32>, max_z: vec4<f32>, refs: vec4<u32>, t_max: f32) -> vec4<f32> {
    let tx0 = (min_x - vec4<f32>(f.o.x)) * f.inv.x;
    let tx1 = (max_x - vec4<f32>(f.o_max.x)) * f.inv.x;
    let ty0 = (min_y - vec4<f32>(f.o.y)) * f.inv.y;
    let ty1 = (max_y - vec4<f32>(f.o_max.y)) * f.inv.y;
    let tz0 = (min_z - vec4<f32>(f.o.z)) * f.inv.z;
    let tz1 = (max_z - vec4<f32>(f.o_max.z)) * f.inv.z;
    let enter = max(max(min(tx0, tx1), min(ty0, ty1)), max(min(tz0, tz1), vec4<f32>(0.0)));
    let exit = min(min(max(tx0, tx1), max(ty0, ty1)), min(max(tz0, tz1), vec4<f32>(t_max)));
    let entered = (enter <= exit * 1.0000004) & (refs != vec4<u32>(NONE));
    return select(vec4<f32>(FAR), enter, entered);
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
                let n = node_at(index);
                hit.visited += 1u;
                let enter = child_entries(n, f, hit.t);
                // Nearest first: a sorting network on the four (distance, reference) pairs, misses
                // at FAR; no indexing by a variable, which would keep the pairs in memory.
                var t0 = enter.x;
                var t1 = enter.y;
                var t2 = enter.z;
                var t3 = enter.w;
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
