// A pixel's colour from the denoiser's result (`denoised`, its reflected light divided by its
// albedo) and its `n` samples' guides: times the albedo, plus the light its surfaces emit, which
// passes the filter untouched. Kernels that append this file declare `guides` and `denoised`.
fn remodulated(i: u32, n: f32) -> vec3<f32> {
    let g = GUIDE_WORDS * i;
    let albedo = vec3<f32>(
        bitcast<f32>(guides[g + GUIDE_ALBEDO]),
        bitcast<f32>(guides[g + GUIDE_ALBEDO + 1u]),
        bitcast<f32>(guides[g + GUIDE_ALBEDO + 2u]),
    ) / n;
    return denoised[i].rgb * max(albedo, vec3<f32>(0.02)) + guide_emission(i);
}
