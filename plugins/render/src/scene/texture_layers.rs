//! Base-colour textures for the path tracer. Software Vulkan has no binding arrays, so every image a
//! traced material uses is resampled on the GPU (from the `GpuImage` Bevy already uploaded; no pixel
//! crosses the CPU) into one layer of a texture array, and the kernel reads any material's texture
//! through one binding. Extraction asks for layers; the render world fills them once the image is on
//! the GPU, and a material only names its layer once the layer holds the image.

use crate::kernels::pipelines::PathTracerShaders;
use crate::types::records::{LayerTexture, TextureWrap};
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
use bevy::render::renderer::{RenderAdapterInfo, RenderDevice, RenderQueue};
use bevy::render::texture::GpuImage;
use bevy::render::{Render, RenderStartup, RenderSystems};
use std::collections::HashMap;

/// Side of every layer of the texture array, in texels, while the images fit at it: images are
/// resampled to it (averaging when they are larger). 4 MiB per layer.
pub const TEXTURE_LAYER_SIZE: u32 = 1024;

/// The smallest side layers shrink to when more images are used than fit at a larger one.
pub const MIN_TEXTURE_LAYER_SIZE: u32 = 128;

/// Bytes the texture array may hold: 256 layers at full size.
pub const TEXTURE_BUDGET_BYTES: u64 = 1 << 30;

/// Layers at full size the budget holds.
pub const MAX_TEXTURE_LAYERS: u32 =
    (TEXTURE_BUDGET_BYTES / (TEXTURE_LAYER_SIZE as u64 * TEXTURE_LAYER_SIZE as u64 * 4)) as u32;

/// Layers of `side` texels the budget and a device of `device_layers` hold.
pub fn layers_at(side: u32, device_layers: u32) -> u32 {
    let per_layer = u64::from(side) * u64::from(side) * 4;
    (TEXTURE_BUDGET_BYTES / per_layer).min(u64::from(device_layers)) as u32
}

/// The side layers take when `count` images need one each: the largest, halving from
/// [`TEXTURE_LAYER_SIZE`] down to [`MIN_TEXTURE_LAYER_SIZE`], at which they all fit; `None` when
/// not even the smallest holds them.
pub fn layer_side_for(count: u32, device_layers: u32) -> Option<u32> {
    let mut side = TEXTURE_LAYER_SIZE;
    while side >= MIN_TEXTURE_LAYER_SIZE {
        if layers_at(side, device_layers) >= count {
            return Some(side);
        }
        side /= 2;
    }
    None
}

/// Layers to make the array with when `wanted` are in use and it held `held`: at least twice what it
/// held (layers added one at a time then copy the array seldom), never more than `max`. With
/// `arrays_in_powers_of_two`, at least two and a power of two (where `max` allows).
///
/// A software adapter compiles the trace kernel anew for each state of the textures it samples,
/// and llvmpipe's takes in whether an array has one layer or more and whether their count is a
/// power of two (a kernel compiled for one layer was compiled again for eight, one for three served
/// five). Counted so, the array keeps the state the kernel was warmed up for at the start, empty,
/// when a scene's textures come in: one compile of the kernel, where a second took half a minute.
pub fn layer_capacity(wanted: u32, held: u32, max: u32, arrays_in_powers_of_two: bool) -> u32 {
    let n = wanted.max(held.saturating_mul(2)).max(1);
    let n = if arrays_in_powers_of_two {
        n.max(2).checked_next_power_of_two().unwrap_or(n)
    } else {
        n
    };
    n.min(max)
}

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
    /// Layers of `side` texels the array holds (0 until the first image: the array is then a
    /// stand-in of one texel a side, as few layers as [`layer_capacity`] allows).
    capacity: u32,
    /// The side of the layers, in texels ([`layer_side_for`] the images in use).
    side: u32,
    /// Layers the device allows in one array.
    device_layers: u32,
    /// Whether the array has two layers or more, counted in powers of two ([`layer_capacity`]):
    /// on a software adapter.
    arrays_in_powers_of_two: bool,
    /// The layers are to be made again at `side` (every image copied anew).
    resize: bool,
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

