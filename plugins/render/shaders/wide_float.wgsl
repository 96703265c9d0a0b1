// The 4-wide records with float boxes (`Bvh::gpu_wide_layout`), for traverse_wide.wgsl.

struct Node {
    min_x: vec4<f32>,
    max_x: vec4<f32>,
    min_y: vec4<f32>,
    max_y: vec4<f32>,
    min_z: vec4<f32>,
    max_z: vec4<f32>,
    refs: vec4<u32>,
}

fn child_entries(n: Node, f: Frame, t_max: f32) -> vec4<f32> {
    return slab_entries(f, n.min_x, n.max_x, n.min_y, n.max_y, n.min_z, n.max_z, n.refs, t_max);
}
