//! Base-colour textures for the path tracer. Software Vulkan has no binding arrays, so every image a
//! traced material uses is resampled on the GPU (from the `GpuImage` Bevy already uploaded; no pixel
//! crosses the CPU) into one layer of a texture array, and the kernel reads any material's texture
//! through one binding. Extraction asks for layers; the render world fills them once the image is on
//! the GPU, and a material only names its layer once the layer holds the image.

use crate::pipelines::PathTracerShaders;
use crate::records::{LayerTexture, TextureWrap};
use bevy::image::{ImageAddressMode, ImageSampler};
use bevy::prelude::*;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::binding_types::{texture_2d, texture_storage_2d};
use bevy::render::render_resource::{
    AddressMode, BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries,
    CachedComputePipelineId, CommandEncoderDescriptor, ComputePassDescriptor,
    ComputePipelineDescriptor, Extent3d, FilterMode, Origin3d, PipelineCache, Sampler,
    SamplerDescriptor, ShaderStages, StorageTextureAccess, TexelCopyTextureInfo, Texture,
    TextureAspect, TextureDescriptor, TextureDimension, TextureFormat, TextureId,
    TextureSampleType, TextureUsages, TextureView, TextureViewDescriptor, TextureViewDimension,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::texture::GpuImage;
use bevy::render::{Render, RenderStartup, RenderSystems};
use std::collections::HashMap;

/// Side of every layer of the base-colour texture array, in texels: images are resampled to it
/// (averaging when they are larger). 4 MiB per layer.
pub const TEXTURE_LAYER_SIZE: u32 = 1024;

/// Most layers the array may grow to (fewer if the device allows fewer): 1 GiB at most.
pub const MAX_TEXTURE_LAYERS: u32 = 256;

const LAYER_FORMAT: TextureFormat = TextureFormat::Rgba8Unorm;

pub(crate) fn build(render_app: &mut SubApp) {
    render_app
        .add_systems(RenderStartup, init_texture_layers)
        .add_systems(
            Render,
            fill_texture_layers.in_set(RenderSystems::PrepareResources),
        );
}

/// One image's layer.
struct Slot {
    layer: u32,
    /// The GPU texture last copied into the layer (Bevy makes a new one when the image changes).
    copied_from: Option<TextureId>,
    /// Asked for by the latest pass over the scene's materials.
    used: bool,
}

/// The base-colour texture array and which image each layer holds.
#[derive(Resource)]
pub(crate) struct TextureLayers {
    texture: Texture,
    /// The whole array, as the kernel binds it.
    pub view: TextureView,
    /// Bilinear, clamped: the kernel wraps coordinates itself, per material.
    pub sampler: Sampler,
    capacity: u32,
    max_layers: u32,
    slots: HashMap<AssetId<Image>, Slot>,
    free: Vec<u32>,
    next: u32,
    copy_layout: BindGroupLayoutDescriptor,
    copy_pipeline: CachedComputePipelineId,
    warned: bool,
    /// Raised whenever a layer's texels change: views restart their accumulation.
    pub generation: u64,
    /// Raised whenever the array is replaced by a larger one: the scene bind group is made again.
    pub array_version: u64,
}

fn array_texture(device: &RenderDevice, layers: u32) -> (Texture, TextureView) {
    let texture = device.create_texture(&TextureDescriptor {
        label: Some("treelight base colour layers"),
        size: Extent3d {
            width: TEXTURE_LAYER_SIZE,
            height: TEXTURE_LAYER_SIZE,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: TextureDimension::D2,
        format: LAYER_FORMAT,
        usage: TextureUsages::TEXTURE_BINDING
            | TextureUsages::STORAGE_BINDING
            | TextureUsages::COPY_SRC
            | TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let view = texture.create_view(&TextureViewDescriptor {
        label: Some("treelight base colour layers"),
        dimension: Some(TextureViewDimension::D2Array),
        ..default()
    });
    (texture, view)
}

fn init_texture_layers(
    mut commands: Commands,
    device: Res<RenderDevice>,
    shaders: Res<PathTracerShaders>,
    pipeline_cache: Res<PipelineCache>,
) {
    let (texture, view) = array_texture(&device, 1);
    let sampler = device.create_sampler(&SamplerDescriptor {
        label: Some("treelight base colour"),
        address_mode_u: AddressMode::ClampToEdge,
        address_mode_v: AddressMode::ClampToEdge,
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        ..default()
    });
    let copy_layout = BindGroupLayoutDescriptor::new(
        "treelight texture layer copy",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_storage_2d(LAYER_FORMAT, StorageTextureAccess::WriteOnly),
            ),
        ),
    );
    let copy_pipeline = pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
        label: Some("treelight texture layer copy".into()),
        layout: vec![copy_layout.clone()],
        shader: shaders.texture_layer.clone(),
        entry_point: Some("copy_to_layer".into()),
        ..default()
    });
    commands.insert_resource(TextureLayers {
        texture,
        view,
        sampler,
        capacity: 1,
        max_layers: device
            .limits()
            .max_texture_array_layers
            .min(MAX_TEXTURE_LAYERS),
        slots: HashMap::new(),
        free: Vec::new(),
        next: 0,
        copy_layout,
        copy_pipeline,
        warned: false,
        generation: 0,
        array_version: 0,
    });
}

/// The kernel's wrap mode for a Bevy address mode (clamp-to-border is drawn clamped).
fn wrap_of(mode: ImageAddressMode) -> TextureWrap {
    match mode {
        ImageAddressMode::Repeat => TextureWrap::Repeat,
        ImageAddressMode::MirrorRepeat => TextureWrap::Mirror,
        ImageAddressMode::ClampToEdge | ImageAddressMode::ClampToBorder => TextureWrap::Clamp,
    }
}

