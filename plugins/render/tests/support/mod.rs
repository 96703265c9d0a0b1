//! A bare wgpu harness for the kernels: the adapter the machine has (llvmpipe in CI), buffers built
//! from the crate's record functions, one dispatch, read back.

#![allow(dead_code)]

pub mod brdf;
pub mod scenes;
pub mod temporal;

use treelight_bvh::glam::Vec3;
use treelight_bvh::{Bvh, Ray};
use treelight_render::{
    BufferKind, GpuPrimaryCamera, MAX_PART_SHIFT, PRIMARY_HITS_SPLIT_WGSL, PRIMARY_HITS_WGSL,
    PartLayout, ShadingBuffers, TEXTURE_LAYER_WGSL, ViewParams, instance_bytes, node_bytes,
    part_bindings, part_count, triangle_bytes,
};
use wgpu::util::DeviceExt;

/// A device and its queue.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// Bound where a kernel declares more parts of a split kind than a scene has.
    stand_in: wgpu::Buffer,
}

impl Gpu {
    pub fn new() -> Self {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
        let adapter = bevy::tasks::block_on(
            instance.request_adapter(&wgpu::RequestAdapterOptions::default()),
        )
        .unwrap_or_else(|e| {
            panic!(
                "no GPU adapter was found ({e}). Install Mesa's software Vulkan (apt-get install -y \
                 mesa-vulkan-drivers libvulkan1)."
            )
        });
        eprintln!("adapter: {:?}", adapter.get_info().name);
        // The kernels bind more storage buffers per stage than the defaults allow (the split
        // kinds' parts): the adapter's limits, as the plugin asks for them.
        let (device, queue) =
            bevy::tasks::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                required_limits: adapter.limits(),
                ..Default::default()
            }))
            .expect("a device");
        let stand_in = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stand-in part"),
            size: 256,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Self {
            device,
            queue,
            stand_in,
        }
    }

    /// Group 0 of a split kernel reading the scene (`scene_parts.wgsl`): `sequential` at bindings
    /// 0, 1, 2 and on, then the parts of `kinds` at their bindings past those: `parts` where it
    /// names one, else the stand-in.
    pub fn scene_entries<'a>(
        &'a self,
        sequential: Vec<wgpu::BindingResource<'a>>,
        kinds: &[BufferKind],
        parts: &[(u32, &'a wgpu::Buffer)],
    ) -> Vec<(u32, wgpu::BindingResource<'a>)> {
        let mut entries: Vec<(u32, wgpu::BindingResource<'a>)> = sequential
            .into_iter()
            .enumerate()
            .map(|(i, r)| (i as u32, r))
            .collect();
        let bound = entries.len() as u32;
        for &kind in kinds {
            for &binding in part_bindings(kind).iter().filter(|&&b| b >= bound) {
                let buffer = parts
                    .iter()
                    .find(|(b, _)| *b == binding)
                    .map_or(&self.stand_in, |(_, buffer)| *buffer);
                entries.push((binding, buffer.as_entire_binding()));
            }
        }
        entries
    }

    /// Dispatches a split kernel reading the tree ([`PRIMARY_HITS_SPLIT_WGSL`]'s): `buffers` bound
    /// in order to group 0, the other parts of the nodes, triangles and positions from `parts` or
    /// the stand-in.
    pub fn dispatch_split(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
        parts: &[(u32, &wgpu::Buffer)],
        groups: (u32, u32),
    ) {
        let entries = self.scene_entries(
            buffers.iter().map(|b| b.as_entire_binding()).collect(),
            &[
                BufferKind::Nodes,
                BufferKind::Triangles,
                BufferKind::Positions,
            ],
            parts,
        );
        self.dispatch_indexed(pipeline, vec![entries], groups);
    }

    /// A storage buffer holding `bytes` (at least 256 bytes: bindings may not be empty or shorter
    /// than one record).
    pub fn storage(&self, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        let mut contents = bytes.to_vec();
        if contents.is_empty() {
            contents.resize(256, 0);
        }
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &contents,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            })
    }

    pub fn uniform(&self, bytes: &[u8]) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("uniform"),
                contents: bytes,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
    }

    pub fn zeroed(&self, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("output"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    /// A compute pipeline for `entry` in `source`.
    pub fn pipeline(&self, source: &str, entry: &str) -> wgpu::ComputePipeline {
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(entry),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    /// Dispatches `groups` workgroups with `buffers` bound in order to group 0, and waits.
    pub fn dispatch(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
        groups: (u32, u32),
    ) {
        let resources: Vec<wgpu::BindingResource> =
            buffers.iter().map(|b| b.as_entire_binding()).collect();
        self.dispatch_with(pipeline, resources, groups);
    }

    /// Dispatches with any resources (buffers, textures, samplers) bound in order to group 0.
    pub fn dispatch_with(
        &self,
        pipeline: &wgpu::ComputePipeline,
        resources: Vec<wgpu::BindingResource>,
        groups: (u32, u32),
    ) {
        self.dispatch_groups(pipeline, vec![resources], groups);
    }

    /// Dispatches with one list of resources per bind group, each bound in order.
    pub fn dispatch_groups(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bind_groups: Vec<Vec<wgpu::BindingResource>>,
        groups: (u32, u32),
    ) {
        let indexed = bind_groups
            .into_iter()
            .map(|resources| {
                resources
                    .into_iter()
                    .enumerate()
                    .map(|(i, r)| (i as u32, r))
                    .collect()
            })
            .collect();
        self.dispatch_indexed(pipeline, indexed, groups);
    }

    /// Dispatches with one list of (binding, resource) per bind group.
    pub fn dispatch_indexed(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bind_groups: Vec<Vec<(u32, wgpu::BindingResource)>>,
        groups: (u32, u32),
    ) {
        let bound: Vec<wgpu::BindGroup> = bind_groups
            .into_iter()
            .enumerate()
            .map(|(g, resources)| {
                let entries: Vec<wgpu::BindGroupEntry> = resources
                    .into_iter()
                    .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
                    .collect();
                self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: None,
                    layout: &pipeline.get_bind_group_layout(g as u32),
                    entries: &entries,
                })
            })
            .collect();
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            for (g, group) in bound.iter().enumerate() {
                pass.set_bind_group(g as u32, group, &[]);
            }
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        }
        self.queue.submit([encoder.finish()]);
        self.wait();
    }

    pub fn wait(&self) {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .expect("the GPU finishes");
    }

    /// The buffer's contents.
    pub fn read(&self, buffer: &wgpu::Buffer) -> Vec<u8> {
        let size = buffer.size();
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &readback, 0, size);
        self.queue.submit([encoder.finish()]);
        readback
            .slice(..)
            .map_async(wgpu::MapMode::Read, |r| r.expect("readback maps"));
        self.wait();
        readback.slice(..).get_mapped_range().to_vec()
    }
}

