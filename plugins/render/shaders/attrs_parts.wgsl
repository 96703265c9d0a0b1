// The shading records split across bindings like the triangles (scene_parts.wgsl): attrs at 3, the
// other parts at 22 to 28.

@group(0) @binding(3) var<storage, read> attrs: array<Attr>;
@group(0) @binding(22) var<storage, read> attrs1: array<Attr>;
@group(0) @binding(23) var<storage, read> attrs2: array<Attr>;
@group(0) @binding(24) var<storage, read> attrs3: array<Attr>;
@group(0) @binding(25) var<storage, read> attrs4: array<Attr>;
@group(0) @binding(26) var<storage, read> attrs5: array<Attr>;
@group(0) @binding(27) var<storage, read> attrs6: array<Attr>;
@group(0) @binding(28) var<storage, read> attrs7: array<Attr>;

// Triangle i's shading record, from its part (as scene_parts.wgsl's tri_at).
fn attr_at(i: u32) -> Attr {
    let part = i >> part_shift();
    if part == 0u {
        return attrs[i];
    }
    let o = i & part_mask();
    var a: Attr;
    switch part {
        case 1u: { a = attrs1[o]; }
        case 2u: { a = attrs2[o]; }
        case 3u: { a = attrs3[o]; }
        case 4u: { a = attrs4[o]; }
        case 5u: { a = attrs5[o]; }
        case 6u: { a = attrs6[o]; }
        default: { a = attrs7[o]; }
    }
    return a;
}