impl TextureLayers {
    /// Starts a pass over the scene's materials: layers nobody asks for again are freed at its end.
    pub fn begin_pass(&mut self) {
        for s in self.slots.values_mut() {
            s.used = false;
        }
    }

    /// The layer holding `image`, once it holds it; until then `None` (and a layer is reserved, to be
    /// filled when the image reaches the GPU). `images` gives the wrap modes of its sampler.
    pub fn layer_for(
        &mut self,
        image: AssetId<Image>,
        images: &Assets<Image>,
    ) -> Option<LayerTexture> {
        if !self.slots.contains_key(&image) {
            let layer = match self.free.pop() {
                Some(l) => l,
                None if self.next < self.max_layers => {
                    self.next += 1;
                    self.next - 1
                }
                None => {
                    if !self.warned {
                        self.warned = true;
                        warn!(
                            "treelight: more than {} base-colour textures; further ones are traced \
                             untextured",
                            self.max_layers
                        );
                    }
                    return None;
                }
            };
            self.slots.insert(
                image,
                Slot {
                    layer,
                    copied_from: None,
                    used: true,
                },
            );
        }
        let slot = self.slots.get_mut(&image)?;
        slot.used = true;
        slot.copied_from?;
        let wrap = match images.get(image).map(|i| &i.sampler) {
            Some(ImageSampler::Descriptor(d)) => {
                [wrap_of(d.address_mode_u), wrap_of(d.address_mode_v)]
            }
            _ => [TextureWrap::Clamp; 2],
        };
        Some(LayerTexture {
            layer: slot.layer,
            wrap,
        })
    }

    /// Ends a pass: unused layers go back to the free list.
    pub fn end_pass(&mut self) {
        let free = &mut self.free;
        self.slots.retain(|_, s| {
            if !s.used {
                free.push(s.layer);
            }
            s.used
        });
    }
}

/// Whether the copy kernel can read `image` (a plain 2D image with float texels).
fn copyable(image: &GpuImage) -> bool {
    let d = &image.texture_descriptor;
    d.dimension == TextureDimension::D2
        && d.size.depth_or_array_layers == 1
        && d.sample_count == 1
        && matches!(
            d.format.sample_type(None, None),
            Some(TextureSampleType::Float { .. })
        )
}

/// Grows the array when more layers are reserved than it has, then copies every image whose layer is
/// empty or stale. A layer written here restarts accumulation through the layers' generation.
pub(crate) fn fill_texture_layers(
    mut layers: ResMut<TextureLayers>,
    gpu_images: Res<RenderAssets<GpuImage>>,
    pipeline_cache: Res<PipelineCache>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    let layers = &mut *layers;
    let stale: Vec<(u32, &GpuImage)> = layers
        .slots
        .iter()
        .filter_map(|(id, s)| {
            let gpu = gpu_images.get(*id)?;
            (s.copied_from != Some(gpu.texture.id()) && copyable(gpu)).then_some((s.layer, gpu))
        })
        .collect();
    let grow = layers.next > layers.capacity;
    if stale.is_empty() && !grow {
        return;
    }
    let Some(pipeline) = pipeline_cache.get_compute_pipeline(layers.copy_pipeline) else {
        return;
    };
    let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor {
        label: Some("treelight texture layers"),
    });
    if grow {
        let capacity = (layers.capacity * 2)
            .max(layers.next)
            .min(layers.max_layers);
        let (texture, view) = array_texture(&device, capacity);
        // Keep the layers already filled.
        encoder.copy_texture_to_texture(
            texel_copy(&layers.texture),
            texel_copy(&texture),
            Extent3d {
                width: TEXTURE_LAYER_SIZE,
                height: TEXTURE_LAYER_SIZE,
                depth_or_array_layers: layers.capacity,
            },
        );
        layers.texture = texture;
        layers.view = view;
        layers.capacity = capacity;
        layers.generation += 1;
        layers.array_version += 1;
    }
    let bind_layout = pipeline_cache.get_bind_group_layout(&layers.copy_layout);
    let mut copied = Vec::new();
    for (layer, gpu) in stale {
        if layer >= layers.capacity {
            continue;
        }
        let source = gpu.texture.create_view(&TextureViewDescriptor {
            label: Some("treelight texture source"),
            dimension: Some(TextureViewDimension::D2),
            base_mip_level: 0,
            mip_level_count: Some(1),
            ..default()
        });
        let target = layers.texture.create_view(&TextureViewDescriptor {
            label: Some("treelight texture layer"),
            dimension: Some(TextureViewDimension::D2),
            base_array_layer: layer,
            array_layer_count: Some(1),
            ..default()
        });
        let bind_group = device.create_bind_group(
            "treelight texture layer copy",
            &bind_layout,
            &BindGroupEntries::sequential((&source, &target)),
        );
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("treelight texture layer copy"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        let groups = TEXTURE_LAYER_SIZE.div_ceil(8);
        pass.dispatch_workgroups(groups, groups, 1);
        drop(pass);
        copied.push((layer, gpu.texture.id()));
    }
    queue.submit([encoder.finish()]);
    for s in layers.slots.values_mut() {
        if let Some(&(_, id)) = copied.iter().find(|(l, _)| *l == s.layer) {
            s.copied_from = Some(id);
        }
    }
    if !copied.is_empty() {
        layers.generation += 1;
    }
}

fn texel_copy(texture: &Texture) -> TexelCopyTextureInfo<'_> {
    TexelCopyTextureInfo {
        texture,
        mip_level: 0,
        origin: Origin3d::ZERO,
        aspect: TextureAspect::All,
    }
}
