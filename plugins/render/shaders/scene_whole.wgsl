// The tree's records in one binding each: the kernels for a scene that fits (scene_parts.wgsl is
// the split form, with the same functions).

@group(0) @binding(0) var<storage, read> nodes: array<Node>;
@group(0) @binding(1) var<storage, read> tris: array<TriRecord>;

fn node_at(i: u32) -> Node {
    return nodes[i];
}

fn tri_at(i: u32) -> Tri {
    return unpack_tri(tris[i]);
}
