//! Base-colour textures on the adapter: the plugin's layer-copy kernel against a CPU resampling of
//! the same image, and the path tracer's albedo view of a textured quad (UV transform, mirrored and
//! clamped wrap, a layer other than 0) against colours worked out on the CPU from the ray, the quad's
//! UVs and the texture.

mod support;

use support::scenes::{Scene, ShadedTriangle, Trace, camera, trace, view_ray};
use support::{Gpu, Rng, linear_to_srgb, srgb_to_linear};
use treelight_bvh::Triangle;
use treelight_bvh::glam::{Affine2, Affine3A, Mat4, Vec2, Vec3};
use treelight_render::{DebugView, LayerTexture, MaterialMap, SurfaceMaterial, TextureWrap};

fn random_image(rng: &mut Rng, w: u32, h: u32) -> Vec<u8> {
    (0..w * h * 4).map(|_| rng.byte()).collect()
}

/// Linear RGBA of texel (x, y), edges clamped.
fn linear_texel(img: &[u8], w: u32, h: u32, x: i32, y: i32) -> [f32; 4] {
    let x = x.clamp(0, w as i32 - 1) as u32;
    let y = y.clamp(0, h as i32 - 1) as u32;
    let p = &img[((y * w + x) * 4) as usize..][..4];
    let c = |v: u8| srgb_to_linear(v as f32 / 255.0);
    [c(p[0]), c(p[1]), c(p[2]), p[3] as f32 / 255.0]
}

fn encode(c: [f32; 4]) -> [u8; 4] {
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    [
        q(linear_to_srgb(c[0])),
        q(linear_to_srgb(c[1])),
        q(linear_to_srgb(c[2])),
        q(c[3]),
    ]
}

fn assert_close(got: &[u8], want: &[[u8; 4]], what: &str) {
    let worst = got
        .chunks_exact(4)
        .zip(want)
        .flat_map(|(g, w)| (0..4).map(move |k| (g[k] as i32 - w[k] as i32).abs()))
        .max()
        .unwrap();
    assert!(worst <= 2, "{what}: a channel differs by {worst} levels");
}

#[test]
fn copy_kernel_resamples_images_into_layers() {
    let gpu = Gpu::new();
    let layers = gpu.layers(8, 2);
    let mut rng = Rng(7);
    // Shrinking 32 → 8: each layer texel is the mean of a 4×4 block, in linear colour.
    let big = random_image(&mut rng, 32, 32);
    gpu.copy_to_layer(&layers, 1, 32, 32, &big);
    // Growing 4 → 8: bilinear between texel centres, edges clamped.
    let small = random_image(&mut rng, 4, 4);
    gpu.copy_to_layer(&layers, 0, 4, 4, &small);

    let mut shrunk = Vec::new();
    let mut grown = Vec::new();
    for y in 0..8 {
        for x in 0..8 {
            let mut sum = [0.0f32; 4];
            for j in 0..4 {
                for i in 0..4 {
                    let t = linear_texel(&big, 32, 32, x * 4 + i, y * 4 + j);
                    (0..4).for_each(|k| sum[k] += t[k] / 16.0);
                }
            }
            shrunk.push(encode(sum));
            let p = Vec2::new((x as f32 + 0.5) / 2.0 - 0.5, (y as f32 + 0.5) / 2.0 - 0.5);
            let (i, f) = (p.floor(), p - p.floor());
            let at =
                |dx: i32, dy: i32| linear_texel(&small, 4, 4, i.x as i32 + dx, i.y as i32 + dy);
            let c = std::array::from_fn(|k| {
                let a = at(0, 0)[k] * (1.0 - f.x) + at(1, 0)[k] * f.x;
                let b = at(0, 1)[k] * (1.0 - f.x) + at(1, 1)[k] * f.x;
                a * (1.0 - f.y) + b * f.y
            });
            grown.push(encode(c));
        }
    }
    assert_close(&gpu.read_layer(&layers, 1), &shrunk, "32→8 box filter");
    assert_close(&gpu.read_layer(&layers, 0), &grown, "4→8 bilinear");
}

const SIZE: u32 = 192;
const LAYER: u32 = 8;
const BASE: [f32; 4] = [0.9, 0.8, 1.0, 1.0];

/// The quad's texture coordinates, an affine function of its plane position (v grows downwards).
fn quad_uv(p: Vec2) -> Vec2 {
    Vec2::new(p.x + 0.5, 0.5 - p.y)
}

