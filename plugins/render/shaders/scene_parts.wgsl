// The tree's records split across bindings: one binding holds at most the adapter's
// max_storage_buffer_binding_size, so a large scene's nodes and triangles lie in several buffers,
// each part 1 << part_shift() records (the kernel defines part_shift from its uniform). Record i is
// record i & mask of part i >> shift. Parts not in use are bound to a small stand-in buffer. A
// scene that fits one binding gets the kernels of scene_whole.wgsl instead: on llvmpipe the part
// switch costs about half the trace rate even when every record is in part 0.
// Bindings: nodes at 0 and 8 to 14, triangles at 1 and 15 to 21 (treelight_render::part_bindings).

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
@group(0) @binding(16) var<storage, read> tris2: array<TriRecord>;
@group(0) @binding(17) var<storage, read> tris3: array<TriRecord>;
@group(0) @binding(18) var<storage, read> tris4: array<TriRecord>;
@group(0) @binding(19) var<storage, read> tris5: array<TriRecord>;
@group(0) @binding(20) var<storage, read> tris6: array<TriRecord>;
@group(0) @binding(21) var<storage, read> tris7: array<TriRecord>;

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

fn tri_at(i: u32) -> Tri {
    let part = i >> part_shift();
    if part == 0u {
        return unpack_tri(tris[i]);
    }
    let o = i & part_mask();
    var t: TriRecord;
    switch part {
        case 1u: { t = tris1[o]; }
        case 2u: { t = tris2[o]; }
        case 3u: { t = tris3[o]; }
        case 4u: { t = tris4[o]; }
        case 5u: { t = tris5[o]; }
        case 6u: { t = tris6[o]; }
        default: { t = tris7[o]; }
    }
    return unpack_tri(t);
}
