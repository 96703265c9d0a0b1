// The binary records with boxes in bytes (`GpuCompressedBinaryNode`), for traverse.wgsl: a
// coordinate is origin + q * step, q one byte of `quantized` (the left child's minimum x, y, z and
// maximum x, y, z, then the right child's, from the low byte of the first word), step a power of two
// whose exponent bits the record holds. q * step is exact, so the box is the one the engine rounded
// outwards.

struct Node {
    origin: vec3<f32>,
    exponents: u32,
    quantized: vec3<u32>,
    a_ref: u32,
    b_ref: u32,
    pad: array<u32, 3>,
}

fn child_boxes(n: Node) -> ChildBoxes {
    let s = bitcast<vec3<f32>>((vec3<u32>(n.exponents) >> vec3<u32>(0u, 8u, 16u) & vec3<u32>(0xffu)) << vec3<u32>(23u));
    let shifts = vec4<u32>(0u, 8u, 16u, 24u);
    let q0 = vec4<f32>((vec4<u32>(n.quantized.x) >> shifts) & vec4<u32>(0xffu));
    let q1 = vec4<f32>((vec4<u32>(n.quantized.y) >> shifts) & vec4<u32>(0xffu));
    let q2 = vec4<f32>((vec4<u32>(n.quantized.z) >> shifts) & vec4<u32>(0xffu));
    return ChildBoxes(
        n.origin + q0.xyz * s,
        n.origin + vec3<f32>(q0.w, q1.x, q1.y) * s,
        n.origin + vec3<f32>(q1.z, q1.w, q2.x) * s,
        n.origin + q2.yzw * s,
    );
}
