// What both GPU layouts' traversals share: the triangle and instance records, the hit, the box and
// triangle tests. The crate appends it with one layout's file (traverse.wgsl, binary nodes, or
// traverse_wide.wgsl, 4-wide nodes), which defines `Node`, `STACK_SIZE` and `trace`; `closest_hit` and
// `occluded` below call that `trace`. The kernel defines `surface_is_there(triangle, instance, u, v)`,
// asked of every candidate hit.
//
// A child reference carries its kind in its two high bits: 0 inner node, 1 leaf (the value is a
// triangle id), 2 instance (a group kept whole under a transform, traversed in its object space).
// Instances do not nest, so one saved world-space ray suffices.

// A triangle's record: its corners, records of the position pool (treelight_bvh's
// GpuIndexedTriangle; each group's vertices are one run of the pool, shared by its triangles). The
// pool's records are vec4<f32> (the position, then the bits of the slot of the group whose run it
// is: treelight_bvh's GpuPosition): one load each, where three floats took three and slowed the
// traversal by a tenth on llvmpipe.
struct TriRecord {
    corners: array<u32, 3>,
}

// A triangle's corners, as the tests read them.
struct Tri {
    v0: vec3<f32>,
    v1: vec3<f32>,
    v2: vec3<f32>,
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
fn hit_box(f: Frame, bmin: vec3<f32>, bmax: vec3<f32>, t_max: f32) -> f32 {
    let t0 = (bmin - f.o) * f.inv;
    let t1 = (bmax - f.o_max) * f.inv;
    let tn = min(t0, t1);
    let tf = max(t0, t1);
    let enter = max(max(tn.x, tn.y), max(tn.z, 0.0));
    let exit = min(min(tf.x, tf.y), min(tf.z, t_max));
    if enter <= exit * 1.0000004 {
        return enter;
    }
    return FAR;
}

// The watertight ray/triangle test (Woop, Benthin, Wald 2013), as in treelight_bvh, with its
// per-ray part done once per ray (and again inside an instance): the axis permutation and the shear
// become three rows, so a vertex's sheared coordinates are three dot products, with no component
// picked by a variable (costly where invocations run in SIMD lanes, as on llvmpipe).
struct RayTest {
    // Sheared x and y, and z scaled by 1 / d[kz], of a vertex relative to the origin.
    mx: vec3<f32>,
    my: vec3<f32>,
    mz: vec3<f32>,
}

fn ray_test(d: vec3<f32>) -> RayTest {
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
    let px = vec3<f32>(f32(kx == 0u), f32(kx == 1u), f32(kx == 2u));
    let py = vec3<f32>(f32(ky == 0u), f32(ky == 1u), f32(ky == 2u));
    let pz = vec3<f32>(f32(kz == 0u), f32(kz == 1u), f32(kz == 2u));
    let sz = 1.0 / d[kz];
    return RayTest(px - d[kx] * sz * pz, py - d[ky] * sz * pz, sz * pz);
}

// Returns (t, u, v) with t < 0 for a miss.
fn hit_triangle(o: vec3<f32>, m: RayTest, tri: Tri, t_max: f32) -> vec3<f32> {
    let a = tri.v0 - o;
    let b = tri.v1 - o;
    let c = tri.v2 - o;
    let ax = dot(m.mx, a);
    let ay = dot(m.my, a);
    let bx = dot(m.mx, b);
    let by = dot(m.my, b);
    let cx = dot(m.mx, c);
    let cy = dot(m.my, c);
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
    let t = (u * dot(m.mz, a) + v * dot(m.mz, b) + w * dot(m.mz, c)) / det;
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

// The origin the slab tests measure a box's maximum planes from. Along an axis the ray does not
// move (d 0, its inverse +1e30), an origin exactly in a box's maximum plane would put that plane
// at t = 0 and the box behind the ray, though the ray runs inside it (the minimum plane gives
// -1e30 and 0, right): there the origin steps at least one ulp down, so the ray meets the box
// (and one an ulp beside it, which costs a visit, never a hit). Per frame, not per box.
fn origin_for_max_planes(o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let below = o - max(abs(o) * 2.384e-7, vec3<f32>(1e-30));
    return select(o, below, d == vec3<f32>(0.0));
}

// The ray as the traversal tests it, in the space it is in: world space, or an instance's object
// space while inside one.
struct Frame {
    o: vec3<f32>,
    // `origin_for_max_planes`.
    o_max: vec3<f32>,
    inv: vec3<f32>,
    m: RayTest,
    // The instance the ray is inside; NONE in world space.
    inside: u32,
}

fn world_frame(o: vec3<f32>, d: vec3<f32>) -> Frame {
    return Frame(o, origin_for_max_planes(o, d), safe_inverse(d), ray_test(d), NONE);
}

// The world ray o + t d in the object space of instance `index` (t unchanged).
fn instance_frame(index: u32, o: vec3<f32>, d: vec3<f32>) -> Frame {
    let inst = instances[index];
    let local_d = xform_vector(inst.world_to_object, d);
    let local_o = xform_point(inst.world_to_object, o);
    return Frame(local_o, origin_for_max_planes(local_o, local_d), safe_inverse(local_d), ray_test(local_d), index);
}

// Whether `tri`, met at exactly the distance of the hit so far, takes its place. Exact ties
// happen where surfaces touch (a box standing on a floor) or along a shared edge. Settled by the
// triangles' corners (the lower sum wins: x, then y, then z), not by the order the tree visits
// them in, they leave an image independent of how the tree was built (the viewport's, filled as
// meshes arrive, and a render's).
fn wins_tie(tri: Tri, hit: Hit) -> bool {
    let best = tri_at(hit.triangle);
    let s = tri.v0 + tri.v1 + tri.v2;
    let r = best.v0 + best.v1 + best.v2;
    if s.x != r.x {
        return s.x < r.x;
    }
    if s.y != r.y {
        return s.y < r.y;
    }
    return s.z < r.z;
}

// Tests triangle `index` (a leaf); a nearer hit replaces `hit`, and one as near if it `wins_tie`.
// Returns whether it did.
fn test_leaf(f: Frame, index: u32, hit: ptr<function, Hit>) -> bool {
    let tri = tri_at(index);
    let r = hit_triangle(f.o, f.m, tri, (*hit).t);
    if r.x < 0.0 {
        return false;
    }
    if r.x == (*hit).t && (*hit).triangle != NONE && !wins_tie(tri, *hit) {
        return false;
    }
    // The kernel says whether the surface is there (a masked material's cut-away parts are not).
    if !surface_is_there(index, f.inside, r.y, r.z) {
        return false;
    }
    (*hit).t = r.x;
    (*hit).triangle = index;
    (*hit).u = r.y;
    (*hit).v = r.z;
    (*hit).instance = f.inside;
    return true;
}

// The layout's `trace` as the kernels call it.
fn closest_hit(root: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> Hit {
    return trace(root, o, d, t_max, false);
}

fn occluded(root: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    return trace(root, o, d, t_max, true).triangle != NONE;
}
