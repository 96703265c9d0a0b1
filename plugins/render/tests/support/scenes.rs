//! Small scenes for the kernels' tests: meshes with their shading records and materials, traced
//! as the plugin traces a view.

use super::{Gpu, Layers, floats, put_record};
use std::f32::consts::PI;
use treelight_bvh::glam::{Affine3A, Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use treelight_bvh::{Bvh, GroupId, Triangle};
use treelight_render::{
    CornerShading, DebugView, EmitterList, MapTransformTable, OBJECT_BYTES, PATHTRACE_WGSL,
    SceneLight, ShadingBuffers, SurfaceMaterial, TraceWork, ViewParams, attribute_record,
    light_bytes, object_bytes,
};

/// A triangle with its corners' normals (when it has them) and UVs.
pub type ShadedTriangle = (Triangle, Option<[Vec3; 3]>, [Vec2; 3]);

/// A scene as the kernel reads it: the tree, each group's material and corners' shading.
pub struct Scene {
    pub bvh: Bvh,
    pub shading: ShadingBuffers,
    pub objects: Vec<u8>,
    /// The sets of per-map UV transforms the object records name.
    pub map_transforms: MapTransformTable,
    /// Each group's emission (linear, nits), for the emitters' list.
    pub emission: Vec<(GroupId, Vec3)>,
}

impl Scene {
    pub fn new() -> Self {
        Self {
            bvh: Bvh::default(),
            shading: ShadingBuffers::default(),
            objects: Vec::new(),
            map_transforms: MapTransformTable::default(),
            emission: Vec::new(),
        }
    }

    /// The list of emissive triangles the plugin would upload after the lights: its records (the
    /// groups' table, then their triangles) and (groups in the table, total weight).
    pub fn emitters(&self) -> (Vec<u8>, (u32, f32)) {
        let list = EmitterList::of_groups(&self.bvh, self.emission.iter().copied());
        (list.bytes(), (list.group_count(), list.total()))
    }

    /// Adds a mesh: triangles with per-corner normals and UVs (object space), placed by
    /// `transform` (kept whole: traced as an instance).
    pub fn add(
        &mut self,
        tris: &[ShadedTriangle],
        transform: Affine3A,
        keep_whole: bool,
        material: &SurfaceMaterial,
    ) -> GroupId {
        self.add_with_tangents(tris, None, transform, keep_whole, material)
    }

    /// [`Scene::add`], with each triangle's corners' second UV set in its shading record.
    pub fn add_with_second_uvs(
        &mut self,
        tris: &[ShadedTriangle],
        uvs1: &[[Vec2; 3]],
        transform: Affine3A,
        keep_whole: bool,
        material: &SurfaceMaterial,
    ) -> GroupId {
        self.add_records(tris, transform, keep_whole, material, |k, r| {
            r.with_second_uv_set(uvs1[k])
        })
    }

    /// [`Scene::add`], with each triangle's corner tangents (xyz and the bitangent's sign) when
    /// `tangents` gives them.
    pub fn add_with_tangents(
        &mut self,
        tris: &[ShadedTriangle],
        tangents: Option<&[[Vec4; 3]]>,
        transform: Affine3A,
        keep_whole: bool,
        material: &SurfaceMaterial,
    ) -> GroupId {
        self.add_records(tris, transform, keep_whole, material, |k, r| {
            r.with_tangents(tangents.map(|t| t[k]))
        })
    }

    /// Adds a mesh whose k-th shading record `finish(k, record)` completes.
    fn add_records(
        &mut self,
        tris: &[ShadedTriangle],
        transform: Affine3A,
        keep_whole: bool,
        material: &SurfaceMaterial,
        finish: impl Fn(usize, CornerShading) -> CornerShading,
    ) -> GroupId {
        let t: Vec<Triangle> = tris.iter().map(|x| x.0).collect();
        let g = self.bvh.insert_group(&t, transform, keep_whole).unwrap();
        self.emission.push((g, Vec3::from(material.emissive)));
        self.shading.reserve_triangles(self.bvh.triangle_capacity());
        for (k, id) in self.bvh.group_triangles(g).unwrap().iter().enumerate() {
            let (_, n, uv) = tris[k];
            let record = finish(k, attribute_record(n, Some(uv)));
            self.shading.put(id, &record);
        }
        let need = self.bvh.group_slots() as usize * OBJECT_BYTES as usize;
        self.objects.resize(need.max(self.objects.len()), 0);
        put_record(
            &mut self.objects,
            g.index(),
            &object_bytes(
                Mat3::from(transform.matrix3),
                material,
                &mut self.map_transforms,
            ),
        );
        g
    }
}

/// A unit sphere of `rings` × `2 rings` quads with smooth normals.
pub fn sphere(rings: u32) -> Vec<ShadedTriangle> {
    let segments = rings * 2;
    let p = |i: u32, j: u32| {
        let theta = PI * i as f32 / rings as f32;
        let phi = 2.0 * PI * j as f32 / segments as f32;
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        )
    };
    let uv = |i: u32, j: u32| Vec2::new(j as f32 / segments as f32, i as f32 / rings as f32);
    let mut out = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let c = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            for f in [[0, 1, 2], [0, 2, 3]] {
                let [a, b, d] = f.map(|k| c[k]);
                let (pa, pb, pd) = (p(a.0, a.1), p(b.0, b.1), p(d.0, d.1));
                if (pb - pa).cross(pd - pa).length_squared() < 1e-12 {
                    continue;
                }
                out.push((
                    Triangle::new(pa, pb, pd),
                    Some([pa, pb, pd]),
                    [uv(a.0, a.1), uv(b.0, b.1), uv(d.0, d.1)],
                ));
            }
        }
    }
    out
}

