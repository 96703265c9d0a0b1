// Unit vectors as two snorm16 octahedral coordinates in one word: the shading records' corner normals
// (encoded on the CPU by `records::encode_normal`) and the denoiser's guides. Appended to the kernels
// that read or write them.

fn decode_normal(w: u32) -> vec3<f32> {
    return octahedral_direction(unpack2x16snorm(w));
}

// The unit vector at octahedral coordinates `e` (each -1..1).
fn octahedral_direction(e: vec2<f32>) -> vec3<f32> {
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    let t = max(-n.z, 0.0);
    n.x += select(t, -t, n.x >= 0.0);
    n.y += select(t, -t, n.y >= 0.0);
    return normalize(n);
}

// A unit vector (or zero) as octahedral snorm16x2, decode_normal's inverse.
fn encode_normal(n: vec3<f32>) -> u32 {
    let l1 = abs(n.x) + abs(n.y) + abs(n.z);
    if l1 == 0.0 {
        return 0u;
    }
    var p = n.xy / l1;
    if n.z < 0.0 {
        p = (vec2<f32>(1.0) - abs(p.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    }
    return pack2x16snorm(p);
}
