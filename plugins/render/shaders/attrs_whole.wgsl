// The shading records in one binding (attrs_parts.wgsl is the split form).

@group(0) @binding(3) var<storage, read> attrs: array<Attr>;

fn attr_at(i: u32) -> Attr {
    return attrs[i];
}
