// The triangles' shading records and the shading vertices' pool split across bindings like the
// tree's records (scene_parts.wgsl), in parts of four times the records (a quarter of a node's
// bytes each): the records at 3 and 22, the vertices at 23 to 28.

@group(0) @binding(3) var<storage, read> attrs: array<ShadingRecord>;
@group(0) @binding(22) var<storage, read> attrs1: array<ShadingRecord>;
@group(0) @binding(23) var<storage, read> shading_vertices: array<ShadingVertex>;
@group(0) @binding(24) var<storage, read> shading_vertices1: array<ShadingVertex>;
@group(0) @binding(25) var<storage, read> shading_vertices2: array<ShadingVertex>;
@group(0) @binding(26) var<storage, read> shading_vertices3: array<ShadingVertex>;
@group(0) @binding(27) var<storage, read> shading_vertices4: array<ShadingVertex>;
@group(0) @binding(28) var<storage, read> shading_vertices5: array<ShadingVertex>;

// Records per part of the shading kinds, as a power of two (PartLayout::shift_of).
fn attr_part_shift() -> u32 {
    return min(part_shift() + 2u, 30u);
}

// Triangle i's shading record, from its part (as scene_parts.wgsl's tri_at).
fn shading_record_at(i: u32) -> ShadingRecord {
    let part = i >> attr_part_shift();
    if part == 0u {
        return attrs[i];
    }
    return attrs1[i & ((1u << attr_part_shift()) - 1u)];
}

// Record i of the shading vertices' pool, from its part.
fn shading_vertex_at(i: u32) -> ShadingVertex {
    let part = i >> attr_part_shift();
    if part == 0u {
        return shading_vertices[i];
    }
    let o = i & ((1u << attr_part_shift()) - 1u);
    var v: ShadingVertex;
    switch part {
        case 1u: { v = shading_vertices1[o]; }
        case 2u: { v = shading_vertices2[o]; }
        case 3u: { v = shading_vertices3[o]; }
        case 4u: { v = shading_vertices4[o]; }
        default: { v = shading_vertices5[o]; }
    }
    return v;
}
