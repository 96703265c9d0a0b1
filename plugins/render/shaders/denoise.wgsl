// The denoiser: an edge-aware à-trous filter (SVGF's spatial part) over a view's accumulated
// samples, guided by what the trace kernel keeps of each pixel's primary hits (the first one's
// object slot and depth, the mean shading normal of those on its object, the mean albedo and
// emission of all) and by the noise of
// each pixel's mean. That noise is measured, not inferred from the samples' spread: a pixel's
// samples cover it evenly (a Sobol sequence), so what varies across it (a texture finer than the
// pixel, an edge) spreads them widely while their mean is nearly exact; the spread would call it
// noise and the filter would blur it away. The trace kernel keeps the first P samples' sum apart
// (P a power of two), and the difference between their mean and the rest's, two independent
// estimates each covering the pixel evenly, gives the variance of the whole mean, averaged over
// the 3 × 3 pixels of the same object around. The same two estimates decide how far two pixels'
// lighting truly differs: the product of their differences has the squared true difference for
// its mean, noise adding nothing (a difference of noisy means is inflated by their noise), so
// the filter mixes pixels while their true difference stays within the noise it removes
// (`sigma_luminance` deviations), and noise is not taken for detail nor detail for noise.
//
// Those two estimates cannot tell a few rare bright paths that fell in both (a caustic, one
// sample in 20, lands in both halves of 16 samples one time in nine) from true detail, and the
// filter would keep such a pixel as a speckle. The trace kernel splits the head in two and the
// tail in two, so a pixel has four parts (three until its tail passes its first half), and the
// second lowest of them is its lighting with what its parts caught alone left out: a pixel
// standing far above that level of all its neighbours, and whose own parts do not all agree, is a
// firefly. It is tamed, and the filter mixes it with its neighbours as noise. Where each part
// holds at least 4 samples, the four parts also give the noise (three independent contrasts, not
// one) and the filter's differences (the mean of their six pairwise products, not one), both
// steadier than the halves alone.
//
// Reflected light is filtered apart from the surface colour (divided by the albedo here,
// multiplied back by the resolve), so textures stay sharp; emitted light and directly seen sky are
// not filtered at all. Taps on another object never count, so nothing smears across an object's
// edge or over the selection outline. A first pass reads the accumulation and filters nothing: it
// holds each pixel's lighting to at most TAME times its neighbours' highest level (a rare
// bright path among few samples is a firefly the filter would spread into a blotch) and estimates
// its noise.
// Then up to five filter passes, taps 1, 2, 4, 8 and 16 pixels apart. Each pass writes (rgb:
// demodulated colour, w: its variance) for the next, the last for the resolve. The first pass also
// keeps what a tap reads of each pixel (`taps`): the filter passes read that alone, a third of
// the words (most of a pass's cost on a CPU adapter is in its gathers), and a run spread over
// frames filters one snapshot while the trace goes on. The crate appends aux_layout.wgsl,
// guide_layout.wgsl and octahedral.wgsl.

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
const LOG2_E: f32 = 1.4426950408889634;
// How far above its neighbours' highest level (`PartStats`) a pixel's lighting may stand.
const TAME: f32 = 3.0;

@group(0) @binding(0) var<storage, read> accum: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> aux: array<u32>;
// Storage, not uniform: lavapipe recompiles a shader whose branches test uniforms at every
// bind (see `view_buffers` in prepare.rs).
@group(0) @binding(2) var<storage, read> params: Denoise;
@group(0) @binding(3) var<storage, read> source: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> filtered: array<vec4<f32>>;
// The trace kernel's guides (guide_layout.wgsl).
@group(0) @binding(5) var<storage, read> guides: array<u32>;
// Written by the first pass, read by the others: TAP_WORDS words a pixel, what `Tap` holds.
@group(0) @binding(6) var<storage, read_write> taps: array<u32>;