/// Two triangles over the square `half` from the origin in the z = 0 plane, facing +z; UVs 0..1
/// across it, v growing downwards.
pub fn square(half: f32) -> Vec<ShadedTriangle> {
    let c = [
        Vec2::new(-half, -half),
        Vec2::new(half, -half),
        Vec2::new(half, half),
        Vec2::new(-half, half),
    ];
    let uv = |p: Vec2| Vec2::new(p.x / (2.0 * half) + 0.5, 0.5 - p.y / (2.0 * half));
    [[0, 1, 2], [0, 2, 3]]
        .iter()
        .map(|f| {
            let p = f.map(|k| c[k]);
            (
                Triangle::new(p[0].extend(0.0), p[1].extend(0.0), p[2].extend(0.0)),
                None,
                p.map(uv),
            )
        })
        .collect()
}

pub fn camera(eye: Vec3, target: Vec3, up: Vec3, fov: f32) -> Mat4 {
    let view = Mat4::look_at_rh(eye, target, up);
    let proj = Mat4::perspective_infinite_reverse_rh(fov.to_radians(), 1.0, 0.1);
    (proj * view).inverse()
}

/// The ray (origin on the near plane, direction, not unit) through point `px` of a square view of
/// `size` pixels (y down) through `world_from_clip`, as the kernel makes its camera rays.
pub fn view_ray(world_from_clip: Mat4, size: u32, px: Vec2) -> (Vec3, Vec3) {
    let ndc = Vec2::new(
        px.x / size as f32 * 2.0 - 1.0,
        1.0 - px.y / size as f32 * 2.0,
    );
    let near = world_from_clip.project_point3(ndc.extend(1.0));
    let far = world_from_clip.project_point3(ndc.extend(0.5));
    (near, far - near)
}

/// What to trace: a square image of `size` pixels, `samples` per pixel.
pub struct Trace {
    pub size: u32,
    pub samples: u32,
    pub bounces: u32,
    pub sky: Vec3,
    pub mode: u32,
    pub world_from_clip: Mat4,
    pub lights: Vec<SceneLight>,
}

/// The mean radiance per pixel and each pixel's primary object slot.
pub fn trace(gpu: &Gpu, scene: &Scene, layers: &Layers, t: &Trace) -> (Vec<Vec3>, Vec<u32>) {
    let (image, slots, _) = trace_into(gpu, scene, layers, t);
    (image, slots)
}

/// [`trace`], with the target its samples are in.
pub fn trace_into(
    gpu: &Gpu,
    scene: &Scene,
    layers: &Layers,
    t: &Trace,
) -> (Vec<Vec3>, Vec<u32>, super::TraceTarget) {
    let target = Frames::new(gpu, scene, layers, &t.lights).trace(t, TraceWork::WHOLE_IMAGE);
    let image = mean_image(gpu, &target);
    let slots = gpu.read_objects(&target);
    (image, slots, target)
}

/// Each pixel's mean sample in `target`.
pub fn mean_image(gpu: &Gpu, target: &super::TraceTarget) -> Vec<Vec3> {
    floats(&gpu.read(&target.accum))
        .chunks_exact(4)
        .map(|c| Vec3::new(c[0], c[1], c[2]) / c[3].max(1.0))
        .collect()
}

/// A scene's buffers (with its lights) and the trace kernel, made once for the frames traced of
/// it.
pub struct Frames<'a> {
    gpu: &'a Gpu,
    scene: &'a Scene,
    layers: &'a Layers,
    buffers: [wgpu::Buffer; 9],
    pipeline: wgpu::ComputePipeline,
    /// The groups in the emitters' table after the lights, and their triangles' total weight.
    emitters: (u32, f32),
}

impl<'a> Frames<'a> {
    pub fn new(gpu: &'a Gpu, scene: &'a Scene, layers: &'a Layers, lights: &[SceneLight]) -> Self {
        Self::sampling_emitters(gpu, scene, layers, lights, true)
    }