fn world_from_clip() -> Mat4 {
    camera(Vec3::new(0.0, 0.0, 2.6), Vec3::ZERO, Vec3::Y, 50.0)
}

/// Colours of the 4×4 blocks of 2×2 texels the texture is made of.
fn block_colour(bx: u32, by: u32) -> [u8; 4] {
    [
        (bx * 60 + 20) as u8,
        (by * 60 + 30) as u8,
        ((bx + by) * 25 + 40) as u8,
        255,
    ]
}

/// The quad's second texture coordinates: another affine function of its plane position.
fn quad_uv1(p: Vec2) -> Vec2 {
    Vec2::new(0.5 + 0.35 * p.x - 0.3 * p.y, 0.45 + 0.25 * p.x + 0.4 * p.y)
}

const QUAD: [Vec2; 4] = [
    Vec2::new(-1.0, -1.0),
    Vec2::new(1.0, -1.0),
    Vec2::new(1.0, 1.0),
    Vec2::new(-1.0, 1.0),
];
const FACES: [[usize; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

/// The quad's two triangles with their first UV set, and their corners' second set.
fn quad() -> (Vec<ShadedTriangle>, Vec<[Vec2; 3]>) {
    let at = |k: usize| QUAD[k].extend(0.0);
    let tris = FACES
        .iter()
        .map(|f| {
            let t = Triangle::new(at(f[0]), at(f[1]), at(f[2]));
            (t, None, f.map(|c| quad_uv(QUAD[c])))
        })
        .collect();
    let uvs1 = FACES.iter().map(|f| f.map(|c| quad_uv1(QUAD[c]))).collect();
    (tris, uvs1)
}

/// The blocks texture in layer 1 (8×8, copied 1:1); layer 0 holds something else.
fn block_layers(gpu: &Gpu) -> support::Layers {
    let layers = gpu.layers(LAYER, 2);
    let image: Vec<u8> = (0..LAYER * LAYER)
        .flat_map(|i| block_colour((i % LAYER) / 2, (i / LAYER) / 2))
        .collect();
    gpu.copy_to_layer(&layers, 1, LAYER, LAYER, &image);
    gpu.copy_to_layer(&layers, 0, 1, 1, &[200, 0, 0, 255]);
    layers
}

fn albedo_view() -> Trace {
    Trace {
        size: SIZE,
        samples: 8,
        bounces: 1,
        sky: Vec3::ZERO,
        mode: DebugView::Albedo.shader_index(),
        world_from_clip: world_from_clip(),
        lights: Vec::new(),
    }
}

/// What the albedo view's pixels are checked against.
struct Checked {
    pixels: u32,
    mirrored: u32,
    clamped: u32,
    worst: f32,
}

impl Checked {
    /// Asserts that over 4,000 pixels were checked, over 500 of them mirrored and 500 clamped, and
    /// that `what` (the traced colour) is within 0.01 of the texture everywhere.
    fn assert_wrapped_and_close(&self, what: &str) {
        eprintln!(
            "{what}: {} pixels checked ({} mirrored, {} clamped), worst {}",
            self.pixels, self.mirrored, self.clamped, self.worst
        );
        assert!(
            self.pixels > 4000,
            "only {} pixels could be checked",
            self.pixels
        );
        assert!(
            self.mirrored > 500 && self.clamped > 500,
            "{} mirrored, {} clamped",
            self.mirrored,
            self.clamped
        );
        assert!(self.worst < 0.01, "{what} differs by {}", self.worst);
    }
}

/// Compares the albedo view of the quad with the blocks texture read at `texture_uv` of each
/// pixel's hit (its position on the quad) through the `wrap` modes, where a pixel's jittered
/// samples all fall inside one block's flat middle (bilinear taps there see only that block's
/// colour).
fn check_albedo(
    image: &[Vec3],
    wrap: [TextureWrap; 2],
    texture_uv: impl Fn(Vec2) -> Vec2,
) -> Checked {
    let wfc = world_from_clip();
    let mut out = Checked {
        pixels: 0,
        mirrored: 0,
        clamped: 0,
        worst: 0.0,
    };
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (o, d) = view_ray(wfc, SIZE, Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let hit = o + d * (-o.z / d.z);
            if hit.x.abs() > 0.95 || hit.y.abs() > 0.95 {
                continue;
            }
            let t = texture_uv(hit.truncate());
            let st = Vec2::new(wrap[0].apply(t.x), wrap[1].apply(t.y));
            let p = st * LAYER as f32;
            let last = LAYER as f32 / 2.0 - 1.0;
            let block = (p / 2.0).floor().min(Vec2::splat(last));
            // A block's colour is exact between its texel centres, and (the sampler clamping to the
            // edge) all the way to the border for the first and last blocks.
            let flat = |b: f32| {
                let lo = if b == 0.0 {
                    f32::NEG_INFINITY
                } else {
                    2.0 * b + 0.5
                };
                let hi = if b == last {
                    f32::INFINITY
                } else {
                    2.0 * b + 1.5
                };
                (lo, hi)
            };
            // A pixel spans about 0.15 texels here; jitter reaches half of that either way, and the
            // UV transform's shear widens it a little.
            let margin = 0.12;
            let ok = |p: f32, b: f32| {
                let (lo, hi) = flat(b);
                p - margin >= lo && p + margin <= hi
            };
            if !ok(p.x, block.x) || !ok(p.y, block.y) {
                continue;
            }
            let c = block_colour(block.x as u32, block.y as u32);
            let px = image[(y * SIZE + x) as usize];
            for k in 0..3 {
                let want = BASE[k] * srgb_to_linear(c[k] as f32 / 255.0);
                out.worst = out.worst.max((px[k] - want).abs());
            }
            out.pixels += 1;
            out.mirrored += (t.x > 1.0 || t.x < 0.0) as u32;
            out.clamped += (t.y > 1.0 || t.y < 0.0) as u32;
        }
    }
    out
}

/// A map in `layer`, wrapped by `wrap`, reading UV set 1 or 0.
fn map(layer: u32, wrap: [TextureWrap; 2], second_uv_set: bool) -> Option<LayerTexture> {
    Some(LayerTexture {
        layer,
        wrap,
        second_uv_set,
    })
}

fn uv_transform() -> Affine2 {
    Affine2::from_mat2_translation(
        treelight_bvh::glam::Mat2::from_cols(Vec2::new(1.5, 0.0), Vec2::new(0.2, 1.25)),
        Vec2::new(-0.3, 0.1),
    )
}

#[test]
fn albedo_view_reads_the_material_texture_with_its_wrap_modes() {
    let gpu = Gpu::new();
    let layers = block_layers(&gpu);
    let (tris, _) = quad();
    let wrap = [TextureWrap::Mirror, TextureWrap::Clamp];
    let material = SurfaceMaterial {
        base_color: BASE,
        base_color_texture: map(1, wrap, false),
        uv_transform: uv_transform(),
        ..Default::default()
    };
    let mut scene = Scene::new();
    scene.add(&tris, Affine3A::IDENTITY, false, &material);
    let (image, _) = trace(&gpu, &scene, &layers, &albedo_view());
    let c = check_albedo(&image, wrap, |p| {
        uv_transform().transform_point2(quad_uv(p))
    });
    c.assert_wrapped_and_close("albedo");
}

/// A material whose maps read both UV sets: each map reads its own, from a shading record holding
/// both (the first set's corners as half-float offsets there), whichever set the base colour reads.
#[test]
fn each_map_reads_its_own_uv_set() {
    let gpu = Gpu::new();
    let layers = block_layers(&gpu);
    let (tris, uvs1) = quad();
    let wrap = [TextureWrap::Mirror, TextureWrap::Clamp];
    for base_on_second in [true, false] {
        // The occlusion map reads the other set: the record holds both either way.
        let material = SurfaceMaterial {
            base_color: BASE,
            base_color_texture: map(1, wrap, base_on_second),
            occlusion_texture: map(0, wrap, !base_on_second),
            uv_transform: uv_transform(),
            ..Default::default()
        };
        let mut scene = Scene::new();
        scene.add_with_second_uvs(&tris, &uvs1, Affine3A::IDENTITY, false, &material);
        let (image, _) = trace(&gpu, &scene, &layers, &albedo_view());
        let set = if base_on_second { quad_uv1 } else { quad_uv };
        let c = check_albedo(&image, wrap, |p| uv_transform().transform_point2(set(p)));
        eprintln!(
            "base colour on set {}: {} pixels checked, worst {}",
            base_on_second as u32, c.pixels, c.worst
        );
        assert!(c.pixels > 3000, "only {} pixels could be checked", c.pixels);
        assert!(c.worst < 0.01, "albedo differs by {}", c.worst);
    }
}

/// A material whose maps have their own UV transforms (glTF's `KHR_texture_transform` per texture):
/// the emission map, not the material's first map, is read through its own. The quad's base colour
/// is black and nothing lights it, so each pixel is its emission.
#[test]
fn each_map_reads_through_its_own_uv_transform() {
    let gpu = Gpu::new();
    let layers = block_layers(&gpu);
    let (tris, _) = quad();
    let wrap = [TextureWrap::Mirror, TextureWrap::Clamp];
    let base_transform =
        Affine2::from_scale_angle_translation(Vec2::new(0.3, 0.7), 0.4, Vec2::new(0.2, -0.1));
    let mut each = [Affine2::IDENTITY; 5];
    each[MaterialMap::BaseColor as usize] = base_transform;
    each[MaterialMap::Emissive as usize] = uv_transform();
    let material = SurfaceMaterial {
        base_color: [0.0, 0.0, 0.0, 1.0],
        base_color_texture: map(0, wrap, false),
        emissive: [BASE[0], BASE[1], BASE[2]],
        emissive_texture: map(1, wrap, false),
        map_uv_transforms: Some(each),
        ..Default::default()
    };
    let mut scene = Scene::new();
    scene.add(&tris, Affine3A::IDENTITY, false, &material);
    assert_eq!(scene.map_transforms.len(), 1);
    let view = Trace {
        mode: DebugView::PathTraced.shader_index(),
        ..albedo_view()
    };
    let (image, _) = trace(&gpu, &scene, &layers, &view);
    let c = check_albedo(&image, wrap, |p| {
        uv_transform().transform_point2(quad_uv(p))
    });
    c.assert_wrapped_and_close("emission through its own transform");
}

/// A pixel's samples cover it evenly: along a slanted edge between a white triangle and the black
/// background, the albedo view's 16 samples a pixel give each edge pixel its covered share (worked
/// out on the CPU from 256 rays a pixel) far closer than 16 random positions would.
#[test]
fn a_pixel_s_samples_cover_it_evenly() {
    let gpu = Gpu::new();
    let layers = block_layers(&gpu);
    let corners = [
        Vec2::new(-3.0, -2.7),
        Vec2::new(3.0, -0.4),
        Vec2::new(-3.0, 3.0),
    ];
    let tri = Triangle::new(
        corners[0].extend(0.0),
        corners[1].extend(0.0),
        corners[2].extend(0.0),
    );
    let material = SurfaceMaterial {
        base_color: [1.0; 4],
        ..Default::default()
    };
    let mut scene = Scene::new();
    scene.add(
        &[(tri, None, [Vec2::ZERO; 3])],
        Affine3A::IDENTITY,
        false,
        &material,
    );
    let view = Trace {
        samples: 16,
        ..albedo_view()
    };
    let (image, _) = trace(&gpu, &scene, &layers, &view);
    let inside = |p: Vec2| {
        let side = |a: Vec2, b: Vec2| (b - a).perp_dot(p - a);
        let s = [
            side(corners[0], corners[1]),
            side(corners[1], corners[2]),
            side(corners[2], corners[0]),
        ];
        s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0)
    };
    let wfc = world_from_clip();
    // And what 16 independent uniform positions would give: a binomial share's variance.
    let (mut edge, mut squares, mut binomial) = (0u32, 0.0f64, 0.0f64);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let mut covered = 0;
            for sy in 0..16 {
                for sx in 0..16 {
                    let at = Vec2::new(x as f32, y as f32)
                        + Vec2::new(sx as f32 + 0.5, sy as f32 + 0.5) / 16.0;
                    let (o, d) = view_ray(wfc, SIZE, at);
                    covered += inside((o + d * (-o.z / d.z)).truncate()) as u32;
                }
            }
            let share = covered as f32 / 256.0;
            if !(0.05..=0.95).contains(&share) {
                continue;
            }
            let got = image[(y * SIZE + x) as usize].x;
            squares += f64::from(got - share).powi(2);
            binomial += f64::from(share * (1.0 - share)) / 16.0;
            edge += 1;
        }
    }
    let rms = (squares / f64::from(edge)).sqrt();
    let random = (binomial / f64::from(edge)).sqrt();
    eprintln!(
        "{edge} edge pixels, coverage off by {rms:.4} (root mean square); random positions: {random:.4}"
    );
    assert!(edge > 100, "only {edge} edge pixels");
    assert!(
        rms < 0.7 * random,
        "coverage off by {rms} (root mean square), random positions {random}"
    );
}
