// Draws the accumulated samples into the camera's view target (HDR, before Bevy's tonemapping).

struct Resolve {
    // The camera viewport's origin and size in target pixels.
    origin: vec2<f32>,
    viewport: vec2<f32>,
    // The accumulation buffer's size (smaller than the viewport with a resolution scale).
    size: vec2<u32>,
    samples: u32,
    pad: u32,
}

@group(0) @binding(0) var<storage, read> accum: array<vec4<f32>>;
@group(0) @binding(1) var<uniform> resolve: Resolve;

@vertex
fn vertex(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fragment(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let rel = clamp((position.xy - resolve.origin) / resolve.viewport, vec2<f32>(0.0), vec2<f32>(1.0));
    let p = min(vec2<u32>(rel * vec2<f32>(resolve.size)), resolve.size - vec2<u32>(1u));
    let sum = accum[p.y * resolve.size.x + p.x].rgb;
    return vec4<f32>(sum / f32(max(resolve.samples, 1u)), 1.0);
}