    /// [`Frames::new`]; without `emitters`, the emissive triangles are found by the BSDF's samples
    /// alone, as before the kernel sampled them.
    pub fn sampling_emitters(
        gpu: &'a Gpu,
        scene: &'a Scene,
        layers: &'a Layers,
        lights: &[SceneLight],
        emitters: bool,
    ) -> Self {
        let mut lights: Vec<u8> = lights.iter().flat_map(light_bytes).collect();
        let (records, listed) = if emitters {
            scene.emitters()
        } else {
            (Vec::new(), (0, 0.0))
        };
        lights.extend_from_slice(&records);
        Self {
            emitters: listed,
            gpu,
            scene,
            layers,
            buffers: gpu.scene_buffers(
                &scene.bvh,
                &scene.shading,
                &scene.objects,
                &lights,
                &scene.map_transforms.bytes(),
            ),
            pipeline: gpu.pipeline(PATHTRACE_WGSL, "path_trace"),
        }
    }

    /// Traces `work` of `t` into a fresh target: `t.samples` a pixel for whole-image work, in
    /// dispatches of at most 16 (`t.lights` must be the lights the frames were made with).
    pub fn trace(&self, t: &Trace, work: TraceWork) -> super::TraceTarget {
        self.trace_shot(t, work, Shot::RADIANCE)
    }

    /// [`Frames::trace`] with `shot`'s exposure, indirect cap and seed.
    pub fn trace_shot(&self, t: &Trace, work: TraceWork, shot: Shot) -> super::TraceTarget {
        self.trace_in_dispatches(t, work, shot, t.samples.clamp(1, 16))
    }

    /// [`Frames::trace_shot`] in dispatches of `per` samples a pixel: `t.samples` rounded up to
    /// a whole number of them.
    pub fn trace_in_dispatches(
        &self,
        t: &Trace,
        work: TraceWork,
        shot: Shot,
        per: u32,
    ) -> super::TraceTarget {
        let target = self.gpu.trace_target(t.size, t.size);
        for _ in 0..t.samples.div_ceil(per) {
            let params = ViewParams {
                world_from_clip: t.world_from_clip,
                origin: Vec3::ZERO,
                sky: t.sky,
                exposure: shot.exposure,
                width: t.size,
                height: t.size,
                root: super::traced_root(&self.scene.bvh),
                max_bounces: t.bounces,
                samples: per,
                mode: t.mode,
                light_count: t.lights.len() as u32,
                emitters: self.emitters,
                indirect_clamp: shot.indirect_clamp,
                work,
                part_shift: treelight_render::MAX_PART_SHIFT,
                seed: shot.seed,
                environment: self.layers.environment_word,
            };
            self.gpu
                .path_trace(&self.pipeline, &self.buffers, &params, &target, self.layers);
        }
        target
    }
}

/// What a trace runs with beside the scene: the camera's exposure multiplier, the view's indirect
/// cap (nits, 0: none) and the samples' seed.
#[derive(Clone, Copy, Debug)]
pub struct Shot {
    pub exposure: f32,
    pub indirect_clamp: f32,
    pub seed: u32,
}

impl Shot {
    /// Radiance as it is: exposure 1, no cap, seed 0.
    pub const RADIANCE: Shot = Shot {
        exposure: 1.0,
        indirect_clamp: 0.0,
        seed: 0,
    };
}

/// A grey floor, a red sphere and a rough metal one, lit by [`lit_frame`]'s light and sky.
pub fn spheres_on_a_floor() -> Scene {
    let mut s = Scene::new();
    let grey = SurfaceMaterial {
        base_color: [0.7, 0.7, 0.7, 1.0],
        perceptual_roughness: 0.8,
        ..Default::default()
    };
    s.add(
        &square(3.0),
        Affine3A::from_rotation_x(-PI / 2.0),
        false,
        &grey,
    );
    s.add(
        &sphere(24),
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.6),
            Quat::IDENTITY,
            Vec3::new(-0.5, 0.6, 0.0),
        ),
        false,
        &SurfaceMaterial {
            base_color: [0.8, 0.3, 0.2, 1.0],
            ..grey
        },
    );
    s.add(
        &sphere(24),
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.45),
            Quat::IDENTITY,
            Vec3::new(0.7, 0.45, 0.3),
        ),
        false,
        &SurfaceMaterial {
            base_color: [0.9, 0.9, 0.9, 1.0],
            metallic: 1.0,
            perceptual_roughness: 0.35,
            ..Default::default()
        },
    );
    s
}

/// A `size`² view of [`spheres_on_a_floor`] at `samples` a pixel, under a soft point light and a
/// blue sky.
pub fn lit_frame(size: u32, samples: u32) -> Trace {
    Trace {
        size,
        samples,
        bounces: 4,
        sky: Vec3::new(0.4, 0.5, 0.7),
        mode: DebugView::PathTraced.shader_index(),
        world_from_clip: camera(
            Vec3::new(0.0, 2.0, 3.5),
            Vec3::new(0.0, 0.4, 0.0),
            Vec3::Y,
            45.0,
        ),
        lights: vec![SceneLight::Point {
            position: Vec3::new(1.0, 3.0, 1.5),
            power: Vec3::splat(4.0 * PI * 6.0),
            radius: 0.3,
            range: None,
        }],
    }
}
