// The denoiser: an edge-aware à-trous filter (SVGF's spatial part) over a view's accumulated
// samples, guided by what the trace kernel keeps of each pixel's primary hits (the first one's
// object slot, shading normal and depth; the mean albedo of all) and by the noise of each pixel's mean (from its samples' squared
// luminance, averaged over its neighbours). Lighting is
// filtered apart from the surface colour (divided by the albedo here, multiplied back by the
// resolve), so textures stay sharp; taps on another object never count, so nothing smears across
// an object's edge or over the selection outline. A first pass reads the accumulation and filters
// nothing: it holds each pixel's lighting to at most TAME times its brightest neighbour's (a rare
// bright path among few samples is a firefly the filter would spread into a blotch) and estimates
// its noise. Then up to five filter passes, taps 1, 2, 4, 8 and 16 pixels apart. Each pass writes
// (rgb: demodulated colour, w: its variance) for the next, the last for the resolve. The crate
// appends octahedral.wgsl.

struct Denoise {
    width: u32,
    height: u32,
    // Pixels between taps.
    step: u32,
    // 1 for the first pass (reads the accumulation).
    first: u32,
    sigma_luminance: f32,
    sigma_normal: f32,
    sigma_depth: f32,
    pad: u32,
}

const NONE: u32 = 0xffffffffu;
// How far above its brightest neighbour a pixel's lighting may stand.
const TAME: f32 = 3.0;

@group(0) @binding(0) var<storage, read> accum: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> aux: array<u32>;
// Storage, not uniform: lavapipe recompiles a shader whose branches test uniforms at every
// bind (see `view_buffers` in prepare.rs).
@group(0) @binding(2) var<storage, read> params: Denoise;
@group(0) @binding(3) var<storage, read> source: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> filtered: array<vec4<f32>>;
// The trace kernel's guides, five words a pixel (see pathtrace.wgsl).
@group(0) @binding(5) var<storage, read> guides: array<u32>;

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

struct Guide {
    slot: u32,
    normal: vec3<f32>,
    depth: f32,
    albedo: vec3<f32>,
    // The sum of the samples' squared luminance.
    moment: f32,
    // Whether its samples met more than one object.
    mixed: bool,
}

fn guide(i: u32) -> Guide {
    let pixels = params.width * params.height;
    let g = 5u * i;
    var out: Guide;
    out.slot = aux[pixels + i];
    out.normal = decode_normal(guides[g]);
    out.depth = bitcast<f32>(aux[i]);
    let sum = vec3<f32>(bitcast<f32>(guides[g + 2u]), bitcast<f32>(guides[g + 3u]), bitcast<f32>(guides[g + 4u]));
    out.albedo = sum / max(accum[i].w, 1.0);
    let m = bitcast<f32>(guides[g + 1u]);
    out.moment = abs(m);
    out.mixed = m < 0.0;
    return out;
}

// The variance of a pixel's mean luminance, from its samples (in demodulated units).
fn mean_variance(i: u32, g: Guide) -> f32 {
    let a = accum[i];
    let n = max(a.w, 1.0);
    let mean = luminance(a.rgb) / n;
    let v = max(g.moment / n - mean * mean, 0.0) / n;
    let albedo = max(luminance(g.albedo), 0.02);
    return v / (albedo * albedo);
}

// A pixel's mean colour divided by its albedo (lighting alone).
fn demodulated(i: u32, g: Guide) -> vec3<f32> {
    let a = accum[i];
    return a.rgb / max(a.w, 1.0) / max(g.albedo, vec3<f32>(0.02));
}

// A pixel's demodulated colour `c`, its luminance held to TAME times `top` (the brightest of its
// 8 neighbours') but lowered by no more than 3 standard deviations of its mean (`variance`): a
// firefly (one rare bright path among few samples) would spread into a blotch, while a bright
// feature a pixel wide that the samples agree on stays.
fn tamed(c: vec3<f32>, top: f32, variance: f32) -> vec3<f32> {
    let l = luminance(c);
    let bound = max(top * TAME, l - 3.0 * sqrt(variance));
    if l > bound && bound > 0.0 {
        return c * (bound / l);
    }
    return c;
}