fn array_texture(device: &RenderDevice, side: u32, layers: u32) -> (Texture, TextureView) {
    let texture = device.create_texture(&TextureDescriptor {
        label: Some("treelight base colour layers"),
        size: Extent3d {
            width: side,
            height: side,
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

/// The layers' sampler: bilinear, clamped.
pub(crate) fn sampler_descriptor() -> SamplerDescriptor<'static> {
    SamplerDescriptor {
        label: Some("treelight base colour"),
        address_mode_u: AddressMode::ClampToEdge,
        address_mode_v: AddressMode::ClampToEdge,
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        ..default()
    }
}

fn init_texture_layers(
    mut commands: Commands,
    device: Res<RenderDevice>,
    adapter: Res<RenderAdapterInfo>,
    shaders: Res<PathTracerShaders>,
    pipeline_cache: Res<PipelineCache>,
) {
    let device_layers = device.limits().max_texture_array_layers;
    let arrays_in_powers_of_two = adapter.device_type == wgpu::DeviceType::Cpu;
    // Nothing to hold yet: a texel a side, in the state the array keeps once it holds images.
    let (texture, view) = array_texture(
        &device,
        1,
        layer_capacity(0, 0, device_layers, arrays_in_powers_of_two),
    );
    let sampler = device.create_sampler(&sampler_descriptor());
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
        capacity: 0,
        side: TEXTURE_LAYER_SIZE,
        device_layers,
        arrays_in_powers_of_two,
        resize: false,
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
    /// Layers the array may grow to at its current side.
    fn max_layers(&self) -> u32 {
        layers_at(self.side, self.device_layers)
    }

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
                None if self.next < self.max_layers() => {
                    self.next += 1;
                    self.next - 1
                }
                None => match layer_side_for(self.next + 1, self.device_layers) {
                    // Every image again at a smaller side, so one more fits.
                    Some(side) if side < self.side => {
                        self.side = side;
                        self.resize = true;
                        warn!(
                            "treelight: {} textures are in use; the path tracer now holds each at \
                             {side} × {side} texels to stay within its {} MiB",
                            self.next + 1,
                            TEXTURE_BUDGET_BYTES >> 20
                        );
                        self.next += 1;
                        self.next - 1
                    }
                    _ => {
                        if !self.warned {
                            self.warned = true;
                            warn!(
                                "treelight: more than {} textures; further ones are traced \
                                 untextured",
                                self.max_layers()
                            );
                        }
                        return None;
                    }
                },
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
            second_uv_set: false,
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
    stats: Res<crate::types::figures::PathTracerStats>,
) {
    let layers = &mut *layers;
    if layers.resize {
        // Made again at the new side; every image is copied into it anew below.
        let capacity = layer_capacity(
            layers.next,
            0,
            layers.max_layers(),
            layers.arrays_in_powers_of_two,
        );
        let (texture, view) = array_texture(&device, layers.side, capacity);
        layers.texture = texture;
        layers.view = view;
        layers.capacity = capacity;
        layers.resize = false;
        layers.generation += 1;
        layers.array_version += 1;
        for slot in layers.slots.values_mut() {
            slot.copied_from = None;
        }
        stats.update(|f| f.texture_side = layers.side);
    }
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
        let capacity = layer_capacity(
            layers.next,
            layers.capacity,
            layers.max_layers(),
            layers.arrays_in_powers_of_two,
        );
        let (texture, view) = array_texture(&device, layers.side, capacity);
        // Keep the layers already filled (none in the first array's stand-in).
        if layers.capacity > 0 {
            encoder.copy_texture_to_texture(
                texel_copy(&layers.texture),
                texel_copy(&texture),
                Extent3d {
                    width: layers.side,
                    height: layers.side,
                    depth_or_array_layers: layers.capacity,
                },
            );
        }
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
        let groups = layers.side.div_ceil(8);
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
        stats.update(|f| f.texture_side = layers.side);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn more_images_than_fit_shrink_every_layer_rather_than_drop_some() {
        // The budget holds 256 layers at full size, four times as many at half.
        assert_eq!(MAX_TEXTURE_LAYERS, 256);
        assert_eq!(layer_side_for(256, 2048), Some(1024));
        assert_eq!(layer_side_for(257, 2048), Some(512));
        assert_eq!(layer_side_for(1024, 2048), Some(512));
        assert_eq!(layer_side_for(1025, 2048), Some(256));
        // The device's own limit on layers counts too.
        assert_eq!(layer_side_for(300, 256), None);
        assert_eq!(layer_side_for(4096, 65536), Some(256));
        assert_eq!(layer_side_for(1 << 14, 1 << 20), Some(128));
        assert_eq!(layer_side_for((1 << 14) + 1, 1 << 20), None);
    }

    #[test]
    fn layers_grow_by_doubling_and_in_powers_of_two_on_a_software_adapter() {
        // Five images into an array of one: five layers, or eight counted in powers of two.
        assert_eq!(layer_capacity(5, 1, 256, false), 5);
        assert_eq!(layer_capacity(5, 1, 256, true), 8);
        // One more image than four layers hold: twice the four either way.
        assert_eq!(layer_capacity(5, 4, 256, false), 8);
        assert_eq!(layer_capacity(5, 4, 256, true), 8);
        // Made again at a smaller side (nothing held): what is used, at least one, or two.
        assert_eq!(layer_capacity(300, 0, 1024, false), 300);
        assert_eq!(layer_capacity(300, 0, 1024, true), 512);
        assert_eq!(layer_capacity(0, 0, 1024, false), 1);
        assert_eq!(layer_capacity(0, 0, 1024, true), 2);
        assert_eq!(layer_capacity(1, 0, 1024, true), 2, "never one layer");
        // Never past what the budget and the device hold, even where that is no power of two.
        assert_eq!(layer_capacity(200, 150, 256, true), 256);
        assert_eq!(layer_capacity(200, 0, 250, true), 250);
        assert_eq!(layer_capacity(u32::MAX, u32::MAX, u32::MAX, true), u32::MAX);
    }
}
