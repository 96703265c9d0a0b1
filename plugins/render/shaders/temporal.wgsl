// Temporal reuse through camera motion. Each frame this pass writes what the view shows (`shown`,
// read by the resolve): the current estimate of each traced pixel (the denoised or averaged
// samples, else the preview) mixed with a prior. When the camera alone moved, the prior is rebuilt
// from the last frame's picture: each pixel's primary hit is carried back to the previous camera
// (its depth through the two cameras' matrices) and read there, bilinearly, from the taps on the
// same object at the same depth whose samples all met that object (so what the move uncovers
// takes nothing from what hid it). Any
// other change (an edit, the light, a resize) clears the prior. The prior weighs as many samples as
// the picture it came from held, up to `max_weight`, and fades out as the pixel's own samples reach
// `fade_samples`: from there on the view shows its samples alone.

struct Temporal {
    // The previous camera's clip space from the current one's: prev_clip_from_world × world_from_clip.
    reproject: mat4x4<f32>,
    width: u32,
    height: u32,
    // Pixels per preview block where a pixel has no sample yet; 0: no preview.
    preview_scale: u32,
    // 1: the denoiser's result stands for a pixel's samples.
    denoised: u32,
    // 0: keep the prior; 1: rebuild it from the last frame (the camera alone moved); 2: clear it.
    restart: u32,
    max_weight: f32,
    fade_samples: f32,
    pad: u32,
}

const NONE: u32 = 0xffffffffu;
// A preview block's single sample stands in for a pixel's as one sample.
const PREVIEW_WEIGHT: f32 = 1.0;

@group(0) @binding(0) var<storage, read> accum: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> aux: array<u32>;
// Storage, not uniform: lavapipe recompiles a shader whose branches test uniforms at every
// bind (see `view_buffers` in prepare.rs).
@group(0) @binding(2) var<storage, read> params: Temporal;
// The denoiser's last pass: per pixel its lighting, to be multiplied by the albedo.
@group(0) @binding(3) var<storage, read> denoised: array<vec4<f32>>;
// The trace kernel's guides (guide_layout.wgsl): the albedo and the emitted light summed over a
// pixel's samples, and whether they met more than one surface.
@group(0) @binding(4) var<storage, read> guides: array<u32>;
// The last frame's picture and this frame's, 16 bytes a pixel (as the accumulation, so a view that
// binds one binds the other): rgb and weight in half floats (`pack_picture`), the primary hit's
// depth (negated less one where the pixel's samples met more than one surface) and object slot.
@group(0) @binding(5) var<storage, read> history: array<vec4<u32>>;
@group(0) @binding(6) var<storage, read_write> shown: array<vec4<u32>>;
// Per pixel the prior: (rgb, weight).
@group(0) @binding(7) var<storage, read_write> prior: array<vec4<f32>>;

// Colour and weight in two words of half floats (colour clamped to what a half float holds).
fn pack_picture(colour: vec3<f32>, weight: f32) -> vec2<u32> {
    let c = min(colour, vec3<f32>(65000.0));
    return vec2<u32>(pack2x16float(c.xy), pack2x16float(vec2<f32>(c.z, weight)));
}

fn unpack_picture(p: vec4<u32>) -> vec4<f32> {
    let zw = unpack2x16float(p.y);
    return vec4<f32>(unpack2x16float(p.x), zw.x, zw.y);
}

struct Estimate {
    colour: vec3<f32>,
    weight: f32,
    depth: f32,
    object: u32,
    // Its samples met more than one surface (a silhouette or a crease): its colour is no one
    // surface's.
    mixed: bool,
}

fn aux_f32(i: u32) -> f32 {
    return bitcast<f32>(aux[i]);
}

fn preview_block(q: vec2<i32>, n: vec2<i32>) -> vec4<f32> {
    let c = clamp(q, vec2<i32>(0), n - vec2<i32>(1));
    let at = 2u * params.width * params.height + 4u * (u32(c.y) * u32(n.x) + u32(c.x));
    return vec4<f32>(aux_f32(at), aux_f32(at + 1u), aux_f32(at + 2u), aux_f32(at + 3u));
}

fn block_object(q: vec2<i32>, n: vec2<i32>) -> u32 {
    let c = clamp(q, vec2<i32>(0), n - vec2<i32>(1));
    return aux[block_objects_start(params.width, params.height) + u32(c.y) * u32(n.x) + u32(c.x)];
}

