// One primary ray per pixel from a pinhole camera; writes the closest triangle id (NONE for a miss).
// The crate appends traverse.wgsl and sampling.wgsl. The tests compare it with the engine's CPU
// traversal.

// Pixel (x, y) looks along lower_left + (x+0.5)/width * horizontal + (y+0.5)/height * vertical.
struct PrimaryCamera {
    origin: vec3<f32>,
    width: u32,
    lower_left: vec3<f32>,
    height: u32,
    horizontal: vec3<f32>,
    root: u32,
    vertical: vec3<f32>,
    pad: u32,
}

@group(0) @binding(0) var<storage, read> nodes: array<Node>;
@group(0) @binding(1) var<storage, read> tris: array<Tri>;
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

// The paper's second quality measure: from each primary hit, `ao.rays` cosine-distributed shadow
// rays of length `ao.length`. Writes the number of unoccluded rays per pixel (NONE for a miss).
@compute @workgroup_size(8, 8, 1)
fn ambient_occlusion(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= camera.width || id.y >= camera.height {
        return;
    }
    let pixel = id.y * camera.width + id.x;
    let d = primary_ray_dir(id.x, id.y);
    let hit = closest_hit(camera.root, camera.origin, d, FAR);
    if hit.triangle == NONE {
        hit_ids[pixel] = NONE;
        return;
    }
    let p = camera.origin + d * hit.t;
    let tri = tris[hit.triangle];
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
    let frame = basis(n);
    let o = offset(p, n);
    var state = pcg(pixel);
    var open = 0u;
    for (var k = 0u; k < ao.rays; k += 1u) {
        state = pcg(state);
        let u1 = f32(state >> 8u) / 16777216.0;
        state = pcg(state);
        let u2 = f32(state >> 8u) / 16777216.0;
        let dir = cosine_direction(frame, u1, u2);
        if !occluded(camera.root, o, dir, ao.length) {
            open += 1u;
        }
    }
    hit_ids[pixel] = open;
}
