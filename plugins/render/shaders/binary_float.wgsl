// The binary records with float boxes (`GpuNode`), for traverse.wgsl.

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

fn child_boxes(n: Node) -> ChildBoxes {
    return ChildBoxes(n.a_min, n.a_max, n.b_min, n.b_max);
}