// What this frame has of a pixel: its samples (denoised where the denoiser ran), else the preview
// (bilinear between block centres; the nearest block's depth and object), else nothing.
fn estimate(p: vec2<u32>) -> Estimate {
    let pixels = params.width * params.height;
    let i = p.y * params.width + p.x;
    let a = accum[i];
    var e: Estimate;
    if a.w > 0.0 {
        if params.denoised == 1u {
            e.colour = remodulated(i, a.w);
        } else {
            e.colour = a.rgb / a.w;
        }
        e.weight = a.w;
        e.depth = aux_f32(i);
        e.object = aux[pixels + i];
        // The trace kernel sets the sign bit of their second guide word.
        e.mixed = (guides[GUIDE_WORDS * i + GUIDE_HEAD] >> 31u) != 0u;
        return e;
    }
    let k = params.preview_scale;
    if k == 0u {
        e.colour = vec3<f32>(0.0);
        e.weight = 0.0;
        e.depth = 0.0;
        e.object = NONE;
        e.mixed = false;
        return e;
    }
    let n = vec2<i32>((vec2<u32>(params.width, params.height) + vec2<u32>(k - 1u)) / k);
    let f = (vec2<f32>(p) + vec2<f32>(0.5)) / f32(k) - vec2<f32>(0.5);
    let q = vec2<i32>(floor(f));
    let t = f - floor(f);
    let top = mix(preview_block(q, n).rgb, preview_block(q + vec2<i32>(1, 0), n).rgb, t.x);
    let bottom = mix(preview_block(q + vec2<i32>(0, 1), n).rgb, preview_block(q + vec2<i32>(1, 1), n).rgb, t.x);
    e.colour = mix(top, bottom, t.y);
    e.weight = PREVIEW_WEIGHT;
    let b = vec2<i32>(p / k);
    e.depth = preview_block(b, n).w;
    e.object = block_object(b, n);
    // Between block centres the colour mixes four blocks: one object's only if all four are it.
    e.mixed = false;
    for (var j = 0; j < 4; j += 1) {
        e.mixed = e.mixed || block_object(q + vec2<i32>(j & 1, j >> 1u), n) != e.object;
    }
    return e;
}

// Whether a history tap at depth `seen` shows the point now at depth `expected` (both the previous
// camera's reverse-Z depths, proportional to the inverse distance): within 5% of either.
fn same_depth(expected: f32, seen: f32, object: u32) -> bool {
    if object == NONE {
        return true;
    }
    return abs(expected - seen) <= 0.05 * max(expected, seen);
}

// The last frame's picture where this pixel's primary hit was: (rgb, weight), weight 0 where the
// hit was not seen then (off screen, behind another object, or another object).
fn reprojected(p: vec2<u32>, e: Estimate) -> vec4<f32> {
    if e.weight <= 0.0 {
        return vec4<f32>(0.0);
    }
    let size = vec2<f32>(f32(params.width), f32(params.height));
    let uv = (vec2<f32>(p) + vec2<f32>(0.5)) / size;
    let ndc = vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    let c = params.reproject * vec4<f32>(ndc, e.depth, 1.0);
    if !(c.w > 0.0) {
        return vec4<f32>(0.0);
    }
    let q = c.xyz / c.w;
    let at = vec2<f32>((q.x + 1.0) * 0.5, (1.0 - q.y) * 0.5) * size - vec2<f32>(0.5);
    let base = vec2<i32>(floor(at));
    let t = at - floor(at);
    var colour = vec3<f32>(0.0);
    var weight = 0.0;
    var total = 0.0;
    for (var k = 0; k < 4; k += 1) {
        let o = vec2<i32>(k & 1, k >> 1u);
        let tap = base + o;
        if any(tap < vec2<i32>(0)) || tap.x >= i32(params.width) || tap.y >= i32(params.height) {
            continue;
        }
        let j = u32(tap.y) * params.width + u32(tap.x);
        let seen = history[j];
        let seen_depth = bitcast<f32>(seen.z);
        // A negative depth marks a pixel whose samples met more than one surface.
        if seen_depth < 0.0 || seen.w != e.object || !same_depth(q.z, seen_depth, e.object) {
            continue;
        }
        let h = unpack_picture(seen);
        if !(h.w > 0.0) {
            continue;
        }
        let b = select(1.0 - t.x, t.x, o.x == 1) * select(1.0 - t.y, t.y, o.y == 1);
        colour += h.rgb * b;
        weight += h.w * b;
        total += b;
    }
    // Too little of the footprint agrees: a thin sliver, or an edge.
    if total < 0.25 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(colour / total, min(weight / total, params.max_weight));
}

@compute @workgroup_size(8, 8, 1)
fn temporal(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let p = id.xy;
    let i = p.y * params.width + p.x;
    let e = estimate(p);
    if params.restart == 1u {
        prior[i] = reprojected(p, e);
    } else if params.restart == 2u {
        prior[i] = vec4<f32>(0.0);
    }
    let r = prior[i];
    let h = r.w * clamp(1.0 - e.weight / params.fade_samples, 0.0, 1.0);
    var colour = e.colour;
    if h > 0.0 {
        colour = (e.colour * e.weight + r.rgb * h) / (e.weight + h);
    }
    let depth = select(e.depth, -1.0 - e.depth, e.mixed);
    shown[i] = vec4<u32>(
        pack_picture(colour, min(e.weight + h, params.max_weight)),
        bitcast<u32>(depth),
        e.object,
    );
}
