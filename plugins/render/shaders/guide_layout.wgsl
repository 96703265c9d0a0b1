// The denoiser's guides, GUIDE_WORDS words a pixel, written by the trace kernel: the mean shading
// normal of the samples whose primary hit is on the first one's object (octahedral, pack2x16snorm;
// on a crease, between its faces', so the pixels along it filter alike); the summed luminance of
// the light the first P samples reflect (their colour less what their primary hits emit), P the
// largest power of two below their count (an f32, its sign bit set once the samples met more than
// one surface: another object, or another face of a crease, `CREASE_COSINE` in pathtrace.wgsl); the
// sum of the samples' primary hits' albedo (three f32); the mean light those hits emit (three f16
// in two words: the denoiser subtracts and the resolve adds back the same value, so its rounding
// moves no light; the view's largest buffer stays small); in the last half word, the mean albedo
// luminance of the first P samples (an f16), so the denoiser can demodulate them apart from the
// rest. The first P / 2 samples' share of the head sum and their mean albedo luminance (two
// unorm16: a share, not a sum, so no light is too bright for it), the head split in two, lie in the
// view's `aux` buffer (`head_split_at`, aux_layout.wgsl), and so does the tail's split in two
// (`tail_split_at`).
const GUIDE_WORDS: u32 = 7u;

// How many of n samples the guide's head sum covers: the largest power of two below n.
fn head_count(n: u32) -> u32 {
    return 1u << (31u - countLeadingZeros(n - 1u));
}

// Whether a pixel of n samples has four parts: its samples reach past the first half of its tail
// (`tail_split_at`, aux_layout.wgsl), n > a + a / 2 for a head of a samples, at least 2.
fn four_parts(n: u32) -> bool {
    if n < 4u {
        return false;
    }
    let a = head_count(n);
    return n > a + a / 2u;
}
const GUIDE_NORMAL: u32 = 0u;
const GUIDE_HEAD: u32 = 1u;
const GUIDE_ALBEDO: u32 = 2u;
const GUIDE_EMISSION: u32 = 5u;

// The mean light a pixel's samples' primary hits emit.
fn guide_emission(i: u32) -> vec3<f32> {
    let g = GUIDE_WORDS * i + GUIDE_EMISSION;
    return vec3<f32>(unpack2x16float(guides[g]), unpack2x16float(guides[g + 1u]).x);
}

// The mean albedo luminance of a pixel's first P samples (the head sum's samples).
fn guide_head_albedo(i: u32) -> f32 {
    return unpack2x16float(guides[GUIDE_WORDS * i + GUIDE_EMISSION + 1u]).y;
}
