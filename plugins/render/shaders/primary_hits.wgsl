// One primary ray per pixel from a pinhole camera; writes the closest triangle id (NONE for a miss).
// The crate appends a traversal (any layout's) and sampling.wgsl. The tests compare it with the
// engine's CPU traversal.

// Pixel (x, y) looks along lower_left + (x+0.5)/width * horizontal + (y+0.5)/height * vertical.
struct PrimaryCamera {
    origin: vec3<f32>,
    width: u32,
    lower_left: vec3<f32>,
    height: u32,
    horizontal: vec3<f32>,
    root: u32,
    vertical: vec3<f32>,
    // Records per part of a split buffer: 1 << part_shift (scene_parts.wgsl, which declares the
    // nodes, triangles and positions).
    part_shift: u32,
}

fn part_shift() -> u32 {
    return camera.part_shift;
}

// These kernels see geometry only: every triangle is solid.
fn surface_is_there(triangle: u32, instance: u32, u: f32, v: f32) -> bool {
    return true;
}

@group(0) @binding(2) var<storage, read> instances: array<Instance>;
@group(0) @binding(3) var<uniform> camera: PrimaryCamera;
@group(0) @binding(4) var<storage, read_write> hit_ids: array<u32>;
// Ambient occlusion (the `ambient_occlusion` kernel only): rays per primary hit and their length.
struct AoParams {
    rays: u32,
    length: f32,
    pad0: u32,
    pad1: u32,
}
@group(0) @binding(5) var<uniform> ao: AoParams;

fn primary_ray_dir(x: u32, y: u32) -> vec3<f32> {
    let s = (f32(x) + 0.5) / f32(camera.width);
    let t = (f32(y) + 0.5) / f32(camera.height);
    return camera.lower_left + s * camera.horizontal + t * camera.vertical;
}

@compute @workgroup_size(8, 8, 1)
fn primary_hits(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= camera.width || id.y >= camera.height {
        return;
    }
    let hit = closest_hit(camera.root, camera.origin, primary_ray_dir(id.x, id.y), FAR);
    hit_ids[id.y * camera.width + id.x] = hit.triangle;
}

// A primary hit seen from the camera: where secondary rays start, and the frame about its normal.
struct SecondaryStart {
    hit: bool,
    p: vec3<f32>,
    o: vec3<f32>,
    n: vec3<f32>,
}

fn secondary_start(x: u32, y: u32) -> SecondaryStart {
    var s: SecondaryStart;
    let d = primary_ray_dir(x, y);
    let hit = closest_hit(camera.root, camera.origin, d, FAR);
    s.hit = hit.triangle != NONE;
    if !s.hit {
        return s;
    }
    s.p = camera.origin + d * hit.t;
    let tri = tri_at(hit.triangle);
    var n = cross(tri.v1 - tri.v0, tri.v2 - tri.v0);
    if hit.instance != NONE {
        // Object-space normal to world space through the inverse's transpose.
        let m = instances[hit.instance].world_to_object;
        n = m[0].xyz * n.x + m[1].xyz * n.y + m[2].xyz * n.z;
    }
    n = normalize(n);
    if dot(n, d) > 0.0 {
        n = -n;
    }
    s.n = n;
    s.o = offset(s.p, n);
    return s;
}

// Two uniform numbers in [0, 1) from the generator's state.
fn next_pair(state: ptr<function, u32>) -> vec2<f32> {
    *state = pcg(*state);
    let u1 = f32(*state >> 8u) / 16777216.0;
    *state = pcg(*state);
    let u2 = f32(*state >> 8u) / 16777216.0;
    return vec2<f32>(u1, u2);
}

const RAYS_AO: u32 = 0u;
const RAYS_DIFFUSE: u32 = 1u;
const RAYS_SHADOW: u32 = 2u;

// From the primary hit of pixel `id`, `ao.rays` secondary rays of one kind; writes how many of them
// count (NONE for a miss):
// - RAYS_AO, the paper's second quality measure: cosine-distributed rays of length `ao.length`,
//   counted when unoccluded;
// - RAYS_DIFFUSE, the path tracer's indirect rays: cosine-distributed rays to their closest hit,
//   however far, counted when they hit something;
// - RAYS_SHADOW, the path tracer's light rays: rays to points of a square light above the camera
//   (its side the image plane's height), counted when they reach it.
fn secondary_rays(id: vec3<u32>, kind: u32) {
    if id.x >= camera.width || id.y >= camera.height {
        return;
    }
    let pixel = id.y * camera.width + id.x;
    let s = secondary_start(id.x, id.y);
    if !s.hit {
        hit_ids[pixel] = NONE;
        return;
    }
    let frame = basis(s.n);
    var state = pcg(pixel);
    var counted = 0u;
    for (var k = 0u; k < ao.rays; k += 1u) {
        let u = next_pair(&state);
        var counts = false;
        if kind == RAYS_SHADOW {
            let light = camera.origin + camera.vertical * (1.0 + u.y) + camera.horizontal * (u.x - 0.5);
            let to = light - s.p;
            let dist = length(to);
            counts = !occluded(camera.root, s.o, to / dist, dist * 0.999);
        } else if kind == RAYS_DIFFUSE {
            let dir = cosine_direction(frame, u.x, u.y);
            counts = closest_hit(camera.root, s.o, dir, FAR).triangle != NONE;
        } else {
            counts = !occluded(camera.root, s.o, cosine_direction(frame, u.x, u.y), ao.length);
        }
        if counts {
            counted += 1u;
        }
    }
    hit_ids[pixel] = counted;
}

@compute @workgroup_size(8, 8, 1)
fn ambient_occlusion(@builtin(global_invocation_id) id: vec3<u32>) {
    secondary_rays(id, RAYS_AO);
}

@compute @workgroup_size(8, 8, 1)
fn diffuse_bounces(@builtin(global_invocation_id) id: vec3<u32>) {
    secondary_rays(id, RAYS_DIFFUSE);
}

@compute @workgroup_size(8, 8, 1)
fn shadow_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    secondary_rays(id, RAYS_SHADOW);
}