/// The path tracer's base-colour texture array, as the plugin makes it (RGBA8, sRGB-encoded colour).
pub struct Layers {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub sampler: wgpu::Sampler,
    pub size: u32,
    /// The GGX albedo table the kernel binds beside the layers.
    pub energy: wgpu::Buffer,
    /// The panorama sky: its image, its sampler and its distribution (1×1 stand-ins without one).
    pub environment: (wgpu::TextureView, wgpu::Sampler, wgpu::TextureView),
    /// The view uniform's word for it (`treelight_render::environment_uniform`).
    pub environment_word: treelight_bvh::glam::Vec4,
}

impl Layers {
    /// The scene group's panorama entries.
    pub fn environment_entries(&self) -> [(u32, wgpu::BindingResource<'_>); 3] {
        let [a, b, c] = treelight_render::ENVIRONMENT_BINDINGS;
        [
            (a, wgpu::BindingResource::TextureView(&self.environment.0)),
            (b, wgpu::BindingResource::Sampler(&self.environment.1)),
            (c, wgpu::BindingResource::TextureView(&self.environment.2)),
        ]
    }
}

impl Gpu {
    /// A `count`-layer array of `size`² texels, bilinear and clamped like the plugin's.
    pub fn layers(&self, size: u32, count: u32) -> Layers {
        let texture = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("layers"),
            size: wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: count,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let sampler = self.device.create_sampler(&wgpu::SamplerDescriptor {
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Layers {
            texture,
            view,
            sampler,
            size,
            energy: self.uniform(treelight_render::energy_bytes()),
            environment: self.environment(None),
            environment_word: treelight_bvh::glam::Vec4::ZERO,
        }
    }

    /// The panorama's textures as the plugin makes them (`environment.rs`), or its stand-ins.
    pub fn environment(
        &self,
        texels: Option<&treelight_render::EnvironmentTexels>,
    ) -> (wgpu::TextureView, wgpu::Sampler, wgpu::TextureView) {
        let (size, rgba, cells, cdf): ([u32; 2], &[u16], [u32; 2], &[f32]) = match texels {
            Some(t) => ([t.width, t.height], &t.rgba16, t.cells, &t.cdf),
            None => ([1, 1], &[0, 0, 0, 0], [1, 1], &[1.0, 1.0]),
        };
        let texture = |label, [width, height]: [u32; 2], format, bytes: &[u8]| {
            self.device
                .create_texture_with_data(
                    &self.queue,
                    &wgpu::TextureDescriptor {
                        label: Some(label),
                        size: wgpu::Extent3d {
                            width,
                            height,
                            depth_or_array_layers: 1,
                        },
                        mip_level_count: 1,
                        sample_count: 1,
                        dimension: wgpu::TextureDimension::D2,
                        format,
                        usage: wgpu::TextureUsages::TEXTURE_BINDING,
                        view_formats: &[],
                    },
                    wgpu::util::TextureDataOrder::LayerMajor,
                    bytes,
                )
                .create_view(&Default::default())
        };
        let image = texture(
            "environment",
            size,
            wgpu::TextureFormat::Rgba16Float,
            bytemuck::cast_slice(rgba),
        );
        let distribution = texture(
            "environment distribution",
            [cells[0] + 1, cells[1]],
            wgpu::TextureFormat::R32Float,
            bytemuck::cast_slice(cdf),
        );
        let sampler = self.device.create_sampler(&wgpu::SamplerDescriptor {
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        (image, sampler, distribution)
    }

    /// Runs the plugin's `copy_to_layer` kernel from an sRGB RGBA8 image into `layer`.
    pub fn copy_to_layer(
        &self,
        layers: &Layers,
        layer: u32,
        width: u32,
        height: u32,
        rgba8: &[u8],
    ) {
        let source = self.device.create_texture_with_data(
            &self.queue,
            &wgpu::TextureDescriptor {
                label: Some("source"),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba8UnormSrgb,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            rgba8,
        );
        let source_view = source.create_view(&Default::default());
        let target = layers.texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2),
            base_array_layer: layer,
            array_layer_count: Some(1),
            ..Default::default()
        });
        let pipeline = self.pipeline(TEXTURE_LAYER_WGSL, "copy_to_layer");
        self.dispatch_with(
            &pipeline,
            vec![
                wgpu::BindingResource::TextureView(&source_view),
                wgpu::BindingResource::TextureView(&target),
            ],
            (layers.size.div_ceil(8), layers.size.div_ceil(8)),
        );
    }

    /// One layer's texels, RGBA8, rows top to bottom.
    pub fn read_layer(&self, layers: &Layers, layer: u32) -> Vec<u8> {
        self.read_texture(&layers.texture, layer, (layers.size, layers.size), 4)
    }

    /// Layer `layer` of `texture` (`width` × `height` texels of `texel_bytes` each), rows top to
    /// bottom, without the copy's row padding.
    pub fn read_texture(
        &self,
        texture: &wgpu::Texture,
        layer: u32,
        (width, height): (u32, u32),
        texel_bytes: u32,
    ) -> Vec<u8> {
        let row = (width * texel_bytes).next_multiple_of(256);
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("texture readback"),
            size: (row * height) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: layer,
                },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        self.queue.submit([encoder.finish()]);
        buffer
            .slice(..)
            .map_async(wgpu::MapMode::Read, |r| r.expect("readback maps"));
        self.wait();
        let data = buffer.slice(..).get_mapped_range().to_vec();
        data.chunks_exact(row as usize)
            .flat_map(|r| r[..(width * texel_bytes) as usize].to_vec())
            .collect()
    }
}

impl Gpu {
    /// The scene buffers `path_trace` binds: the tree's records, then the given shading records,
    /// object and light records at bindings 0 to 5, the object records' table of per-map UV
    /// transforms (`MapTransformTable::bytes`) at `MAP_TRANSFORMS_BINDING`, and the shading
    /// vertices and the positions (each at the first of their part bindings).
    pub fn scene_buffers(
        &self,
        bvh: &Bvh,
        shading: &ShadingBuffers,
        objects: &[u8],
        lights: &[u8],
        map_transforms: &[u8],
    ) -> [wgpu::Buffer; 9] {
        let [n, t, i, p] = tree_bytes(bvh);
        [
            self.storage("nodes", &n),
            self.storage("triangles", &t),
            self.storage("instances", &i),
            self.storage("attributes", &shading.attributes),
            self.storage("objects", objects),
            self.storage("lights", lights),
            self.storage("map transforms", map_transforms),
            self.storage("shading vertices", &shading.vertices),
            self.storage("positions", &p),
        ]
    }

