// Where the preview blocks' object slots start in a view's `aux` buffer of a width × height image:
// after the per-pixel depths and slots and the blocks' samples, room made for the finest preview
// scale (blocks of 2 × 2 pixels).
fn block_objects_start(width: u32, height: u32) -> u32 {
    return 2u * width * height + 4u * ((width + 1u) / 2u) * ((height + 1u) / 2u);
}

// Where the per-pixel guides start (five words a pixel: the first sample's shading normal,
// octahedral in pack2x16snorm; the sum of its samples' squared luminance, an f32, negated once
// they met more than one object; the sum of their primary hits' albedo, three f32), after the
// preview blocks' object slots.
fn guides_start(width: u32, height: u32) -> u32 {
    return block_objects_start(width, height) + ((width + 1u) / 2u) * ((height + 1u) / 2u);
}
