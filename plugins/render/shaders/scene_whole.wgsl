// The tree's records in one binding each: the kernels for a scene that fits (scene_parts.wgsl is
// the split form, with the same functions).

@group(0) @binding(0) var<storage, read> nodes: array<Node>;
@group(0) @binding(1) var<storage, read> tris: array<TriRecord>;
@group(0) @binding(16) var<storage, read> positions: array<vec4<f32>>;

fn node_at(i: u32) -> Node {
    return nodes[i];
}

fn tri_at(i: u32) -> Tri {
    let r = tris[i];
    return Tri(
        positions[r.corners[0]].xyz,
        positions[r.corners[1]].xyz,
        positions[r.corners[2]].xyz,
    );
}

// The slot of the group that owns triangle i, which its first corner's position record names
// (NONE for a triangle outside any group).
fn triangle_group(i: u32) -> u32 {
    return bitcast<u32>(positions[tris[i].corners[0]].w);
}
