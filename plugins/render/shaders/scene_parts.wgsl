// The tree's records split across bindings: one binding holds at most the adapter's
// max_storage_buffer_binding_size, so a large scene's nodes, triangles and positions lie in
// several buffers, the nodes' parts 1 << part_shift() records each (the kernel defines part_shift
// from its uniform), the 12-byte triangles' and 16-byte positions' four times as many
// (small_part_shift). Record i is record i & mask of part i >> shift. Parts not in use are bound to a small stand-in buffer. A
// scene that fits one binding gets the kernels of scene_whole.wgsl instead: on llvmpipe the part
// switch costs about half the trace rate even when every record is in part 0.
// Bindings: nodes at 0 and 8 to 14, triangles at 1 and 15, positions at 16 to 21
// (treelight_render::part_bindings).

@group(0) @binding(0) var<storage, read> nodes: array<Node>;
@group(0) @binding(8) var<storage, read> nodes1: array<Node>;
@group(0) @binding(9) var<storage, read> nodes2: array<Node>;
@group(0) @binding(10) var<storage, read> nodes3: array<Node>;
@group(0) @binding(11) var<storage, read> nodes4: array<Node>;
@group(0) @binding(12) var<storage, read> nodes5: array<Node>;
@group(0) @binding(13) var<storage, read> nodes6: array<Node>;
@group(0) @binding(14) var<storage, read> nodes7: array<Node>;
@group(0) @binding(1) var<storage, read> tris: array<TriRecord>;
@group(0) @binding(15) var<storage, read> tris1: array<TriRecord>;
@group(0) @binding(16) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(17) var<storage, read> positions1: array<vec4<f32>>;
@group(0) @binding(18) var<storage, read> positions2: array<vec4<f32>>;
@group(0) @binding(19) var<storage, read> positions3: array<vec4<f32>>;
@group(0) @binding(20) var<storage, read> positions4: array<vec4<f32>>;
@group(0) @binding(21) var<storage, read> positions5: array<vec4<f32>>;

fn part_mask() -> u32 {
    return (1u << part_shift()) - 1u;
}

fn node_at(i: u32) -> Node {
    let part = i >> part_shift();
    if part == 0u {
        return nodes[i];
    }
    let o = i & part_mask();
    var n: Node;
    switch part {
        case 1u: { n = nodes1[o]; }
        case 2u: { n = nodes2[o]; }
        case 3u: { n = nodes3[o]; }
        case 4u: { n = nodes4[o]; }
        case 5u: { n = nodes5[o]; }
        case 6u: { n = nodes6[o]; }
        default: { n = nodes7[o]; }
    }
    return n;
}

// Records per part of the 12-byte triangles and the 16-byte positions, as a power of two
// (PartLayout::shift_of).
fn small_part_shift() -> u32 {
    return min(part_shift() + 2u, 30u);
}

fn tri_record_at(i: u32) -> TriRecord {
    let part = i >> small_part_shift();
    if part == 0u {
        return tris[i];
    }
    return tris1[i & ((1u << small_part_shift()) - 1u)];
}

// Position record i: the position, then the bits of its run's group slot in w.
fn position_record_at(i: u32) -> vec4<f32> {
    let part = i >> small_part_shift();
    if part == 0u {
        return positions[i];
    }
    let o = i & ((1u << small_part_shift()) - 1u);
    var p: vec4<f32>;
    switch part {
        case 1u: { p = positions1[o]; }
        case 2u: { p = positions2[o]; }
        case 3u: { p = positions3[o]; }
        case 4u: { p = positions4[o]; }
        default: { p = positions5[o]; }
    }
    return p;
}

fn position_at(i: u32) -> vec3<f32> {
    return position_record_at(i).xyz;
}

// The slot of the group that owns triangle i, which its first corner's position record names
// (NONE for a triangle outside any group).
fn triangle_group(i: u32) -> u32 {
    return bitcast<u32>(position_record_at(tri_record_at(i).corners[0]).w);
}

fn tri_at(i: u32) -> Tri {
    let r = tri_record_at(i);
    return Tri(position_at(r.corners[0]), position_at(r.corners[1]), position_at(r.corners[2]));
}
