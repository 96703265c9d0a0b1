// Draws the accumulated samples into the camera's view target (HDR, before Bevy's tonemapping), and
// the depth of their primary hits into its depth buffer, so what is drawn after (gizmos, overlays)
// is hidden behind traced surfaces. A pixel with no sample yet shows the preview, upscaled (or, with
// temporal reuse, what the temporal pass made of the samples, the preview and the last frame). Objects
// marked for an outline get one around their visible silhouette, from the object slots of the
// primary hits: complete in every frame, whatever the samples have converged to. Where the view
// is denoised, a pixel with samples shows the denoiser's lighting times its albedo.

struct Resolve {
    // The camera viewport's origin and size in target pixels.
    origin: vec2<f32>,
    viewport: vec2<f32>,
    // The accumulation buffer's size (smaller than the viewport with a resolution scale).
    size: vec2<u32>,
    // Pixels per preview block; 0 when there is no preview to show.
    preview_scale: u32,
    // Object slots the outline buffer covers; 0 when nothing is outlined.
    outline_slots: u32,
    // The outline's colours (HDR, like the image): outline value 1, then 2.
    outline_colours: array<vec4<f32>, 2>,
    // The outline's width in target pixels.
    outline_width: f32,
    // 1: show the denoiser's result where a pixel has samples.
    denoised: u32,
    // The target rectangle the outlined objects' projected bounds cover, widened by the line:
    // fragments outside it skip the search.
    outline_min: vec2<f32>,
    outline_max: vec2<f32>,
    // 1: show the temporal pass's picture (temporal.wgsl) in place of the samples and preview.
    temporal: u32,
    pad2: u32,
}

const NONE: u32 = 0xffffffffu;

// Per pixel the sum of its samples and their count; `aux` as the trace kernel writes it (see
// pathtrace.wgsl); per object slot two bits of outline (0 none), sixteen slots a word.
@group(0) @binding(0) var<storage, read> accum: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> aux: array<u32>;
// Storage, not uniform: lavapipe recompiles a shader whose branches test uniforms at every
// bind (see `view_buffers` in prepare.rs).
@group(0) @binding(2) var<storage, read> resolve: Resolve;
@group(0) @binding(3) var<storage, read> outlines: array<u32>;
// The denoiser's last pass (denoise.wgsl): per pixel its lighting, to be multiplied by the albedo.
@group(0) @binding(4) var<storage, read> denoised: array<vec4<f32>>;
// The trace kernel's guides (guide_layout.wgsl): the albedo and the emitted light summed over a
// pixel's samples.
@group(0) @binding(5) var<storage, read> guides: array<u32>;
// The temporal pass's picture: per traced pixel rgb and weight in half floats, depth, object slot
// (temporal.wgsl).
@group(0) @binding(6) var<storage, read> shown: array<vec4<u32>>;