    /// A view's buffers for the trace kernel, zeroed: accumulation, then depth, objects and
    /// preview.
    pub fn trace_target(&self, width: u32, height: u32) -> TraceTarget {
        let pixels = (width * height) as usize;
        let blocks = (width.div_ceil(2) * height.div_ceil(2)) as usize;
        TraceTarget {
            accum: self.storage("accum", &vec![0u8; pixels * 16]),
            aux: self.storage(
                "aux",
                &vec![0u8; treelight_render::aux_bytes(width, height) as usize],
            ),
            denoised: [0; treelight_render::DENOISE_IMAGES]
                .map(|_| self.storage("denoised", &vec![0u8; pixels * 16])),
            guides: self.storage(
                "guides",
                &vec![0u8; treelight_render::guide_bytes(width, height) as usize],
            ),
            denoise_taps: self.storage(
                "denoiser taps",
                &vec![0u8; treelight_render::denoise_tap_bytes(width, height) as usize],
            ),
            width,
            height,
            pixels,
            blocks,
        }
    }

    /// The denoiser's passes over `target`'s samples (`samples` a pixel), as the plugin runs them; the result (lighting
    /// per pixel, to be multiplied by the albedo) lies in `target.denoised[0]`.
    pub fn denoise(&self, target: &TraceTarget, samples: u32) {
        let pipeline = self.pipeline(treelight_render::DENOISE_WGSL, "denoise");
        self.denoise_with(&pipeline, target, samples);
    }

    /// [`Gpu::denoise`] with a pipeline made once, for pixels of `samples` samples.
    pub fn denoise_with(
        &self,
        pipeline: &wgpu::ComputePipeline,
        target: &TraceTarget,
        samples: u32,
    ) {
        let passes = treelight_render::denoise_passes(u64::from(samples));
        for k in 0..passes {
            self.denoise_pass(pipeline, target, k, passes);
        }
    }

