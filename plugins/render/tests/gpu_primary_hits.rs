//! The WGSL traversal on a real adapter (Mesa's llvmpipe in CI) finds the same primary-hit triangles
//! as the engine's CPU traversal, for the same camera rays.

use std::path::Path;
use treelight_bvh::glam::{Affine3A, Quat, Vec3};
use treelight_bvh::{Bvh, BvhConfig, Ray, Triangle};
use treelight_render::{PRIMARY_HITS_WGSL, instance_bytes, node_bytes, triangle_bytes};
use wgpu::util::DeviceExt;

fn skip() -> bool {
    if std::env::var("TREELIGHT_SKIP_GPU_TESTS").as_deref() == Ok("1") {
        eprintln!("SKIPPED: TREELIGHT_SKIP_GPU_TESTS=1");
        return true;
    }
    false
}

fn device() -> (wgpu::Device, wgpu::Queue) {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter = bevy::tasks::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
        .unwrap_or_else(|e| {
            panic!(
                "no GPU adapter was found ({e}). Install Mesa's software Vulkan (apt-get install -y mesa-vulkan-drivers \
                 libvulkan1), or set TREELIGHT_SKIP_GPU_TESTS=1 to skip GPU tests."
            )
        });
    eprintln!("adapter: {:?}", adapter.get_info().name);
    bevy::tasks::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default()))
        .expect("a device")
}

struct View {
    origin: Vec3,
    lower_left: Vec3,
    horizontal: Vec3,
    vertical: Vec3,
    width: u32,
    height: u32,
}

impl View {
    fn looking_at(eye: Vec3, target: Vec3, width: u32, height: u32) -> Self {
        let f = (target - eye).normalize();
        let r = f.cross(Vec3::Y).normalize();
        let u = r.cross(f);
        let half = (30f32).to_radians().tan();
        let horizontal = r * 2.0 * half;
        let vertical = -u * 2.0 * half;
        Self {
            origin: eye,
            lower_left: f - horizontal * 0.5 - vertical * 0.5,
            horizontal,
            vertical,
            width,
            height,
        }
    }
    fn ray(&self, x: u32, y: u32) -> Ray {
        let s = (x as f32 + 0.5) / self.width as f32;
        let t = (y as f32 + 0.5) / self.height as f32;
        Ray::new(
            self.origin,
            self.lower_left + self.horizontal * s + self.vertical * t,
        )
    }
    fn uniform(&self, root: u32) -> Vec<u8> {
        let mut w: Vec<u32> = Vec::new();
        for (v, extra) in [
            (self.origin, self.width),
            (self.lower_left, self.height),
            (self.horizontal, root),
            (self.vertical, 0),
        ] {
            w.extend(v.to_array().map(f32::to_bits));
            w.push(extra);
        }
        w.iter().flat_map(|x| x.to_le_bytes()).collect()
    }
}

/// Runs `primary_hits` and returns one triangle id (or u32::MAX) per pixel.
fn gpu_hits(bvh: &Bvh, view: &View) -> Vec<u32> {
    let (device, queue) = device();
    let mut nodes: Vec<u8> = (0..bvh.inner_capacity())
        .flat_map(|i| node_bytes(&bvh.gpu_node(i)))
        .collect();
    let mut tris: Vec<u8> = (0..bvh.triangle_capacity())
        .flat_map(|t| triangle_bytes(&bvh.gpu_triangle(t)))
        .collect();
    let mut insts: Vec<u8> = (0..bvh.instance_capacity())
        .flat_map(|i| instance_bytes(&bvh.gpu_instance(i)))
        .collect();
    // Storage bindings may not be empty.
    for (buf, size) in [(&mut nodes, 64), (&mut tris, 48), (&mut insts, 112)] {
        if buf.is_empty() {
            buf.resize(size, 0);
        }
    }
    let storage = |label, contents: &[u8]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::STORAGE,
        })
    };
    let nodes = storage("nodes", &nodes);
    let tris = storage("triangles", &tris);
    let insts = storage("instances", &insts);
    let camera = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("camera"),
        contents: &view.uniform(bvh.gpu_root()),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let size = (view.width * view.height * 4) as u64;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("hit ids"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("primary_hits.wgsl"),
        source: wgpu::ShaderSource::Wgsl(PRIMARY_HITS_WGSL.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("primary_hits"),
        layout: None,
        module: &module,
        entry_point: Some("primary_hits"),
        compilation_options: Default::default(),
        cache: None,
    });
    let entries: Vec<wgpu::BindGroupEntry> = [&nodes, &tris, &insts, &camera, &out]
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(view.width.div_ceil(8), view.height.div_ceil(8), 1);
    }
    encoder.copy_buffer_to_buffer(&out, 0, &readback, 0, size);
    queue.submit([encoder.finish()]);
    readback
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.expect("readback maps"));
    device
        .poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .expect("the GPU finishes");
    let bytes = readback.slice(..).get_mapped_range().to_vec();
    bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

