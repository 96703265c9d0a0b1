// Draws the accumulated samples into the camera's view target (HDR, before Bevy's tonemapping), and
// the depth of their primary hits into its depth buffer, so what is drawn after (gizmos, overlays)
// is hidden behind traced surfaces. A pixel with no sample yet shows the preview, upscaled.

struct Resolve {
    // The camera viewport's origin and size in target pixels.
    origin: vec2<f32>,
    viewport: vec2<f32>,
    // The accumulation buffer's size (smaller than the viewport with a resolution scale).
    size: vec2<u32>,
    // Pixels per preview block; 0 when there is no preview to show.
    preview_scale: u32,
    pad: u32,
}

// Per pixel the sum of its samples and their count; then, as the trace kernel writes it, per pixel
// its depth and per preview block its sample and depth.
@group(0) @binding(0) var<storage, read> accum: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> aux: array<f32>;
@group(0) @binding(2) var<uniform> resolve: Resolve;

@vertex
fn vertex(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

fn preview_at(q: vec2<i32>, n: vec2<i32>) -> vec4<f32> {
    let c = clamp(q, vec2<i32>(0), n - vec2<i32>(1));
    let at = resolve.size.x * resolve.size.y + 4u * (u32(c.y) * u32(n.x) + u32(c.x));
    return vec4<f32>(aux[at], aux[at + 1u], aux[at + 2u], aux[at + 3u]);
}

// Colour (rgb) and depth (w) of the traced pixel under a fragment.
fn traced(position: vec2<f32>) -> vec4<f32> {
    let rel = clamp((position - resolve.origin) / resolve.viewport, vec2<f32>(0.0), vec2<f32>(1.0));
    let p = min(vec2<u32>(rel * vec2<f32>(resolve.size)), resolve.size - vec2<u32>(1u));
    let i = p.y * resolve.size.x + p.x;
    let a = accum[i];
    if a.w > 0.0 {
        return vec4<f32>(a.rgb / a.w, aux[i]);
    }
    let k = resolve.preview_scale;
    if k == 0u {
        return vec4<f32>(0.0);
    }
    // Bilinear between block centres for the colour; the nearest block's depth.
    let n = vec2<i32>((resolve.size + vec2<u32>(k - 1u)) / k);
    let f = rel * vec2<f32>(resolve.size) / f32(k) - vec2<f32>(0.5);
    let q = vec2<i32>(floor(f));
    let t = f - floor(f);
    let top = mix(preview_at(q, n).rgb, preview_at(q + vec2<i32>(1, 0), n).rgb, t.x);
    let bottom = mix(preview_at(q + vec2<i32>(0, 1), n).rgb, preview_at(q + vec2<i32>(1, 1), n).rgb, t.x);
    let nearest = preview_at(vec2<i32>(p / k), n);
    return vec4<f32>(mix(top, bottom, t.y), nearest.w);
}

@fragment
fn fragment(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(traced(position.xy).rgb, 1.0);
}

struct WithDepth {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fragment_depth(@builtin(position) position: vec4<f32>) -> WithDepth {
    let t = traced(position.xy);
    return WithDepth(vec4<f32>(t.rgb, 1.0), t.w);
}