// A tap's words: its slot and flags (the slot shifted past TAP_FLAG_BITS), its normal, depth and
// variance, then its parts as a scale (f32) and four fractions of it (two pack2x16snorm).
const TAP_WORDS: u32 = 7u;
const TAP_FLAG_BITS: u32 = 3u;
// The slot word's slot part for NONE: a view holds no object slot this high (its records would
// outgrow any binding).
const TAP_NO_SLOT: u32 = 0x1fffffffu;
// A tap's flags: the pixel had samples; they met more than one surface (a silhouette or a crease).
const TAP_SAMPLED: u32 = 1u;
const TAP_MIXED: u32 = 2u;
// The tap holds four parts to compare (`quarters`), not two.
const TAP_FOUR: u32 = 4u;
// The noise a firefly's tap declares: any difference from its neighbours is within it.
const UNBOUNDED: f32 = 1e30;

// What a filter pass reads of a pixel it taps, as the first pass saw it.
struct Tap {
    slot: u32,
    flags: u32,
    normal: vec3<f32>,
    depth: f32,
    // Its two independent estimates of the lighting (`parts`), or with TAP_FOUR its four in la,
    // lb, lc and ld (`quarters`), and the variance of its mean (`PartStats`, negative with a
    // single sample).
    la: f32,
    lb: f32,
    variance: f32,
    lc: f32,
    ld: f32,
}

fn snapshot(g: Guide, pp: vec3<f32>, stats: PartStats) -> Tap {
    var t: Tap;
    t.slot = g.slot;
    t.flags = TAP_SAMPLED | select(0u, TAP_MIXED, g.mixed);
    t.normal = g.normal;
    t.depth = g.depth;
    t.la = pp.x;
    t.lb = pp.y;
    t.lc = 0.0;
    t.ld = 0.0;
    t.variance = stats.variance;
    if stats.compared {
        t.flags |= TAP_FOUR;
        t.la = stats.quarters.x;
        t.lb = stats.quarters.y;
        t.lc = stats.quarters.z;
        t.ld = stats.quarters.w;
    }
    return t;
}

// A tap's two independent estimates of its lighting: its halves, or, from four parts, the means
// of its head's two and its tail's two (where the taps compared had different sample counts).
fn tap_halves(t: Tap) -> vec2<f32> {
    if (t.flags & TAP_FOUR) != 0u {
        return 0.5 * vec2<f32>(t.la + t.lb, t.lc + t.ld);
    }
    return vec2<f32>(t.la, t.lb);
}

fn keep_tap(i: u32, t: Tap) {
    let w = TAP_WORDS * i;
    taps[w] = (min(t.slot, TAP_NO_SLOT) << TAP_FLAG_BITS) | t.flags;
    taps[w + 1u] = guides[GUIDE_WORDS * i + GUIDE_NORMAL];
    taps[w + 2u] = bitcast<u32>(t.depth);
    taps[w + 3u] = bitcast<u32>(t.variance);
    // The parts as fractions of the largest: a fixed step of it, however bright the pixel.
    let parts = vec4<f32>(t.la, t.lb, t.lc, t.ld);
    let largest = max(max(abs(parts.x), abs(parts.y)), max(abs(parts.z), abs(parts.w)));
    let fractions = select(vec4<f32>(0.0), parts / largest, largest > 0.0);
    taps[w + 4u] = bitcast<u32>(largest);
    taps[w + 5u] = pack2x16snorm(fractions.xy);
    taps[w + 6u] = pack2x16snorm(fractions.zw);
}

// The slot and flags of a pixel's tap, read first: most taps go no further.
fn tap_head(j: u32) -> vec2<u32> {
    let word = taps[TAP_WORDS * j];
    let slot = word >> TAP_FLAG_BITS;
    return vec2<u32>(select(slot, NONE, slot == TAP_NO_SLOT), word & ((1u << TAP_FLAG_BITS) - 1u));
}

// Marks pixel i's tap as having no samples.
fn clear_tap(i: u32) {
    taps[TAP_WORDS * i] = 0u;
}

// Declares pixel i's tap a firefly's: any difference from its neighbours is within its noise.
fn declare_firefly(i: u32) {
    taps[TAP_WORDS * i + 3u] = bitcast<u32>(UNBOUNDED);
}

