// One primary ray per pixel from a pinhole camera; writes the closest triangle id (NONE for a miss).
// The crate appends traverse.wgsl. The tests compare it with the engine's CPU traversal.

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