    /// Pass `pass` of the denoiser's `passes` over `target`, as the plugin makes it (one a frame).
    pub fn denoise_pass(
        &self,
        pipeline: &wgpu::ComputePipeline,
        target: &TraceTarget,
        pass: u32,
        passes: u32,
    ) {
        let (w, h) = (target.width, target.height);
        let params = self.storage(
            "denoise pass",
            &treelight_render::denoise_pass_bytes(w, h, pass),
        );
        let t = treelight_render::denoise_target(pass, passes);
        let (source, out) = (
            &target.denoised[treelight_render::denoise_source(t)],
            &target.denoised[t],
        );
        self.dispatch_indexed(
            pipeline,
            vec![vec![
                (0, target.accum.as_entire_binding()),
                (1, target.aux.as_entire_binding()),
                (2, params.as_entire_binding()),
                (3, source.as_entire_binding()),
                (4, out.as_entire_binding()),
                (5, target.guides.as_entire_binding()),
                (6, target.denoise_taps.as_entire_binding()),
            ]],
            (w.div_ceil(8), h.div_ceil(8)),
        );
    }

    /// One dispatch of `path_trace` (`pipeline`): the work `view` names, into `target`.
    pub fn path_trace(
        &self,
        pipeline: &wgpu::ComputePipeline,
        scene: &[wgpu::Buffer; 9],
        view: &ViewParams,
        target: &TraceTarget,
        layers: &Layers,
    ) {
        // The plugin's two bind groups: the scene (records and textures), then the view.
        let uniform = self.uniform(&view.to_bytes());
        let mut scene_group: Vec<wgpu::BindingResource> =
            scene[..6].iter().map(|b| b.as_entire_binding()).collect();
        scene_group.extend([
            wgpu::BindingResource::TextureView(&layers.view),
            wgpu::BindingResource::Sampler(&layers.sampler),
        ]);
        let scene_group: Vec<(u32, wgpu::BindingResource)> = scene_group
            .into_iter()
            .enumerate()
            .map(|(i, r)| (i as u32, r))
            .chain([
                (
                    treelight_render::ENERGY_BINDING,
                    layers.energy.as_entire_binding(),
                ),
                (
                    treelight_render::MAP_TRANSFORMS_BINDING,
                    scene[6].as_entire_binding(),
                ),
                (
                    part_bindings(BufferKind::ShadingVertices)[0],
                    scene[7].as_entire_binding(),
                ),
                (
                    part_bindings(BufferKind::Positions)[0],
                    scene[8].as_entire_binding(),
                ),
            ])
            .chain(layers.environment_entries())
            .collect();
        let view_group = vec![
            (0, uniform.as_entire_binding()),
            (1, target.accum.as_entire_binding()),
            (2, target.aux.as_entire_binding()),
            (3, target.guides.as_entire_binding()),
        ];
        self.dispatch_indexed(pipeline, vec![scene_group, view_group], view.workgroups());
    }
}

impl Gpu {
    /// [`Gpu::scene_buffers`] cut into parts of `1 << shift` records for the split kernel
    /// ([`treelight_render::PATHTRACE_SPLIT_WGSL`]): each part with its binding.
    pub fn split_scene_buffers(
        &self,
        bvh: &Bvh,
        shading: &ShadingBuffers,
        objects: &[u8],
        lights: &[u8],
        map_transforms: &[u8],
        shift: u32,
    ) -> Vec<(u32, wgpu::Buffer)> {
        let [n, t, i, p] = tree_bytes(bvh);
        let mut out = Vec::new();
        let layout = PartLayout {
            shift,
            max_binding_bytes: u64::MAX,
        };
        for (kind, bytes) in [
            (BufferKind::Nodes, &n[..]),
            (BufferKind::Triangles, &t[..]),
            (BufferKind::Positions, &p[..]),
            (BufferKind::Instances, &i[..]),
            (BufferKind::Attributes, &shading.attributes[..]),
            (BufferKind::ShadingVertices, &shading.vertices[..]),
            (BufferKind::Objects, objects),
            (BufferKind::Lights, lights),
        ] {
            let part_bytes = if part_count(kind) == 1 {
                bytes.len().max(1)
            } else {
                (kind.record_bytes() << layout.shift_of(kind)) as usize
            };
            let chunks: Vec<&[u8]> = if bytes.is_empty() {
                vec![bytes]
            } else {
                bytes.chunks(part_bytes).collect()
            };
            assert!(
                chunks.len() <= part_count(kind),
                "too many parts of {kind:?}"
            );
            for (k, c) in chunks.into_iter().enumerate() {
                out.push((part_bindings(kind)[k], self.storage(kind.label(), c)));
            }
        }
        out.push((
            treelight_render::MAP_TRANSFORMS_BINDING,
            self.storage("map transforms", map_transforms),
        ));
        out
    }

