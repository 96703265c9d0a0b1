// Copies one image into a layer of the path tracer's base-colour texture array, resampled to the
// layer's size: each output texel averages a grid of bilinear taps over its footprint in the source
// (enough taps to see every source texel when shrinking), in linear colour, then stores it
// sRGB-encoded because storage textures cannot be sRGB.

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var layer: texture_storage_2d<rgba8unorm, write>;

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    return select(1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - vec3<f32>(0.055), x * 12.92, x <= vec3<f32>(0.0031308));
}

fn texel(p: vec2<i32>, size: vec2<i32>) -> vec4<f32> {
    return textureLoad(source, clamp(p, vec2<i32>(0), size - vec2<i32>(1)), 0);
}

// Bilinear filtering by hand: the source may be a format without filtering support.
fn bilinear(uv: vec2<f32>, size: vec2<i32>) -> vec4<f32> {
    let p = uv * vec2<f32>(size) - vec2<f32>(0.5);
    let i = vec2<i32>(floor(p));
    let f = p - floor(p);
    let a = mix(texel(i, size), texel(i + vec2<i32>(1, 0), size), f.x);
    let b = mix(texel(i + vec2<i32>(0, 1), size), texel(i + vec2<i32>(1, 1), size), f.x);
    return mix(a, b, f.y);
}

@compute @workgroup_size(8, 8, 1)
fn copy_to_layer(@builtin(global_invocation_id) id: vec3<u32>) {
    let out = textureDimensions(layer);
    if id.x >= out.x || id.y >= out.y {
        return;
    }
    let size = vec2<i32>(textureDimensions(source, 0));
    let taps = clamp(vec2<u32>(ceil(vec2<f32>(size) / vec2<f32>(out))), vec2<u32>(1u), vec2<u32>(8u));
    var sum = vec4<f32>(0.0);
    for (var j = 0u; j < taps.y; j++) {
        for (var i = 0u; i < taps.x; i++) {
            let at = vec2<f32>(id.xy) + (vec2<f32>(f32(i), f32(j)) + vec2<f32>(0.5)) / vec2<f32>(taps);
            sum += bilinear(at / vec2<f32>(out), size);
        }
    }
    let c = sum / f32(taps.x * taps.y);
    textureStore(layer, vec2<i32>(id.xy), vec4<f32>(linear_to_srgb(c.rgb), clamp(c.a, 0.0, 1.0)));
}