/// Fraction of pixels where GPU and CPU agree on the hit triangle (ties at equal distance count as agreement).
fn agreement(bvh: &Bvh, view: &View, gpu: &[u32]) -> f64 {
    let mut agree = 0usize;
    for y in 0..view.height {
        for x in 0..view.width {
            let ray = view.ray(x, y);
            let cpu = bvh.closest_hit(&ray);
            let g = gpu[(y * view.width + x) as usize];
            let same = match cpu {
                None => g == u32::MAX,
                Some(h) if h.triangle == g => true,
                Some(h) => bvh
                    .world_triangle(g)
                    .and_then(|t| {
                        treelight_bvh::RayData::new(&ray).hit_triangle(&t, 0.0, f32::INFINITY)
                    })
                    .is_some_and(|(t, _, _)| (t - h.t).abs() <= 1e-4 * h.t.max(1.0)),
            };
            agree += same as usize;
        }
    }
    agree as f64 / (view.width * view.height) as f64
}

fn sibenik() -> Vec<Triangle> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes/obj/sibenik.obj");
    let scene = treelight_import::load_scene(&path).unwrap();
    scene
        .world_triangles()
        .into_iter()
        .map(|[a, b, c]| Triangle::new(a, b, c))
        .collect()
}

#[test]
fn sibenik_primary_hits_match_the_cpu() {
    if skip() {
        return;
    }
    let tris = sibenik();
    let mut bvh = Bvh::new(BvhConfig::incr_u());
    bvh.insert_triangles(&tris).unwrap();
    let b = bvh.bounds();
    // Inside the nave, looking along it.
    let c = b.center();
    let view = View::looking_at(
        c + Vec3::new(-(b.max.x - b.min.x) * 0.35, -0.2 * (b.max.y - b.min.y), 0.0),
        c,
        128,
        128,
    );
    let gpu = gpu_hits(&bvh, &view);
    let hits = gpu.iter().filter(|&&g| g != u32::MAX).count();
    assert!(hits > 128 * 128 / 2, "only {hits} pixels hit anything");
    let a = agreement(&bvh, &view, &gpu);
    assert!(
        a >= 0.999,
        "GPU and CPU agree on {:.3}% of pixels",
        a * 100.0
    );
}

#[test]
fn instanced_groups_are_traversed_in_object_space() {
    if skip() {
        return;
    }
    let tris = sibenik();
    let mut bvh = Bvh::default();
    bvh.insert_triangles(&tris[..30_000]).unwrap();
    let g = bvh
        .insert_group(&tris[30_000..], Affine3A::IDENTITY, true)
        .unwrap();
    bvh.set_group_transform(
        g,
        Affine3A::from_rotation_translation(Quat::from_rotation_y(0.4), Vec3::new(3.0, 1.0, -2.0)),
    )
    .unwrap();
    assert!(bvh.is_group_whole(g).unwrap());
    let b = bvh.bounds();
    let view = View::looking_at(
        b.center() + Vec3::new(0.0, 0.2, 1.0) * (b.max - b.min).length(),
        b.center(),
        96,
        96,
    );
    let gpu = gpu_hits(&bvh, &view);
    let a = agreement(&bvh, &view, &gpu);
    assert!(
        a >= 0.999,
        "GPU and CPU agree on {:.3}% of pixels",
        a * 100.0
    );
}
