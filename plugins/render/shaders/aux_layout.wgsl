// Where the preview blocks' object slots start in a view's `aux` buffer of a width × height image:
// after the per-pixel depths and slots and the blocks' samples, room made for the finest preview
// scale (blocks of 2 × 2 pixels).
fn block_objects_start(width: u32, height: u32) -> u32 {
    return 2u * width * height + 4u * ((width + 1u) / 2u) * ((height + 1u) / 2u);
}

// Where pixel i's split of the denoiser's head sum lies (guide_layout.wgsl: the first P / 2
// samples' share of it and their mean albedo luminance, two unorm16), after the blocks' slots:
// in `aux`, not in the guides, so a view's largest buffer (the guides, 7 words a pixel) does not
// grow.
fn head_split_at(width: u32, height: u32, i: u32) -> u32 {
    return block_objects_start(width, height) + ((width + 1u) / 2u) * ((height + 1u) / 2u) + i;
}


// Where pixel i's split of the denoiser's tail lies (the samples after the head: the first half
// of a head's count of them, their share of the tail's sum and their mean albedo luminance, two
// unorm16), after the head splits.
fn tail_split_at(width: u32, height: u32, i: u32) -> u32 {
    return head_split_at(width, height, width * height) + i;
}