    /// [`Gpu::path_trace`] through the split kernel over [`Gpu::split_scene_buffers`]: parts a kind
    /// does not have are bound to the stand-in, as the plugin binds them.
    pub fn path_trace_split(
        &self,
        pipeline: &wgpu::ComputePipeline,
        scene: &[(u32, wgpu::Buffer)],
        view: &ViewParams,
        target: &TraceTarget,
        layers: &Layers,
    ) {
        let uniform = self.uniform(&view.to_bytes());
        let mut scene_group: Vec<(u32, wgpu::BindingResource)> = scene
            .iter()
            .map(|(b, buffer)| (*b, buffer.as_entire_binding()))
            .collect();
        for kind in BufferKind::ALL {
            for &b in part_bindings(kind) {
                if !scene.iter().any(|(x, _)| *x == b) {
                    scene_group.push((b, self.stand_in.as_entire_binding()));
                }
            }
        }
        scene_group.push((6, wgpu::BindingResource::TextureView(&layers.view)));
        scene_group.push((7, wgpu::BindingResource::Sampler(&layers.sampler)));
        scene_group.push((
            treelight_render::ENERGY_BINDING,
            layers.energy.as_entire_binding(),
        ));
        scene_group.extend(layers.environment_entries());
        let view_group = vec![
            (0, uniform.as_entire_binding()),
            (1, target.accum.as_entire_binding()),
            (2, target.aux.as_entire_binding()),
            (3, target.guides.as_entire_binding()),
        ];
        self.dispatch_indexed(pipeline, vec![scene_group, view_group], view.workgroups());
    }
}

/// A view's buffers as the trace kernel binds them.
pub struct TraceTarget {
    /// Per pixel: the sum of its samples (rgb) and their count (w).
    pub accum: wgpu::Buffer,
    /// As `treelight_render::aux_bytes` lays it out.
    pub aux: wgpu::Buffer,
    /// The denoiser's result (the first) and its two working images.
    pub denoised: [wgpu::Buffer; treelight_render::DENOISE_IMAGES],
    /// The trace kernel's guides for the denoiser (guide_layout.wgsl).
    pub guides: wgpu::Buffer,
    /// What the denoiser's first pass keeps for the others' taps.
    pub denoise_taps: wgpu::Buffer,
    /// The image's width.
    pub width: u32,
    /// The image's height.
    pub height: u32,
    /// Pixels in the image.
    pub pixels: usize,
    /// Preview blocks at the finest scale: the room the preview has in `aux`.
    pub blocks: usize,
}

impl Gpu {
    /// Per pixel, the depth of its first sample's primary hit.
    pub fn read_depth(&self, target: &TraceTarget) -> Vec<f32> {
        floats(&self.read(&target.aux))[..target.pixels].to_vec()
    }

    /// Per preview block, its sample (rgb) and depth.
    pub fn read_preview(&self, target: &TraceTarget) -> Vec<f32> {
        let start = 2 * target.pixels;
        floats(&self.read(&target.aux))[start..start + 4 * target.blocks].to_vec()
    }

    /// Per pixel, the object slot of its first sample's primary hit (`u32::MAX` where it escaped).
    pub fn read_objects(&self, target: &TraceTarget) -> Vec<u32> {
        words(&self.read(&target.aux))[target.pixels..2 * target.pixels].to_vec()
    }

    /// Per preview block, the object slot of its sample's primary hit.
    pub fn read_preview_objects(&self, target: &TraceTarget) -> Vec<u32> {
        let start = 2 * target.pixels + 4 * target.blocks;
        words(&self.read(&target.aux))[start..start + target.blocks].to_vec()
    }

    /// Per pixel, the split of the denoiser's head sum (`head_split_at` of aux_layout.wgsl).
    pub fn read_head_splits(&self, target: &TraceTarget) -> Vec<u32> {
        let start = target.head_splits_start();
        words(&self.read(&target.aux))[start..start + target.pixels].to_vec()
    }

    /// Per pixel, the split of the denoiser's tail (`tail_split_at` of aux_layout.wgsl).
    pub fn read_tail_splits(&self, target: &TraceTarget) -> Vec<u32> {
        let start = target.head_splits_start() + target.pixels;
        words(&self.read(&target.aux))[start..start + target.pixels].to_vec()
    }
}

impl TraceTarget {
    /// The word of `aux` where the pixels' splits of the denoiser's head sum start: after the
    /// per-pixel depths and slots, the blocks' samples and their slots.
    pub fn head_splits_start(&self) -> usize {
        2 * self.pixels + 5 * self.blocks
    }
}

/// Writes `record` into slot `index` of an array of equal-sized records.
pub fn put_record(array: &mut [u8], index: u32, record: &[u8]) {
    let at = index as usize * record.len();
    array[at..at + record.len()].copy_from_slice(record);
}

/// A small LCG, independent of the shader's generator.
pub struct Rng(pub u64);

impl Rng {
    fn step(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }

    /// Uniform in [0, 1), from the state's top 24 bits.
    pub fn next(&mut self) -> f32 {
        ((self.step() >> 40) as f32) / (1u64 << 24) as f32
    }