// Whether q can stand in for p at all: the same object, and both inside it or both on its
// silhouette (where samples met another object too: such pixels blend two surfaces, and only
// those along the same edge blend them alike).
fn same_surface(p: Guide, q: Guide) -> bool {
    return q.slot == p.slot && q.mixed == p.mixed;
}

// The edge-stopping weight of q's value at p (besides the kernel's and the luminance's).
fn geometry_weight(p: Guide, q: Guide, distance: f32) -> f32 {
    let wn = pow(max(dot(p.normal, q.normal), 0.0), params.sigma_normal);
    // Reversed-z depth is inversely proportional to distance: their ratio is the distances'.
    var wz = 1.0;
    if p.depth > 0.0 && q.depth > 0.0 {
        wz = exp(-abs(q.depth / p.depth - 1.0) / (params.sigma_depth * distance));
    }
    // Sky pixels (no normal) filter with sky pixels.
    if p.slot == NONE {
        return 1.0;
    }
    return wn * wz;
}

@compute @workgroup_size(8, 8, 1)
fn denoise(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let p = vec2<i32>(id.xy);
    let size = vec2<i32>(i32(params.width), i32(params.height));
    let i = id.y * params.width + id.x;
    if accum[i].w <= 0.0 {
        filtered[i] = vec4<f32>(0.0);
        return;
    }
    let gp = guide(i);
    if params.first == 1u {
        // The first pass filters nothing: it writes each pixel's lighting, tamed by its 8
        // neighbours, and the noise of the pixels' means averaged over the 3 × 3 pixels of the
        // same object around (a few samples say little about their own spread).
        var v = 0.0;
        var n = 0.0;
        var top = 0.0;
        for (var dy = -1; dy <= 1; dy += 1) {
            for (var dx = -1; dx <= 1; dx += 1) {
                let q = p + vec2<i32>(dx, dy);
                if any(q < vec2<i32>(0)) || any(q >= size) {
                    continue;
                }
                let j = u32(q.y) * params.width + u32(q.x);
                if accum[j].w <= 0.0 {
                    continue;
                }
                let gq = guide(j);
                if j != i {
                    top = max(top, luminance(demodulated(j, gq)));
                    if !same_surface(gp, gq) {
                        continue;
                    }
                }
                v += mean_variance(j, gq);
                n += 1.0;
            }
        }
        filtered[i] = vec4<f32>(tamed(demodulated(i, gp), top, mean_variance(i, gp)), v / n);
        return;
    }
    let centre = source[i];
    let sigma = params.sigma_luminance * sqrt(centre.w) + 1e-4;
    let lp = luminance(centre.rgb);
    let kernel = array<f32, 3>(3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);
    var sum = vec3<f32>(0.0);
    var variance = 0.0;
    var total = 0.0;
    for (var dy = -2; dy <= 2; dy += 1) {
        for (var dx = -2; dx <= 2; dx += 1) {
            let q = p + vec2<i32>(dx, dy) * i32(params.step);
            if any(q < vec2<i32>(0)) || any(q >= size) {
                continue;
            }
            let j = u32(q.y) * params.width + u32(q.x);
            if accum[j].w <= 0.0 {
                continue;
            }
            let gq = guide(j);
            if j != i && !same_surface(gp, gq) {
                continue;
            }
            let v = source[j];
            let k = kernel[abs(dx)] * kernel[abs(dy)];
            let distance = max(length(vec2<f32>(vec2<i32>(dx, dy) * i32(params.step))), 1.0);
            let wl = exp(-abs(luminance(v.rgb) - lp) / sigma);
            let w = k * geometry_weight(gp, gq, distance) * wl;
            sum += w * v.rgb;
            variance += w * w * v.w;
            total += w;
        }
    }
    filtered[i] = vec4<f32>(sum / total, variance / (total * total));
}
