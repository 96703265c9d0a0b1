// BVH traversal over treelight_bvh's GPU layout. Shared by the kernels: each kernel file declares the
// `nodes`, `tris` and `instances` bindings this code reads (WGSL resolves module-scope names in any
// order), and the crate appends this file to it.
//
// Node records hold both children's boxes; a child reference carries its kind in its two high bits:
// 0 inner node, 1 leaf (the value is a triangle id), 2 instance (a group kept whole under a transform,
// traversed in its object space). Instances do not nest, so one saved world-space ray suffices.

struct Node {
    a_min: vec3<f32>,
    a_ref: u32,
    a_max: vec3<f32>,
    b_ref: u32,
    b_min: vec3<f32>,
    pad0: u32,
    b_max: vec3<f32>,
    pad1: u32,
}

struct Tri {
    v0: vec3<f32>,
    pad0: u32,
    v1: vec3<f32>,
    pad1: u32,
    v2: vec3<f32>,
    pad2: u32,
}

struct Instance {
    world_to_object: array<vec4<f32>, 3>,
    object_to_world: array<vec4<f32>, 3>,
    root: u32,
    // The group the instance places: its object record holds the material and normal matrix.
    group: u32,
    pad1: u32,
    pad2: u32,
}

const NONE: u32 = 0xffffffffu;
const END_INSTANCE: u32 = 0xfffffffeu;
const KIND_SHIFT: u32 = 30u;
const INDEX_MASK: u32 = 0x3fffffffu;
const KIND_INNER: u32 = 0u;
const KIND_LEAF: u32 = 1u;
const KIND_INSTANCE: u32 = 2u;
const STACK_SIZE: u32 = 96u;
const FAR: f32 = 3.0e38;

struct Hit {
    t: f32,
    triangle: u32,
    u: f32,
    v: f32,
    // Inner nodes visited: the heatmap's measure.
    visited: u32,
    // The instance the hit triangle was reached through, or NONE for a baked triangle (stored in
    // world space).
    instance: u32,
}

// Entry parameter of the ray into the box, or FAR when it misses within [0, t_max].
fn hit_box(o: vec3<f32>, inv: vec3<f32>, bmin: vec3<f32>, bmax: vec3<f32>, t_max: f32) -> f32 {
    let t0 = (bmin - o) * inv;
    let t1 = (bmax - o) * inv;
    let tn = min(t0, t1);
    let tf = max(t0, t1);
    let enter = max(max(tn.x, tn.y), max(tn.z, 0.0));
    let exit = min(min(tf.x, tf.y), min(tf.z, t_max));
    if enter <= exit * 1.0000004 {
        return enter;
    }
    return FAR;
}

// Watertight ray/triangle test (Woop, Benthin, Wald 2013), as in treelight_bvh.
// Returns (t, u, v) with t < 0 for a miss.
fn hit_triangle(o: vec3<f32>, d: vec3<f32>, tri: Tri, t_max: f32) -> vec3<f32> {
    let ad = abs(d);
    var kz = 2u;
    if ad.x >= ad.y && ad.x >= ad.z {
        kz = 0u;
    } else if ad.y >= ad.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if d[kz] < 0.0 {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    let sz = 1.0 / d[kz];
    let sx = d[kx] * sz;
    let sy = d[ky] * sz;
    let a = tri.v0 - o;
    let b = tri.v1 - o;
    let c = tri.v2 - o;
    let ax = a[kx] - sx * a[kz];
    let ay = a[ky] - sy * a[kz];
    let bx = b[kx] - sx * b[kz];
    let by = b[ky] - sy * b[kz];
    let cx = c[kx] - sx * c[kz];
    let cy = c[ky] - sy * c[kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let det = u + v + w;
    if det == 0.0 {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let t = (u * sz * a[kz] + v * sz * b[kz] + w * sz * c[kz]) / det;
    if t < 0.0 || t > t_max {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    return vec3<f32>(t, v / det, w / det);
}

fn xform_point(m: array<vec4<f32>, 3>, p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m[0].xyz, p) + m[0].w, dot(m[1].xyz, p) + m[1].w, dot(m[2].xyz, p) + m[2].w);
}

fn xform_vector(m: array<vec4<f32>, 3>, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m[0].xyz, v), dot(m[1].xyz, v), dot(m[2].xyz, v));
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(1.0) / select(d, vec3<f32>(1e-30), d == vec3<f32>(0.0));
}

// Closest hit from `root` (a node reference) along o + t d, t in [0, t_max]. With `first`, stops at the
// first hit found (shadow rays).
fn trace(root: u32, world_o: vec3<f32>, world_d: vec3<f32>, t_max: f32, first: bool) -> Hit {
    var hit = Hit(t_max, NONE, 0.0, 0.0, 0u, NONE);
    if root == NONE {
        return hit;
    }
    var o = world_o;
    var d = world_d;
    var inv = safe_inverse(d);
    var stack: array<u32, STACK_SIZE>;
    var sp = 0u;
    var current = root;
    var inside = NONE;
    loop {
        if current == END_INSTANCE {
            o = world_o;
            d = world_d;
            inv = safe_inverse(d);
            inside = NONE;
        } else {
            let kind = current >> KIND_SHIFT;
            let index = current & INDEX_MASK;
            if kind == KIND_INNER {
                let n = nodes[index];
                hit.visited += 1u;
                let ta = hit_box(o, inv, n.a_min, n.a_max, hit.t);
                let tb = hit_box(o, inv, n.b_min, n.b_max, hit.t);
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
                let r = hit_triangle(o, d, tris[index], hit.t);
                if r.x >= 0.0 {
                    hit.t = r.x;
                    hit.triangle = index;
                    hit.u = r.y;
                    hit.v = r.z;
                    hit.instance = inside;
                    if first {
                        return hit;
                    }
                }
            } else if kind == KIND_INSTANCE {
                let inst = instances[index];
                if sp < STACK_SIZE {
                    stack[sp] = END_INSTANCE;
                    sp += 1u;
                    o = xform_point(inst.world_to_object, world_o);
                    d = xform_vector(inst.world_to_object, world_d);
                    inv = safe_inverse(d);
                    inside = index;
                    current = inst.root;
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

fn closest_hit(root: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> Hit {
    return trace(root, o, d, t_max, false);
}

fn occluded(root: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    return trace(root, o, d, t_max, true).triangle != NONE;
}
