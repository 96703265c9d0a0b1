// The triangles' shading records and the shading vertices' pool in one binding each
// (attrs_parts.wgsl is the split form).

@group(0) @binding(3) var<storage, read> attrs: array<ShadingRecord>;
@group(0) @binding(23) var<storage, read> shading_vertices: array<ShadingVertex>;

fn shading_record_at(i: u32) -> ShadingRecord {
    return attrs[i];
}

fn shading_vertex_at(i: u32) -> ShadingVertex {
    return shading_vertices[i];
}