fn read_tap(j: u32, head: vec2<u32>) -> Tap {
    let w = TAP_WORDS * j;
    var t: Tap;
    t.slot = head.x;
    t.flags = head.y;
    t.normal = decode_normal(taps[w + 1u]);
    t.depth = bitcast<f32>(taps[w + 2u]);
    t.variance = bitcast<f32>(taps[w + 3u]);
    let largest = bitcast<f32>(taps[w + 4u]);
    let ab = unpack2x16snorm(taps[w + 5u]) * largest;
    let cd = unpack2x16snorm(taps[w + 6u]) * largest;
    t.la = ab.x;
    t.lb = ab.y;
    t.lc = cd.x;
    t.ld = cd.y;
    return t;
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

struct Guide {
    slot: u32,
    normal: vec3<f32>,
    depth: f32,
    albedo: vec3<f32>,
    // The mean light the samples' primary hits emit.
    emission: vec3<f32>,
    // The summed luminance of the light the first `head_count` samples reflect, and their mean
    // albedo luminance; the first half of those samples' share of that sum, and their mean albedo
    // luminance.
    head: f32,
    head_albedo: f32,
    split: vec2<f32>,
    // The tail's split: the share of the tail's sum of its first half a head's count of samples,
    // and their mean albedo luminance.
    tail_split: vec2<f32>,
    // Whether its samples met more than one surface (a silhouette or a crease).
    mixed: bool,
}

fn guide(i: u32) -> Guide {
    let pixels = params.width * params.height;
    let g = GUIDE_WORDS * i;
    let n = max(accum[i].w, 1.0);
    var out: Guide;
    out.slot = aux[pixels + i];
    out.normal = decode_normal(guides[g + GUIDE_NORMAL]);
    out.depth = bitcast<f32>(aux[i]);
    let sum = vec3<f32>(
        bitcast<f32>(guides[g + GUIDE_ALBEDO]),
        bitcast<f32>(guides[g + GUIDE_ALBEDO + 1u]),
        bitcast<f32>(guides[g + GUIDE_ALBEDO + 2u]),
    );
    out.albedo = sum / n;
    out.emission = guide_emission(i);
    let m = guides[g + GUIDE_HEAD];
    out.head = bitcast<f32>(m & 0x7fffffffu);
    out.head_albedo = guide_head_albedo(i);
    out.split = unpack2x16unorm(aux[head_split_at(params.width, params.height, i)]);
    out.tail_split = unpack2x16unorm(aux[tail_split_at(params.width, params.height, i)]);
    out.mixed = (m >> 31u) != 0u;
    return out;
}

// A pixel's two independent estimates of its lighting (luminance, demodulated): the mean of its
// first a samples and the rest's (b), each divided by its own samples' albedo, and (z) a b / n², 0
// where it has a single sample.
fn parts(i: u32, g: Guide) -> vec3<f32> {
    let n = u32(accum[i].w);
    if n < 2u {
        return vec3<f32>(0.0);
    }
    let a = f32(head_count(n));
    let b = f32(n) - a;
    let whole = luminance(g.albedo) * f32(n);
    let tail_albedo = (whole - g.head_albedo * a) / b;
    let reflected = luminance(accum[i].rgb) - luminance(g.emission) * f32(n);
    let la = g.head / a / max(g.head_albedo, 0.02);
    let lb = (reflected - g.head) / b / max(tail_albedo, 0.02);
    return vec3<f32>(la, lb, a * b / (f32(n) * f32(n)));
}

// A pixel's three independent estimates of its lighting (luminance, demodulated): the means of its
// first P / 2 samples, of the next P / 2 and of the rest, each divided by its own samples' albedo;
// below 3 samples, its mean three times. `rest` is the last (the second of its `parts`), `mean`
// its whole demodulated luminance, both already at hand where this is asked. They are used for
// fireflies only: a part of a single sample covers one point of the pixel, so their spread would
// count what varies across the pixel as noise, as the halves' (`parts`) does not.
fn thirds(i: u32, g: Guide, rest: f32, mean: f32) -> vec3<f32> {
    let n = u32(accum[i].w);
    if n < 3u {
        return vec3<f32>(mean);
    }
    let h = 0.5 * f32(head_count(n));
    let second_albedo = 2.0 * g.head_albedo - g.split.y;
    let first = g.split.x * g.head / h / max(g.split.y, 0.02);
    let second = (1.0 - g.split.x) * g.head / h / max(second_albedo, 0.02);
    return vec3<f32>(first, second, rest);
}

// A pixel's four independent estimates of its lighting (luminance, demodulated) where it has
// them (`four_parts`): the means of the head's two halves (`thirds`' first two), then of the
// tail's first half a head's count of samples and of the rest, each divided by its own samples'
// albedo.
fn quarters(i: u32, g: Guide, t: vec3<f32>) -> vec4<f32> {
    let n = f32(accum[i].w);
    let a = f32(head_count(u32(n)));
    let half = 0.5 * a;
    let reflected = luminance(accum[i].rgb) - luminance(g.emission) * n;
    let tail = max(reflected - g.head, 0.0);
    let last = n - a - half;
    let tail_albedo = luminance(g.albedo) * n - g.head_albedo * a;
    let last_albedo = (tail_albedo - g.tail_split.y * half) / last;
    let c = g.tail_split.x * tail / half / max(g.tail_split.y, 0.02);
    let d = (1.0 - g.tail_split.x) * tail / last / max(last_albedo, 0.02);
    return vec4<f32>(t.x, t.y, c, d);
}

// What a pixel's parts say of it.
struct PartStats {
    // Its lighting with what its parts caught alone left out: the second lowest of four parts,
    // the middle of three.
    level: f32,
    // What all its parts agree on: the lowest.
    agreed: f32,
    // The variance of its mean luminance (negative with a single sample).
    variance: f32,
    // Its four parts, where `compared`.
    quarters: vec4<f32>,
    // Whether it has four parts of at least 4 samples each, which then also give the variance
    // and the filter's differences: a part of fewer samples covers the pixel too unevenly, and
    // their spread would count what varies across the pixel (a texture, an edge) as noise.
    compared: bool,
}

// A pixel's `PartStats` from its `parts` (`pp`) and its whole demodulated luminance (`mean`).
fn part_stats(i: u32, g: Guide, pp: vec3<f32>, mean: f32) -> PartStats {
    let n = u32(accum[i].w);
    let t = thirds(i, g, pp.y, mean);
    var out: PartStats;
    out.variance = part_variance(pp);
    out.compared = false;
    if !four_parts(n) {
        out.level = middle(t);
        out.agreed = min(min(t.x, t.y), t.z);
        return out;
    }
    let q = quarters(i, g, t);
    let lo = min(q.xz, q.yw);
    let hi = max(q.xz, q.yw);
    // The second lowest of the four: the higher of the pairs' lows, or the lower of their highs.
    out.level = min(max(lo.x, lo.y), min(hi.x, hi.y));
    out.agreed = min(lo.x, lo.y);
    let h = 0.5 * f32(head_count(n));
    let last = f32(n) - 3.0 * h;
    if h < 4.0 || last < 4.0 {
        return out;
    }
    // Three independent contrasts (the halves, and each half's two parts), each an estimate of
    // the mean's variance s² / n: a difference of means of x and y samples has the variance
    // s² (1 / x + 1 / y).
    let c2 = q.x - q.y;
    let c3 = q.z - q.w;
    let v2 = c2 * c2 / (f32(n) * (2.0 / h));
    let v3 = c3 * c3 / (f32(n) * (1.0 / h + 1.0 / last));
    out.variance = (out.variance + v2 + v3) / 3.0;
    out.quarters = q;
    out.compared = true;
    return out;
}

// The middle one of three values: a pixel's lighting with what one of its parts caught alone left
// out.
fn middle(v: vec3<f32>) -> f32 {
    return max(min(v.x, v.y), min(max(v.x, v.y), v.z));
}

// The variance of a pixel's mean luminance from its `parts`: two independent estimates of a and
// b samples whose difference d has the variance s² (1 / a + 1 / b), s² a sample's, while the
// mean's is s² / (a + b) = d² a b / n² on average. Negative where the pixel has a single sample.
fn part_variance(parts: vec3<f32>) -> f32 {
    let d = parts.x - parts.y;
    return select(-1.0, d * d * parts.z, parts.z > 0.0);
}

// A pixel's mean reflected light (its colour less what its surfaces emit) divided by its albedo:
// lighting alone.
fn demodulated(i: u32, g: Guide) -> vec3<f32> {
    let a = accum[i];
    let reflected = max(a.rgb / max(a.w, 1.0) - g.emission, vec3<f32>(0.0));
    return reflected / max(g.albedo, vec3<f32>(0.02));
}

// A pixel's demodulated colour `c`, its luminance held to TAME times `top` (the highest of its 8
// neighbours' middle parts) but not below `agreed`, what the samples agree on: a firefly (rare
// bright paths among few samples) would spread into a blotch, while a bright feature a pixel wide
// stays (its neighbours along it, or all its samples, agree).
fn tamed(c: vec3<f32>, top: f32, agreed: f32) -> vec3<f32> {
    let l = luminance(c);
    let bound = max(top * TAME, agreed);
    if l > bound && bound > 0.0 {
        return c * (bound / l);
    }
    return c;
}

// Whether q can stand in for p at all (their taps' slots and flags): the same object, and both
// inside it or both on its silhouette or a crease (where samples met another object too, or
// another face of it: such pixels blend two surfaces, and only those along the same edge blend
// them alike).
fn same_surface(p: vec2<u32>, q: vec2<u32>) -> bool {
    return q.x == p.x && (q.y & TAP_MIXED) == (p.y & TAP_MIXED);
}

// The edge-stopping weight of q's value at p (besides the kernel's and the luminance's), as its
// base-2 logarithm: a tap's weights multiply, so one exp2 of their logarithms' sum takes the place
// of three exponentials (on a CPU adapter these dominate a pass).
fn geometry_log_weight(p: Tap, q: Tap, distance: f32) -> f32 {
    // Sky pixels (no normal) filter with sky pixels.
    if p.slot == NONE {
        return 0.0;
    }
    let cosine = dot(p.normal, q.normal);
    if cosine <= 0.0 {
        return -1e30;
    }
    var l = params.sigma_normal * log2(cosine);
    // Reversed-z depth is inversely proportional to distance: their ratio is the distances'.
    if p.depth > 0.0 && q.depth > 0.0 {
        l -= LOG2_E * abs(q.depth / p.depth - 1.0) / (params.sigma_depth * distance);
    }
    return l;
}

@compute @workgroup_size(8, 8, 1)
fn denoise(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let i = id.y * params.width + id.x;
    if params.first == 1u {
        first_pass(vec2<i32>(id.xy), i);
    } else {
        filter_pass(vec2<i32>(id.xy), i);
    }
}

// The first pass filters nothing: it writes each pixel's lighting, tamed by its 8 neighbours, and
// the noise of the pixels' means averaged over the 3 × 3 pixels of the same object around (one
// pixel's two halves say little about their spread), and keeps the pixel's tap. With one sample a
// pixel, the spread of those pixels' lighting stands in.
fn first_pass(p: vec2<i32>, i: u32) {
    if accum[i].w <= 0.0 {
        filtered[i] = vec4<f32>(0.0);
        clear_tap(i);
        return;
    }
    let size = vec2<i32>(i32(params.width), i32(params.height));
    let gp = guide(i);
    let own = demodulated(i, gp);
    let pp = parts(i, gp);
    let sp = part_stats(i, gp, pp, luminance(own));
    let tp = snapshot(gp, pp, sp);
    keep_tap(i, tp);
    // Directly seen sky is the sky itself, not noise: it passes every pass unfiltered.
    if gp.slot == NONE && !gp.mixed {
        filtered[i] = vec4<f32>(demodulated(i, gp), 0.0);
        return;
    }
    let hp = vec2<u32>(tp.slot, tp.flags);
    var v = 0.0;
    var nv = 0.0;
    var n = 0.0;
    var l1 = 0.0;
    var l2 = 0.0;
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
            let lq = luminance(demodulated(j, gq));
            var sq = sp;
            if j != i {
                sq = part_stats(j, gq, parts(j, gq), lq);
                top = max(top, sq.level);
                let hq = vec2<u32>(gq.slot, select(0u, TAP_MIXED, gq.mixed));
                if !same_surface(hp, hq) {
                    continue;
                }
            }
            if sq.variance >= 0.0 {
                v += sq.variance;
                nv += 1.0;
            }
            l1 += lq;
            l2 += lq * lq;
            n += 1.0;
        }
    }
    var variance = v / max(nv, 1.0);
    if tp.variance < 0.0 {
        variance = max(l2 / n - (l1 / n) * (l1 / n), 0.0);
    }
    // What the samples agree on: the lowest of the pixel's parts (a firefly must be in all of
    // them to pass), or, with a single sample, 3 standard deviations below its mean.
    var agreed = luminance(own) - 3.0 * sqrt(variance);
    if tp.variance >= 0.0 {
        agreed = sp.agreed;
    }
    let kept = tamed(own, top, agreed);
    // Held down by its neighbours, not by what its own samples agree on: a firefly, whose excess
    // is noise, so the filter passes mix it with its neighbours.
    if luminance(own) > top * TAME && agreed < top * TAME {
        declare_firefly(i);
    }
    filtered[i] = vec4<f32>(kept, variance);
}