@vertex
fn vertex(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

fn aux_f32(i: u32) -> f32 {
    return bitcast<f32>(aux[i]);
}

fn blocks(k: u32) -> vec2<i32> {
    return vec2<i32>((resolve.size + vec2<u32>(k - 1u)) / k);
}

fn preview_at(q: vec2<i32>, n: vec2<i32>) -> vec4<f32> {
    let c = clamp(q, vec2<i32>(0), n - vec2<i32>(1));
    let at = 2u * resolve.size.x * resolve.size.y + 4u * (u32(c.y) * u32(n.x) + u32(c.x));
    return vec4<f32>(aux_f32(at), aux_f32(at + 1u), aux_f32(at + 2u), aux_f32(at + 3u));
}

// The traced pixel under a target position.
fn pixel_under(position: vec2<f32>) -> vec2<u32> {
    let rel = clamp((position - resolve.origin) / resolve.viewport, vec2<f32>(0.0), vec2<f32>(1.0));
    return min(vec2<u32>(rel * vec2<f32>(resolve.size)), resolve.size - vec2<u32>(1u));
}

// Colour (rgb) and depth (w) of the traced pixel under a fragment.
fn traced(position: vec2<f32>) -> vec4<f32> {
    let p = pixel_under(position);
    let i = p.y * resolve.size.x + p.x;
    let a = accum[i];
    if resolve.temporal == 1u {
        // Its depth: the pixel's own first sample's, else its preview block's.
        var depth = 0.0;
        let k = resolve.preview_scale;
        if a.w > 0.0 {
            depth = aux_f32(i);
        } else if k > 0u {
            depth = preview_at(vec2<i32>(p / k), blocks(k)).w;
        }
        let w = shown[i];
        return vec4<f32>(unpack2x16float(w.x), unpack2x16float(w.y).x, depth);
    }
    if a.w > 0.0 {
        if resolve.denoised == 1u {
            return vec4<f32>(remodulated(i, a.w), aux_f32(i));
        }
        return vec4<f32>(a.rgb / a.w, aux_f32(i));
    }
    let k = resolve.preview_scale;
    if k == 0u {
        return vec4<f32>(0.0);
    }
    // Bilinear between block centres for the colour; the nearest block's depth.
    let n = blocks(k);
    let rel = clamp((position - resolve.origin) / resolve.viewport, vec2<f32>(0.0), vec2<f32>(1.0));
    let f = rel * vec2<f32>(resolve.size) / f32(k) - vec2<f32>(0.5);
    let q = vec2<i32>(floor(f));
    let t = f - floor(f);
    let top = mix(preview_at(q, n).rgb, preview_at(q + vec2<i32>(1, 0), n).rgb, t.x);
    let bottom = mix(preview_at(q + vec2<i32>(0, 1), n).rgb, preview_at(q + vec2<i32>(1, 1), n).rgb, t.x);
    let nearest = preview_at(vec2<i32>(p / k), n);
    return vec4<f32>(mix(top, bottom, t.y), nearest.w);
}

// The object slot of the primary hit at a traced pixel: its own first sample's, else its preview
// block's, else NONE.
fn object_at(p: vec2<u32>) -> u32 {
    let pixels = resolve.size.x * resolve.size.y;
    let i = p.y * resolve.size.x + p.x;
    if accum[i].w > 0.0 {
        return aux[pixels + i];
    }
    let k = resolve.preview_scale;
    if k == 0u {
        return NONE;
    }
    let n = blocks(k);
    let b = (p.y / k) * u32(n.x) + p.x / k;
    return aux[block_objects_start(resolve.size.x, resolve.size.y) + b];
}

fn outline_of(slot: u32) -> u32 {
    if slot >= resolve.outline_slots {
        return 0u;
    }
    return (outlines[slot / 16u] >> ((slot % 16u) * 2u)) & 3u;
}

// The outline value drawn at a fragment: the strongest of the outlined objects within the outline's
// width of it, where the fragment itself shows no outlined object (so the line lies outside the
// silhouette and never covers the object).
fn outline_at(position: vec2<f32>) -> u32 {
    if resolve.outline_slots == 0u || any(position < resolve.outline_min)
        || any(position > resolve.outline_max)
        || outline_of(object_at(pixel_under(position))) != 0u {
        return 0u;
    }
    let w = resolve.outline_width;
    let r = i32(ceil(w));
    var best = 0u;
    for (var y = -r; y <= r; y += 1) {
        for (var x = -r; x <= r; x += 1) {
            let o = vec2<f32>(f32(x), f32(y));
            if dot(o, o) > w * w + 0.25 {
                continue;
            }
            let at = position + o;
            if any(at < resolve.origin) || any(at >= resolve.origin + resolve.viewport) {
                continue;
            }
            best = max(best, outline_of(object_at(pixel_under(at))));
        }
    }
    return best;
}

fn shade(position: vec2<f32>, colour: vec3<f32>) -> vec4<f32> {
    let o = outline_at(position);
    if o == 0u {
        return vec4<f32>(colour, 1.0);
    }
    return vec4<f32>(resolve.outline_colours[o - 1u].rgb, 1.0);
}

@fragment
fn fragment(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return shade(position.xy, traced(position.xy).rgb);
}

struct WithDepth {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fragment_depth(@builtin(position) position: vec4<f32>) -> WithDepth {
    let t = traced(position.xy);
    return WithDepth(shade(position.xy, t.rgb), t.w);
}
