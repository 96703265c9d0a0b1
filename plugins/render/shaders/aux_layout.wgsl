// Where the preview blocks' object slots start in a view's `aux` buffer of a width × height image:
// after the per-pixel depths and slots and the blocks' samples, room made for the finest preview
// scale (blocks of 2 × 2 pixels).
fn block_objects_start(width: u32, height: u32) -> u32 {
    return 2u * width * height + 4u * ((width + 1u) / 2u) * ((height + 1u) / 2u);
}