    /// A uniform byte, from the state's top 8 bits.
    pub fn byte(&mut self) -> u8 {
        (self.step() >> 56) as u8
    }
}

/// sRGB transfer function, decoding.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer function, encoding.
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The path tracer's node, triangle and instance records and its position pool, complete: the
/// nodes as `WideRecords` lays the tree out afresh (its root is [`traced_root`]).
pub fn tree_bytes(bvh: &Bvh) -> [Vec<u8>; 4] {
    layout_bytes(bvh, &treelight_bvh::WideRecords::of(bvh))
}

/// The path tracer's node, triangle and instance records and its position pool, complete, the
/// nodes as `layout` lays them out (its root is `layout.root(bvh)`).
pub fn layout_bytes(bvh: &Bvh, layout: &treelight_bvh::WideRecords) -> [Vec<u8>; 4] {
    let [triangles, positions] = all_triangle_bytes(bvh);
    [
        layout.records(bvh).iter().flat_map(node_bytes).collect(),
        triangles,
        (0..bvh.instance_capacity())
            .flat_map(|i| instance_bytes(&layout.instance(bvh, i)))
            .collect(),
        positions,
    ]
}

/// The root reference of [`tree_bytes`]' records.
pub fn traced_root(bvh: &Bvh) -> u32 {
    treelight_bvh::WideRecords::of(bvh).root(bvh)
}

/// Every triangle's record and the position pool they index, laid out afresh
/// (`PositionPool::of`).
pub fn all_triangle_bytes(bvh: &Bvh) -> [Vec<u8>; 2] {
    let (pool, runs) = treelight_bvh::PositionPool::of(bvh);
    pool_bytes(bvh, &pool, &runs)
}

/// Every triangle's record and the position pool, as `pool` lays them out after the update that
/// said `runs` (every run of a pool laid out afresh).
pub fn pool_bytes(
    bvh: &Bvh,
    pool: &treelight_bvh::PositionPool,
    runs: &treelight_bvh::PositionChanges,
) -> [Vec<u8>; 2] {
    let mut positions = Vec::new();
    pool.write_runs(bvh, runs, &mut positions);
    let triangles = (0..bvh.triangle_capacity())
        .flat_map(|t| triangle_bytes(&pool.record(bvh, t)))
        .collect();
    [triangles, bytemuck::cast_slice(&positions).to_vec()]
}

/// Every instance's record with its root named as the binary layouts name it (by inner node).
pub fn binary_instance_bytes(bvh: &Bvh) -> Vec<u8> {
    (0..bvh.instance_capacity())
        .flat_map(|i| instance_bytes(&bvh.gpu_instance(i)))
        .collect()
}

/// The binary records (`Bvh::gpu_node`): nodes, triangles, instances, and the root reference.
pub fn binary_tree_bytes(bvh: &Bvh) -> ([Vec<u8>; 4], u32) {
    let ([triangles, positions], instances) = (all_triangle_bytes(bvh), binary_instance_bytes(bvh));
    let mut nodes: Vec<u8> = bytemuck::cast_slice(&bvh.gpu_nodes()).to_vec();
    if nodes.is_empty() {
        // A storage buffer may not be empty.
        nodes = vec![0; size_of::<treelight_bvh::GpuNode>()];
    }
    ([nodes, triangles, instances, positions], bvh.gpu_root())
}

/// The binary records renumbered depth first: nodes, triangles, instances, and the root reference.
pub fn depth_first_tree_bytes(bvh: &Bvh) -> ([Vec<u8>; 4], u32) {
    let d = bvh.gpu_depth_first_layout();
    let [triangles, positions] = all_triangle_bytes(bvh);
    let mut nodes: Vec<u8> = bytemuck::cast_slice(&d.nodes).to_vec();
    if nodes.is_empty() {
        // A storage buffer may not be empty.
        nodes = vec![0; size_of::<treelight_bvh::GpuNode>()];
    }
    let instances = d.instances.iter().flat_map(instance_bytes).collect();
    ([nodes, triangles, instances, positions], d.root)
}

/// The tree as 4-wide records: nodes, triangles, instances, and the root reference.
pub fn wide_tree_bytes(bvh: &Bvh) -> ([Vec<u8>; 4], u32) {
    let wide = bvh.gpu_wide_layout();
    let [triangles, positions] = all_triangle_bytes(bvh);
    let mut nodes: Vec<u8> = bytemuck::cast_slice(&wide.nodes).to_vec();
    if nodes.is_empty() {
        // A storage buffer may not be empty.
        nodes = bytemuck::bytes_of(&treelight_bvh::GpuWideNode::default()).to_vec();
    }
    let instances = wide.instances.iter().flat_map(instance_bytes).collect();
    ([nodes, triangles, instances, positions], wide.root)
}

/// The binary records with boxes in bytes: nodes, triangles, instances, and the root reference.
pub fn binary_compressed_tree_bytes(bvh: &Bvh) -> ([Vec<u8>; 4], u32) {
    let ([triangles, positions], instances) = (all_triangle_bytes(bvh), binary_instance_bytes(bvh));
    let nodes = bvh
        .gpu_nodes()
        .iter()
        .map(treelight_bvh::GpuCompressedBinaryNode::quantize)
        .collect::<Vec<_>>();
    let mut nodes: Vec<u8> = bytemuck::cast_slice(&nodes).to_vec();
    if nodes.is_empty() {
        // A storage buffer may not be empty.
        nodes = vec![0; size_of::<treelight_bvh::GpuCompressedBinaryNode>()];
    }
    ([nodes, triangles, instances, positions], bvh.gpu_root())
}

pub fn words(bytes: &[u8]) -> Vec<u32> {
    bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

/// The relative MSE of `image` against `reference`: the sum of squared differences over the sum of
/// the reference's squares.
pub fn relative_mse(
    image: &[treelight_bvh::glam::Vec3],
    reference: &[treelight_bvh::glam::Vec3],
) -> f32 {
    let num: f32 = image
        .iter()
        .zip(reference)
        .map(|(a, b)| (*a - *b).length_squared())
        .sum();
    let den: f32 = reference.iter().map(|b| b.length_squared()).sum();
    num / den
}

pub fn floats(bytes: &[u8]) -> Vec<f32> {
    words(bytes).into_iter().map(f32::from_bits).collect()
}

/// A pinhole camera as `primary_hits` reads it.
pub struct PinholeView {
    pub origin: Vec3,
    pub lower_left: Vec3,
    pub horizontal: Vec3,
    pub vertical: Vec3,
    pub width: u32,
    pub height: u32,
}

impl PinholeView {
    pub fn looking_at(eye: Vec3, target: Vec3, width: u32, height: u32) -> Self {
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
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let s = (x as f32 + 0.5) / self.width as f32;
        let t = (y as f32 + 0.5) / self.height as f32;
        Ray::new(
            self.origin,
            self.lower_left + self.horizontal * s + self.vertical * t,
        )
    }
    pub fn uniform(&self, root: u32) -> Vec<u8> {
        let record = GpuPrimaryCamera {
            origin: self.origin.to_array(),
            width: self.width,
            lower_left: self.lower_left.to_array(),
            height: self.height,
            horizontal: self.horizontal.to_array(),
            root,
            vertical: self.vertical.to_array(),
            part_shift: MAX_PART_SHIFT,
        };
        bytemuck::bytes_of(&record).to_vec()
    }
}

/// Runs `primary_hits` on buffers holding a tree (nodes, triangles, instances, positions): one
/// triangle id (or u32::MAX) per pixel.
pub fn hits_on(gpu: &Gpu, buffers: [&wgpu::Buffer; 4], root: u32, view: &PinholeView) -> Vec<u32> {
    kernel_hits_on(gpu, PRIMARY_HITS_WGSL, buffers, root, view)
}

/// [`hits_on`] through the `primary_hits` of kernel `source` (a layout's).
fn kernel_hits_on(
    gpu: &Gpu,
    source: &str,
    [nodes, tris, insts, positions]: [&wgpu::Buffer; 4],
    root: u32,
    view: &PinholeView,
) -> Vec<u32> {
    let camera = gpu.uniform(&view.uniform(root));
    let out = gpu.zeroed((view.width * view.height * 4) as u64);
    let pipeline = gpu.pipeline(source, "primary_hits");
    let entries = [nodes, tris, insts, &camera, &out]
        .into_iter()
        .enumerate()
        .map(|(k, b)| (k as u32, b.as_entire_binding()))
        .chain([(
            part_bindings(BufferKind::Positions)[0],
            positions.as_entire_binding(),
        )])
        .collect();
    gpu.dispatch_indexed(
        &pipeline,
        vec![entries],
        (view.width.div_ceil(8), view.height.div_ceil(8)),
    );
    words(&gpu.read(&out))
}

/// `primary_hits` with the nodes, triangles and positions cut into parts (of `1 << shift`
/// records for the nodes, as `PartLayout::shift_of` says for the others), each bound at its
/// part's binding, as the plugin binds a scene larger than one binding holds.
pub fn gpu_split_hits(bvh: &Bvh, view: &PinholeView, shift: u32) -> Vec<u32> {
    let gpu = Gpu::new();
    let [n, t, i, p] = tree_bytes(bvh);
    let layout = PartLayout {
        shift,
        max_binding_bytes: u64::MAX,
    };
    let cut = |kind: BufferKind, bytes: &[u8]| -> Vec<wgpu::Buffer> {
        let part_bytes = (kind.record_bytes() << layout.shift_of(kind)) as usize;
        let parts: Vec<wgpu::Buffer> = bytes
            .chunks(part_bytes)
            .map(|c| gpu.storage(kind.label(), c))
            .collect();
        assert!(
            parts.len() <= part_count(kind),
            "{} parts of {kind:?}: more than the kernel binds",
            parts.len()
        );
        parts
    };
    let (nodes, tris) = (cut(BufferKind::Nodes, &n), cut(BufferKind::Triangles, &t));
    let positions = cut(BufferKind::Positions, &p);
    let insts = gpu.storage("instances", &i);
    let mut camera_bytes = view.uniform(traced_root(bvh));
    // The camera's last word is the part shift.
    let at = camera_bytes.len() - 4;
    camera_bytes[at..].copy_from_slice(&shift.to_le_bytes());
    let camera = gpu.uniform(&camera_bytes);
    let out = gpu.zeroed((view.width * view.height * 4) as u64);
    let pipeline = gpu.pipeline(PRIMARY_HITS_SPLIT_WGSL, "primary_hits");
    let mut parts: Vec<(u32, &wgpu::Buffer)> = Vec::new();
    for (kind, buffers) in [
        (BufferKind::Nodes, &nodes),
        (BufferKind::Triangles, &tris),
        (BufferKind::Positions, &positions),
    ] {
        parts.extend(part_bindings(kind).iter().copied().zip(buffers).skip(1));
    }
    parts.push((part_bindings(BufferKind::Positions)[0], &positions[0]));
    gpu.dispatch_split(
        &pipeline,
        &[&nodes[0], &tris[0], &insts, &camera, &out],
        &parts,
        (view.width.div_ceil(8), view.height.div_ceil(8)),
    );
    words(&gpu.read(&out))
}

/// `primary_hits` on a complete upload of the tree.
pub fn gpu_hits(bvh: &Bvh, view: &PinholeView) -> Vec<u32> {
    hits_through(PRIMARY_HITS_WGSL, (tree_bytes(bvh), traced_root(bvh)), view)
}

/// `primary_hits` through the binary records ([`binary_tree_bytes`]).
pub fn gpu_binary_hits(bvh: &Bvh, view: &PinholeView) -> Vec<u32> {
    hits_through(
        treelight_render::PRIMARY_HITS_BINARY_WGSL,
        binary_tree_bytes(bvh),
        view,
    )
}

/// `primary_hits` through the binary records renumbered depth first ([`depth_first_tree_bytes`]).
pub fn gpu_depth_first_hits(bvh: &Bvh, view: &PinholeView) -> Vec<u32> {
    hits_through(
        treelight_render::PRIMARY_HITS_BINARY_WGSL,
        depth_first_tree_bytes(bvh),
        view,
    )
}

/// `primary_hits` through the 4-wide layout ([`wide_tree_bytes`]).
pub fn gpu_wide_hits(bvh: &Bvh, view: &PinholeView) -> Vec<u32> {
    hits_through(
        treelight_render::PRIMARY_HITS_WIDE_WGSL,
        wide_tree_bytes(bvh),
        view,
    )
}

/// `primary_hits` through the binary records with boxes in bytes ([`binary_compressed_tree_bytes`]).
pub fn gpu_binary_compressed_hits(bvh: &Bvh, view: &PinholeView) -> Vec<u32> {
    hits_through(
        treelight_render::PRIMARY_HITS_BINARY_COMPRESSED_WGSL,
        binary_compressed_tree_bytes(bvh),
        view,
    )
}

/// `primary_hits` of kernel `source` over a layout's buffers and root.
fn hits_through(
    source: &str,
    ([n, t, i, p], root): ([Vec<u8>; 4], u32),
    view: &PinholeView,
) -> Vec<u32> {
    let gpu = Gpu::new();
    let buffers = [
        gpu.storage("nodes", &n),
        gpu.storage("triangles", &t),
        gpu.storage("instances", &i),
        gpu.storage("positions", &p),
    ];
    kernel_hits_on(
        &gpu,
        source,
        [&buffers[0], &buffers[1], &buffers[2], &buffers[3]],
        root,
        view,
    )
}

/// For the examples: the number after flag `name` on the command line, or `default`.
pub fn arg(name: &str, default: u32) -> u32 {
    std::env::args()
        .skip_while(|a| a != name)
        .nth(1)
        .map_or(default, |v| v.parse().expect("a number"))
}

/// For the examples: the scene arguments (those that are not a flag or a flag's value); exits with
/// `usage` when there are none.
pub fn scene_args(usage: &str) -> Vec<String> {
    let mut specs: Vec<String> = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a.starts_with("--") {
            args.next();
        } else {
            specs.push(a);
        }
    }
    if specs.is_empty() {
        eprintln!("{usage}");
        std::process::exit(2);
    }
    specs
}

impl Gpu {
    /// The plugin's resolve pass (`fragment`) over `target` into a fresh `width` × `height`
    /// RGBA32F image, with `params` as its uniform and `outlines` as the outline words; returns the
    /// image's pixels, rows from the top.
    pub fn resolve(
        &self,
        target: &TraceTarget,
        (width, height): (u32, u32),
        params: &treelight_render::ResolveParams,
        outlines: &[u32],
    ) -> Vec<[f32; 4]> {
        let format = wgpu::TextureFormat::Rgba32Float;
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("resolve"),
                source: wgpu::ShaderSource::Wgsl(treelight_render::RESOLVE_WGSL.into()),
            });
        let pipeline = self
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("resolve"),
                layout: None,
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vertex"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: Default::default(),
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fragment"),
                    compilation_options: Default::default(),
                    targets: &[Some(format.into())],
                }),
                multiview_mask: None,
                cache: None,
            });
        let texture = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("resolved"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let params = self.storage("resolve", &params.to_bytes());
        let words: Vec<u8> = outlines.iter().flat_map(|w| w.to_le_bytes()).collect();
        let outline_buffer = self.storage("outlines", &words);
        // The temporal pass's picture, for a resolve told to show it.
        let shown = self.zeroed((target.pixels * 16) as u64);
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                (0, target.accum.as_entire_binding()),
                (1, target.aux.as_entire_binding()),
                (2, params.as_entire_binding()),
                (3, outline_buffer.as_entire_binding()),
                (4, target.denoised[0].as_entire_binding()),
                (5, target.guides.as_entire_binding()),
                (6, shown.as_entire_binding()),
            ]
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource }),
        });
        let view = texture.create_view(&Default::default());
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("resolve"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.draw(0..3, 0..1);
        }
        self.queue.submit([encoder.finish()]);
        floats(&self.read_texture(&texture, 0, (width, height), 16))
            .chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect()
    }
}