// A filter pass: 5 × 5 taps `step` pixels apart, over the first pass's taps and the last pass's
// output.
fn filter_pass(p: vec2<i32>, i: u32) {
    let hp = tap_head(i);
    if (hp.y & TAP_SAMPLED) == 0u {
        filtered[i] = vec4<f32>(0.0);
        return;
    }
    // Directly seen sky passes as the first pass left it.
    if hp.x == NONE && (hp.y & TAP_MIXED) == 0u {
        filtered[i] = source[i];
        return;
    }
    let size = vec2<i32>(i32(params.width), i32(params.height));
    let tp = read_tap(i, hp);
    let centre = source[i];
    let lp = luminance(centre.rgb);
    let raw_p = max(tp.variance, 0.0);
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
            let hq = tap_head(j);
            if (hq.y & TAP_SAMPLED) == 0u || (j != i && !same_surface(hp, hq)) {
                continue;
            }
            let tq = read_tap(j, hq);
            let v = source[j];
            let k = kernel[abs(dx)] * kernel[abs(dy)];
            let distance = max(length(vec2<f32>(vec2<i32>(dx, dy) * i32(params.step))), 1.0);
            // How far q's lighting truly is from p's, against the noise of both: the product of
            // the differences of their two independent estimates has the square of the true
            // difference for its mean, noise adding nothing to it (as it would to a difference
            // of the noisy means), so noise is not taken for detail nor a firefly for an edge.
            let raw = raw_p + max(tq.variance, 0.0);
            let spread = params.sigma_luminance * params.sigma_luminance * max(centre.w + v.w, raw) + 1e-8;
            var ll = 0.0;
            if (tp.flags & tq.flags & TAP_FOUR) != 0u {
                // Every pair of independent parts gives an estimate: their mean.
                let d = vec4<f32>(tq.la - tp.la, tq.lb - tp.lb, tq.lc - tp.lc, tq.ld - tp.ld);
                let s1 = d.x + d.y + d.z + d.w;
                ll = max((s1 * s1 - dot(d, d)) / 12.0, 0.0) / spread;
            } else if tp.variance >= 0.0 && tq.variance >= 0.0 {
                let dp = tap_halves(tq) - tap_halves(tp);
                ll = max(dp.x * dp.y, 0.0) / spread;
            } else {
                ll = abs(luminance(v.rgb) - lp) / sqrt(spread);
            }
            let w = k * exp2(geometry_log_weight(tp, tq, distance) - LOG2_E * ll);
            sum += w * v.rgb;
            variance += w * w * v.w;
            total += w;
        }
    }
    filtered[i] = vec4<f32>(sum / total, variance / (total * total));
}
