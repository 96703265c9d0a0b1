// The 4-wide records with boxes in bytes (`treelight_bvh::WideRecords`), for traverse_wide.wgsl:
// child k's box on an axis is origin + q * step, q byte k of the axis's word, step a power of two
// whose exponent bits the record holds. q * step is exact, so the box is the one the engine rounded
// outwards.

struct Node {
    origin: vec3<f32>,
    exponents: u32,
    quantized_x: vec2<u32>,
    quantized_y: vec2<u32>,
    quantized_z: vec2<u32>,
    pad: vec2<u32>,
    refs: vec4<u32>,
}

// The four bytes of `w`, child 0's (the low byte) first.
fn bytes4(w: u32) -> vec4<f32> {
    return vec4<f32>((vec4<u32>(w) >> vec4<u32>(0u, 8u, 16u, 24u)) & vec4<u32>(0xffu));
}

fn child_entries(n: Node, f: Frame, t_max: f32) -> vec4<f32> {
    let s = bitcast<vec3<f32>>((vec3<u32>(n.exponents) >> vec3<u32>(0u, 8u, 16u) & vec3<u32>(0xffu)) << vec3<u32>(23u));
    let o = n.origin;
    return slab_entries(
        f,
        vec4<f32>(o.x) + bytes4(n.quantized_x.x) * s.x,
        vec4<f32>(o.x) + bytes4(n.quantized_x.y) * s.x,
        vec4<f32>(o.y) + bytes4(n.quantized_y.x) * s.y,
        vec4<f32>(o.y) + bytes4(n.quantized_y.y) * s.y,
        vec4<f32>(o.z) + bytes4(n.quantized_z.x) * s.z,
        vec4<f32>(o.z) + bytes4(n.quantized_z.y) * s.z,
        n.refs,
        t_max,
    );
}
