//! Normal maps on the adapter: the path tracer's normals view of three normal-mapped quads against
//! normals worked out on the CPU. One has no tangents of its own (the kernel makes them from its
//! UVs); two carry corner tangents that turn across the quad, one baked to world space and one kept
//! as an instance, both under a turn that the tangents must follow.

mod support;

use support::scenes::{Scene, ShadedTriangle, Trace, camera, trace, view_ray};
use support::{Gpu, srgb_to_linear};
use treelight_bvh::Triangle;
use treelight_bvh::glam::{Affine3A, Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use treelight_render::{DebugView, LayerTexture, SurfaceMaterial, TextureWrap};

const SIZE: u32 = 192;
const SAMPLES: u32 = 4;
/// The normal map's one texel (sRGB bytes, as the test's layer copy reads them).
const TEXEL: [u8; 4] = [230, 150, 235, 255];
/// The quad in object space: corners, and the two triangles.
const HALF: Vec2 = Vec2::new(0.2, 0.6);
const FACES: [[usize; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

fn corners() -> [Vec2; 4] {
    [
        Vec2::new(-HALF.x, -HALF.y),
        Vec2::new(HALF.x, -HALF.y),
        Vec2::new(HALF.x, HALF.y),
        Vec2::new(-HALF.x, HALF.y),
    ]
}

/// Texture coordinates: u along +x, v down (so the UVs' own frame is +x, −y).
fn quad_uv(p: Vec2) -> Vec2 {
    Vec2::new(p.x + 0.5, 0.5 - p.y)
}

/// The corner tangents of the quads that have them: turning from 70° off +x at one corner to 10°
/// at the opposite one, all with a bitangent sign of −1.
fn corner_tangents() -> [Vec4; 4] {
    [70.0f32, 40.0, 10.0, 50.0].map(|a| {
        let a = a.to_radians();
        Vec4::new(a.cos(), a.sin(), 0.0, -1.0)
    })
}

fn world_from_clip() -> Mat4 {
    camera(Vec3::new(0.0, 0.0, 2.6), Vec3::ZERO, Vec3::Y, 50.0)
}

/// Barycentric weights of `p` in the triangle `a b c` (2D).
fn barycentric(p: Vec2, [a, b, c]: [Vec2; 3]) -> Vec3 {
    let (e1, e2, d) = (b - a, c - a, p - a);
    let det = e1.perp_dot(e2);
    let u = d.perp_dot(e2) / det;
    let v = e1.perp_dot(d) / det;
    Vec3::new(1.0 - u - v, u, v)
}

struct Quad {
    transform: Affine3A,
    file_tangents: bool,
    keep_whole: bool,
}

impl Quad {
    /// The normal at object-space point `local` of the quad, as the map bends it, and the same with
    /// the tangents the UVs give.
    fn expected(&self, local: Vec2, m: Vec3) -> (Vec3, Vec3) {
        let n = Vec3::Z;
        let bend = |t: Vec3, sign: f32| {
            let b = n.cross(t) * sign;
            (t * m.x + b * m.y + n * m.z).normalize()
        };
        let r = Mat3::from(self.transform.matrix3);
        // The UVs' frame: dP/du = +x, dP/dv = −y, so the bitangent is −y.
        let from_uvs = bend((r * Vec3::X).normalize(), -1.0);
        if !self.file_tangents {
            return (from_uvs, from_uvs);
        }
        let c = corners();
        let t = corner_tangents();
        for f in FACES {
            let w = barycentric(local, f.map(|k| c[k]));
            if w.min_element() >= -1e-4 {
                let tangent =
                    t[f[0]].truncate() * w.x + t[f[1]].truncate() * w.y + t[f[2]].truncate() * w.z;
                return (bend((r * tangent).normalize(), t[f[0]].w), from_uvs);
            }
        }
        unreachable!("inside the quad")
    }
}

#[test]
fn the_normals_view_bends_normals_along_the_mesh_s_tangents_or_its_uvs() {
    let gpu = Gpu::new();
    let layers = gpu.layers(8, 2);
    gpu.copy_to_layer(&layers, 1, 1, 1, &TEXEL);
    let m =
        Vec3::from_array([0, 1, 2].map(|k| srgb_to_linear(TEXEL[k] as f32 / 255.0) * 2.0 - 1.0));

    // Side by side in one plane, apart.
    let turn = |x: f32, degrees: f32| {
        Affine3A::from_rotation_translation(
            Quat::from_rotation_z(degrees.to_radians()),
            Vec3::new(x, 0.0, 0.0),
        )
    };
    let quads = [
        Quad {
            transform: turn(-0.85, 0.0),
            file_tangents: false,
            keep_whole: false,
        },
        Quad {
            transform: turn(-0.15, 20.0),
            file_tangents: true,
            keep_whole: false,
        },
        Quad {
            transform: turn(0.7, -25.0),
            file_tangents: true,
            keep_whole: true,
        },
    ];
    // The quad's two triangles with their UVs, flat (no normals), and the corner tangents.
    let c = corners();
    let tris: Vec<ShadedTriangle> = FACES
        .iter()
        .map(|f| {
            let [a, b, d] = f.map(|k| c[k].extend(0.0));
            (Triangle::new(a, b, d), None, f.map(|k| quad_uv(c[k])))
        })
        .collect();
    let tangents = FACES.map(|f| f.map(|k| corner_tangents()[k]));
    let material = SurfaceMaterial {
        base_color: [0.8, 0.8, 0.8, 1.0],
        normal_texture: Some(LayerTexture {
            layer: 1,
            wrap: [TextureWrap::Clamp; 2],
            second_uv_set: false,
        }),
        ..Default::default()
    };
    let mut scene = Scene::new();
    for q in &quads {
        let tangents = q.file_tangents.then_some(&tangents[..]);
        scene.add_with_tangents(&tris, tangents, q.transform, q.keep_whole, &material);
    }
    let view = Trace {
        size: SIZE,
        samples: SAMPLES,
        bounces: 1,
        sky: Vec3::ZERO,
        mode: DebugView::Normals.shader_index(),
        world_from_clip: world_from_clip(),
        lights: Vec::new(),
    };
    let (image, _) = trace(&gpu, &scene, &layers, &view);

    let wfc = world_from_clip();
    let mut checked = [0u32; 3];
    // Beyond what the pixel's spread allows.
    let mut worst = [0.0f32; 3];
    // How far the mesh's tangents take the normal from where the UVs' tangents would.
    let mut apart = [0.0f32; 3];
    // Where the ray through a point of the view (pixels, y down) meets the quads' plane.
    let plane_hit = |px: Vec2| {
        let (o, d) = view_ray(wfc, SIZE, px);
        o + d * (-o.z / d.z)
    };
    for y in 0..SIZE {
        for x in 0..SIZE {
            let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            for (i, q) in quads.iter().enumerate() {
                let to_local = q.transform.inverse();
                let local = |px: Vec2| to_local.transform_point3(plane_hit(px)).truncate();
                let at = local(centre);
                // Away from the edges, where a pixel's samples might fall off the quad.
                if at.x.abs() > HALF.x - 0.03 || at.y.abs() > HALF.y - 0.03 {
                    continue;
                }
                let (want, from_uvs) = q.expected(at, m);
                // The samples spread over the pixel, so their mean may stray from the centre's
                // normal by as much as the normal changes across it (where that is little).
                let spread = [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)]
                    .map(|(dx, dy)| q.expected(local(centre + Vec2::new(dx, dy)), m).0)
                    .iter()
                    .map(|n| (*n - want).abs().max_element())
                    .fold(0.0f32, f32::max);
                if spread > 0.02 {
                    continue;
                }
                let got = image[(y * SIZE + x) as usize] * 2.0 - Vec3::ONE;
                worst[i] = worst[i].max((got - want).abs().max_element() - spread);
                apart[i] = apart[i].max((from_uvs - want).abs().max_element());
                checked[i] += 1;
            }
        }
    }
    eprintln!("checked {checked:?}, worst {worst:?}, tangents' effect {apart:?}");
    assert!(checked.iter().all(|&c| c > 1000), "{checked:?}");
    assert!(worst.iter().all(|&w| w < 0.005), "{worst:?}");
    // The mesh's tangents make a difference the test can see.
    assert!(apart[1] > 0.3 && apart[2] > 0.3, "{apart:?}");
}
