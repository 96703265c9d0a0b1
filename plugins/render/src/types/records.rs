//! The path tracer's GPU records, one `#[repr(C)]` plain-data struct per WGSL struct (field for field,
//! so a test can hold their layouts against naga's), and the functions that fill them. Kept free of
//! Bevy's render types so the GPU tests can feed the kernels the same bytes the plugin uploads.

use bevy::math::{Affine2, Mat3, Mat4, Vec2, Vec3, Vec4};
use bytemuck::{Pod, Zeroable};

use crate::types::map_transforms::MapTransformTable;
pub use treelight_scene::packed::{decode_normal, decode_tangents, encode_normal, encode_tangents};

/// Bytes of one per-group record (normal matrix and material).
pub const OBJECT_BYTES: u64 = size_of::<GpuObject>() as u64;
/// Bytes of one light record.
pub const LIGHT_BYTES: u64 = size_of::<GpuLight>() as u64;
/// Bytes of the path tracer's view uniform.
pub const VIEW_BYTES: u64 = size_of::<GpuView>() as u64;

/// Bit of a material's wrap word from which each map says it reads the second UV set.
const SECOND_SET_BITS: u32 = 22;

/// `Object` of `pathtrace.wgsl`: one group's normal matrix and material.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuObject {
    /// Rows of the object-to-world normal matrix (the inverse transpose of the linear part).
    pub normal_rows: [[f32; 4]; 3],
    /// Linear base colour and alpha.
    pub base_color: [f32; 4],
    /// Emitted radiance (rgb), before exposure; alpha cutoff (w) of a masked material.
    pub emissive: [f32; 4],
    /// Metallic, perceptual roughness, reflectance, transmission.
    pub params: [f32; 4],
    /// Columns of the UV transform's linear part.
    pub uv_matrix: [f32; 4],
    /// The UV transform's translation.
    pub uv_offset: [f32; 2],
    /// Layer of the base-colour texture array; `u32::MAX` untextured.
    pub texture: u32,
    /// Wrap modes, four bits per map in [`MaterialMap`] order (u in the low two,
    /// [`TextureWrap::code`]); the alpha mode in bits 20-21 ([`SurfaceAlpha::code`]).
    pub wrap: u32,
    /// Layers of the metallic-roughness, normal, occlusion and emission maps (`u32::MAX`: none).
    pub maps: [u32; 4],
    /// Clear coat strength and perceptual roughness, the normal map's green sign.
    pub coat: [f32; 3],
    /// The set of per-map UV transforms its maps read through ([`MapTransformTable`]); `u32::MAX`:
    /// every map through `uv_matrix` and `uv_offset`.
    pub map_transforms: u32,
    /// Tint of the dielectric's specular reflection (rgb).
    pub specular: [f32; 3],
    /// The slot the views' guides and outlines know the object by; `u32::MAX` for its own. A
    /// group the scene re-laid without restarting the views keeps the slot of the group it
    /// replaced, which the pixels traced before still hold.
    pub identity: u32,
}

/// Where [`GpuObject::identity`] lies in an object record's bytes.
const IDENTITY_AT: usize = std::mem::offset_of!(GpuObject, identity);

/// An object record (`object_bytes`) known to the views by slot `identity` (`None`: its own).
pub(crate) fn with_identity(mut record: Vec<u8>, identity: Option<u32>) -> Vec<u8> {
    let word = identity.unwrap_or(u32::MAX).to_le_bytes();
    if let Some(at) = record.get_mut(IDENTITY_AT..IDENTITY_AT + 4) {
        at.copy_from_slice(&word);
    }
    record
}

/// Whether two object records draw the same (they may differ in [`GpuObject::identity`]).
pub(crate) fn same_drawing(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len()
        && a[..IDENTITY_AT] == b[..IDENTITY_AT]
        && a[IDENTITY_AT + 4..] == b[IDENTITY_AT + 4..]
}

/// The maps of a material, in the order of their wrap bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialMap {
    /// Base colour (sRGB) and alpha.
    BaseColor = 0,
    /// Roughness (green) and metalness (blue).
    MetallicRoughness = 1,
    /// Tangent-space normal.
    Normal = 2,
    /// Ambient occlusion (red).
    Occlusion = 3,
    /// Emission (sRGB).
    Emissive = 4,
}

/// `Light` of `pathtrace.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// A point or spot light's position, or the unit direction towards a directional light.
    pub position: [f32; 3],
    /// 0 point, 1 directional, 2 spot.
    pub kind: u32,
    /// Point and spot: intensity (luminous power / 4π). Directional: illuminance.
    pub radiance: [f32; 3],
    /// A point or spot light's radius.
    pub radius: f32,
    /// A spot light's axis: the unit direction it shines in.
    pub direction: [f32; 3],
    /// 1 / range² of a point or spot light (glTF's smooth window); 0: no range. An emissive
    /// triangle's or an emitting group's cumulative share (`EmitterList`).
    pub inv_range2: f32,
    /// A spot light's cone: the attenuation is `saturate(cos θ * scale + offset)²`, θ the angle
    /// from the axis (glTF's and Bevy's formula).
    pub spot_scale: f32,
    /// See `spot_scale`.
    pub spot_offset: f32,
    /// An emissive triangle's id and its group's object slot, or an emitting group's first
    /// triangle record (from the emitters' table's start) and their count (`EmitterList`); zero
    /// for a punctual light.
    pub ids: [u32; 2],
}

/// `View` of `pathtrace.wgsl`: the per-view uniform ([`ViewParams`] as the kernel reads it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuView {
    /// Clip space to world space relative to `origin`, column-major.
    pub world_from_clip: [[f32; 4]; 4],
    /// World space relative to `origin` to clip space, column-major (the depth the resolve
    /// writes).
    pub clip_from_world: [[f32; 4]; 4],
    /// Sky radiance (rgb) and the camera's exposure (w).
    pub sky: [f32; 4],
    /// Accumulation buffer width.
    pub width: u32,
    /// Accumulation buffer height.
    pub height: u32,
    /// The tree's root reference.
    pub root: u32,
    /// Bounces after the primary hit.
    pub max_bounces: u32,
    /// Samples each traced pixel adds.
    pub samples: u32,
    /// What to show.
    pub mode: u32,
    /// Lights in the light buffer.
    pub light_count: u32,
    /// Indirect luminance cap in nits (scene units, before exposure); 0 disables.
    pub indirect_clamp: f32,
    /// Pixels per preview block along each axis; 0 traces tiles instead.
    pub preview_scale: u32,
    /// The preview's random sequence.
    pub preview_seed: u32,
    /// First position in the tile sequence.
    pub tile_start: u32,
    /// Tiles this dispatch traces.
    pub tile_count: u32,
    /// Tiles per row.
    pub tiles_x: u32,
    /// Tiles in the image.
    pub tile_total: u32,
    /// The tile sequence's step ([`crate::types::budget::TileOrder`]).
    pub tile_stride: u32,
    /// Records per part of a split buffer, as a power of two (`PartLayout`).
    pub part_shift: u32,
    /// The samples' seed ([`crate::types::view::PathTraced::seed`]).
    pub sample_seed: u32,
    /// Reflections from which light is capped by `indirect_clamp`: 2 for images (light seen or
    /// reflected once is direct and never capped), 1 for the preview.
    pub clamp_from: u32,
    /// Groups in the emitters' table after the lights (`EmitterList`), each naming its
    /// triangles' records.
    pub emitter_groups: u32,
    /// The sum of their weights (luminance times area).
    pub emitter_weight: f32,
    /// The panorama sky (the `PathTracedEnvironment` resource): cos and sin of its turn, its radiance
    /// scale, its flags as a whole number (zero: the flat sky colour).
    pub environment: [f32; 4],
    /// The point the clip matrices are relative to (the camera's position; w unused).
    pub origin: [f32; 4],
}

/// `Resolve` of `resolve.wgsl`: where the view sits in its target, and where to find its pixels.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuResolve {
    /// The viewport's origin in target pixels.
    pub origin: [f32; 2],
    /// The viewport's size in target pixels.
    pub viewport: [f32; 2],
    /// The accumulation buffer's size.
    pub size: [u32; 2],
    /// Pixels per preview block, shown where a pixel has no sample yet; 0: no preview.
    pub preview_scale: u32,
    /// Object slots the outline buffer covers; 0 when nothing is outlined.
    pub outline_slots: u32,
    /// The outline's colours (linear HDR, before tonemapping), for outline values 1 and 2.
    pub outline_colours: [[f32; 4]; 2],
    /// The outline's width in target pixels.
    pub outline_width: f32,
    /// 1: show the denoiser's result (times the primary hits' albedo) where a pixel has samples.
    pub denoised: u32,
    /// The corner of the target rectangle outside which no outline is drawn (the outlined objects'
    /// projected bounds, widened by the line): fragments outside it skip the search.
    pub outline_min: [f32; 2],
    /// The opposite corner.
    pub outline_max: [f32; 2],
    /// 1: show the temporal pass's picture in place of the samples and the preview.
    pub temporal: u32,
    /// Padding.
    pub pad2: u32,
}

/// What the resolve pass is told about a view: where its pixels go and how outlines look.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResolveParams {
    /// The viewport's origin in target pixels.
    pub origin: Vec2,
    /// The viewport's size in target pixels.
    pub viewport: Vec2,
    /// The accumulation buffer's size.
    pub size: [u32; 2],
    /// Pixels per preview block shown where a pixel has no sample yet; 0: no preview.
    pub preview_scale: u32,
    /// Object slots the outline buffer covers; 0 when nothing is outlined.
    pub outline_slots: u32,
    /// The outline's look.
    pub outline: crate::types::view::OutlineStyle,
    /// Where the outlined objects can be in the target (pixels, min and max corners), from their
    /// projected bounds; outside it nothing is outlined. The whole target when unknown.
    pub outline_rect: [Vec2; 2],
    /// Whether the denoiser ran over the samples: the resolve shows its result.
    pub denoised: bool,
    /// Whether the temporal pass ran: the resolve shows its picture.
    pub temporal: bool,
}

impl ResolveParams {
    /// The `Resolve` uniform's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let colour = |c: bevy::color::LinearRgba| [c.red, c.green, c.blue, c.alpha];
        let record = GpuResolve {
            origin: self.origin.to_array(),
            viewport: self.viewport.to_array(),
            size: self.size,
            preview_scale: self.preview_scale,
            outline_slots: self.outline_slots,
            outline_colours: [colour(self.outline.selected), colour(self.outline.active)],
            outline_width: self.outline.width.clamp(0.0, 8.0),
            denoised: u32::from(self.denoised),
            outline_min: self.outline_rect[0].to_array(),
            outline_max: self.outline_rect[1].to_array(),
            temporal: u32::from(self.temporal),
            pad2: 0,
        };
        bytemuck::bytes_of(&record).to_vec()
    }
}

/// Bytes of a `width × height` view's `aux` buffer (aux_layout.wgsl): per pixel its first sample's
/// depth and object slot; per preview block (room made for the finest scale, 2 × 2 pixels) a sample
/// and its depth, then its object slot; then per pixel the split of the denoiser's head sum, then
/// that of its tail.
pub fn aux_bytes(width: u32, height: u32) -> u64 {
    let pixels = u64::from(width) * u64::from(height);
    let blocks = u64::from(width.div_ceil(2)) * u64::from(height.div_ceil(2));
    pixels * 16 + blocks * 20
}

/// Words a pixel of the denoiser's guides (`GUIDE_WORDS` of guide_layout.wgsl): the mean normal
/// of the samples on the first one's object, the head samples' reflected luminance, the albedo summed (3), and in 2 the
/// emission's mean (three halves) and the head samples' mean albedo luminance (a half). The head's
/// and the tail's splits lie in `aux` ([`aux_bytes`]), so this, a view's largest buffer, stays at
/// 7 words.
pub const GUIDE_WORDS: u64 = 7;

/// Bytes of a `width × height` view's denoiser guides (guide_layout.wgsl).
pub fn guide_bytes(width: u32, height: u32) -> u64 {
    u64::from(width) * u64::from(height) * GUIDE_WORDS * 4
}

/// Words a pixel of what the denoiser's first pass keeps for the filter passes' taps.
pub const DENOISE_TAP_WORDS: u64 = 7;

/// Bytes of a `width × height` view's denoiser taps (denoise.wgsl's `Tap`).
pub fn denoise_tap_bytes(width: u32, height: u32) -> u64 {
    u64::from(width) * u64::from(height) * DENOISE_TAP_WORDS * 4
}

/// Most passes of the denoiser: the first, which tames fireflies and estimates each pixel's
/// noise, then the filter's, taps 1, 2, 4, 8 and 16 pixels apart.
pub const DENOISE_PASSES: u32 = 6;

/// Passes the denoiser makes over pixels of `samples` samples each, its first included: the noise
/// falls with the samples, and so does the reach the filter needs (each pass doubles it); beyond
/// what the noise asks for, blurring costs detail. All five filter passes at up to 2 samples, one
/// fewer each fourfold more (three at 16: against a converged frame of the default scene, less
/// error at 4, 16 and 64 samples than a step later or earlier), and at least one.
pub fn denoise_passes(samples: u64) -> u32 {
    let mut passes = DENOISE_PASSES;
    let mut at = 2;
    while samples > at && passes > 2 {
        passes -= 1;
        at *= 4;
    }
    passes
}

/// The denoiser's images: the result the resolve and the temporal pass read, and two working
/// images. A view runs its passes over several frames, so the result its pictures show must not
/// be written before the last pass.
pub const DENOISE_IMAGES: usize = 3;

/// Which of the denoiser's images pass `pass` of `passes` writes: the last always the first image
/// (the result), the ones before alternating between the two working images, so that the last
/// pass before it writes the second.
pub fn denoise_target(pass: u32, passes: u32) -> usize {
    if pass + 1 >= passes {
        0
    } else {
        1 + ((passes - 2 - pass) % 2) as usize
    }
}

/// Which image a pass that writes image `target` reads: what the pass before it wrote (the first
/// pass reads the accumulation alone, and is bound to the same image as the pass after it).
pub fn denoise_source(target: usize) -> usize {
    if target == 1 { 2 } else { 1 }
}

/// `Temporal` of `temporal.wgsl`: the temporal pass over a view.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTemporal {
    /// The previous camera's clip space from the current one's (column-major).
    pub reproject: [[f32; 4]; 4],
    /// The traced image's width in pixels.
    pub width: u32,
    /// Its height.
    pub height: u32,
    /// Pixels per preview block where a pixel has no sample yet; 0: no preview.
    pub preview_scale: u32,
    /// 1: the denoiser's result stands for a pixel's samples.
    pub denoised: u32,
    /// 0: keep the prior; 1: rebuild it from the last frame; 2: clear it.
    pub restart: u32,
    /// The most samples the prior weighs as.
    pub max_weight: f32,
    /// A pixel's own samples at which the prior no longer counts.
    pub fade_samples: f32,
    /// Padding.
    pub pad: u32,
}

/// The most samples the last frame's picture weighs as in the next (about an eighth of a second
/// of frames at 60 a second, the window an orbit's picture is averaged over).
pub const TEMPORAL_MAX_WEIGHT: f32 = 16.0;

/// A pixel's own samples from which the view shows them alone (the prior fades out linearly
/// before): a still view converges to exactly its samples.
pub const TEMPORAL_FADE_SAMPLES: f32 = 8.0;

/// What to do with the temporal pass's prior this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TemporalRestart {
    /// Nothing changed: keep it.
    Keep,
    /// The camera alone moved: carry the last frame's picture over.
    Reproject,
    /// Something else changed: drop it.
    Clear,
}

/// The temporal pass's uniform for a `width × height` image.
pub fn temporal_bytes(
    reproject: Mat4,
    width: u32,
    height: u32,
    preview_scale: u32,
    denoised: bool,
    restart: TemporalRestart,
) -> Vec<u8> {
    bytemuck::bytes_of(&GpuTemporal {
        reproject: reproject.to_cols_array_2d(),
        width,
        height,
        preview_scale,
        denoised: u32::from(denoised),
        restart: match restart {
            TemporalRestart::Keep => 0,
            TemporalRestart::Reproject => 1,
            TemporalRestart::Clear => 2,
        },
        max_weight: TEMPORAL_MAX_WEIGHT,
        fade_samples: TEMPORAL_FADE_SAMPLES,
        pad: 0,
    })
    .to_vec()
}

/// `Denoise` of `denoise.wgsl`: one pass of the filter.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuDenoise {
    /// The image's width in pixels.
    pub width: u32,
    /// The image's height in pixels.
    pub height: u32,
    /// Pixels between taps.
    pub step: u32,
    /// 1 for the first pass, which reads the accumulation and filters nothing.
    pub first: u32,
    /// How far apart two pixels' lighting may truly be, in standard deviations of their noise,
    /// before the filter stops mixing them (the weight is e^-1 there).
    pub sigma_luminance: f32,
    /// The exponent of the normals' cosine.
    pub sigma_normal: f32,
    /// How strongly a relative depth difference stops it, per pixel of tap distance.
    pub sigma_depth: f32,
    /// Padding.
    pub pad: u32,
}

/// The denoiser's tolerance of a true difference in lighting, in standard deviations of the
/// noise it removes ([`GpuDenoise::sigma_luminance`]): one, so the blur it adds stays within the
/// noise it takes away. One setting for every scene: of 1, 1.4 and 2, measured on the default
/// scene and FlightHelmet (tools/scripts/image_quality.py's renders), more than 1 left
/// FlightHelmet at 64 samples further from the converged frame than not denoising.
pub const DENOISE_SIGMA_LUMINANCE: f32 = 1.0;

/// The uniform of denoiser pass `pass` (0 first: it filters nothing) over a `width × height`
/// image; filter pass `pass` has taps `2^(pass - 1)` pixels apart.
pub fn denoise_pass_bytes(width: u32, height: u32, pass: u32) -> Vec<u8> {
    bytemuck::bytes_of(&GpuDenoise {
        width,
        height,
        step: (1 << pass) >> 1,
        first: u32::from(pass == 0),
        sigma_luminance: DENOISE_SIGMA_LUMINANCE,
        sigma_normal: 128.0,
        sigma_depth: 0.01,
        pad: 0,
    })
    .to_vec()
}

/// Words of the outline buffer for `slots` object slots: two bits a slot, sixteen slots a word.
pub fn outline_words(slots: usize) -> usize {
    slots.div_ceil(16)
}

/// Sets slot `slot`'s outline value (0 none, 1 [`crate::types::view::Outlined::Selected`], 2
/// [`crate::types::view::Outlined::Active`]) in `words`, keeping the stronger of the two when set twice.
pub fn set_outline(words: &mut [u32], slot: u32, value: u32) {
    let (w, shift) = ((slot / 16) as usize, (slot % 16) * 2);
    if let Some(word) = words.get_mut(w) {
        let old = (*word >> shift) & 3;
        *word = (*word & !(3 << shift)) | (old.max(value & 3) << shift);
    }
}

/// `PrimaryCamera` of `primary_hits.wgsl`: pixel (x, y) looks along `lower_left + (x + 0.5) /
/// width * horizontal + (y + 0.5) / height * vertical` from `origin`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPrimaryCamera {
    /// Eye position.
    pub origin: [f32; 3],
    /// Image width.
    pub width: u32,
    /// Direction to the lower-left corner.
    pub lower_left: [f32; 3],
    /// Image height.
    pub height: u32,
    /// The image's horizontal extent.
    pub horizontal: [f32; 3],
    /// The tree's root reference.
    pub root: u32,
    /// The image's vertical extent.
    pub vertical: [f32; 3],
    /// Records per part of a split buffer, as a power of two (`PartLayout`).
    pub part_shift: u32,
}

/// `AoParams` of `primary_hits.wgsl`: ambient-occlusion rays per primary hit and their length.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuAoParams {
    /// Rays per hit.
    pub rays: u32,
    /// Ray length.
    pub length: f32,
    /// Padding.
    pub pad0: u32,
    /// Padding.
    pub pad1: u32,
}

/// How a texture coordinate outside 0..1 folds back, along one axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TextureWrap {
    /// Hold the edge texel (Bevy's default sampler).
    #[default]
    Clamp,
    /// Tile.
    Repeat,
    /// Tile, every other copy mirrored.
    Mirror,
}

impl TextureWrap {
    /// The shader's code for the mode (two bits).
    pub fn code(self) -> u32 {
        match self {
            TextureWrap::Clamp => 0,
            TextureWrap::Repeat => 1,
            TextureWrap::Mirror => 2,
        }
    }

    /// Folds `x` into 0..1 as the kernel does.
    pub fn apply(self, x: f32) -> f32 {
        match self {
            TextureWrap::Clamp => x.clamp(0.0, 1.0),
            TextureWrap::Repeat => x.rem_euclid(1.0),
            TextureWrap::Mirror => {
                let t = x.rem_euclid(2.0);
                if t > 1.0 { 2.0 - t } else { t }
            }
        }
    }
}

/// A material's map as the kernel finds it: a layer of the texture array, how to wrap, and which
/// of the mesh's UV sets it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LayerTexture {
    /// Layer of the texture array.
    pub layer: u32,
    /// Wrap modes along u and v.
    pub wrap: [TextureWrap; 2],
    /// Whether it reads the mesh's second UV set (Bevy's `UvChannel::Uv1`, glTF's
    /// `TEXCOORD_1`); the first where a shading record holds only one.
    pub second_uv_set: bool,
}

/// How a material's alpha is used (glTF's alpha modes, as Bevy's `AlphaMode` has them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SurfaceAlpha {
    /// Solid.
    #[default]
    Opaque,
    /// Not there where alpha is below the cutoff: rays pass, shadow rays too.
    Mask(f32),
    /// Lets `1 - alpha` of the light through, tinted by the base colour (as transmission).
    Blend,
}

impl SurfaceAlpha {
    /// The kernel's code for the mode (two bits).
    pub fn code(self) -> u32 {
        match self {
            SurfaceAlpha::Opaque => 0,
            SurfaceAlpha::Mask(_) => 1,
            SurfaceAlpha::Blend => 2,
        }
    }
}

/// A surface as the path tracer shades it: Bevy's `StandardMaterial` reduced to what the kernel uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMaterial {
    /// Linear base colour and alpha.
    pub base_color: [f32; 4],
    /// Emitted radiance, linear RGB, before exposure.
    pub emissive: [f32; 3],
    /// 0 dielectric, 1 metal.
    pub metallic: f32,
    /// Perceptual roughness (squared for the GGX alpha).
    pub perceptual_roughness: f32,
    /// Dielectric specular reflectance (0.5 is 4%).
    pub reflectance: f32,
    /// Tint of the dielectric's specular reflection, linear.
    pub specular_tint: [f32; 3],
    /// Fraction of the dielectric's unreflected light that passes through (thin-walled).
    pub transmission: f32,
    /// Clear coat strength, 0 to 1.
    pub clearcoat: f32,
    /// The clear coat's perceptual roughness.
    pub clearcoat_roughness: f32,
    /// What alpha means.
    pub alpha: SurfaceAlpha,
    /// Base-colour texture, multiplied with `base_color`; `None` untextured.
    pub base_color_texture: Option<LayerTexture>,
    /// Roughness (green) and metalness (blue), multiplying the factors.
    pub metallic_roughness_texture: Option<LayerTexture>,
    /// Tangent-space normal map, along the mesh's tangents (made per triangle from its UVs where it has
    /// none).
    pub normal_texture: Option<LayerTexture>,
    /// Sign of the normal map's green channel: -1 for maps whose y points down (Bevy's
    /// `flip_normal_map_y`).
    pub normal_y: f32,
    /// Ambient occlusion (red), dimming the light bounced off the surface.
    pub occlusion_texture: Option<LayerTexture>,
    /// Emission map, multiplying `emissive`.
    pub emissive_texture: Option<LayerTexture>,
    /// Applied to the mesh's UVs before a texture is read (Bevy's `uv_transform`).
    pub uv_transform: Affine2,
    /// Each map's own UV transform, in [`MaterialMap`] order, where the maps do not share one
    /// (glTF's `KHR_texture_transform` is per texture; [`MapUvTransforms`](crate::types::map_transforms::MapUvTransforms));
    /// `None`: every map reads through `uv_transform`.
    pub map_uv_transforms: Option<[Affine2; 5]>,
}

impl SurfaceMaterial {
    /// Its maps, in [`MaterialMap`] order.
    pub fn maps(&self) -> [Option<LayerTexture>; 5] {
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            self.occlusion_texture,
            self.emissive_texture,
        ]
    }

    /// Whether any of its maps reads the mesh's second UV set.
    pub fn reads_second_uv_set(&self) -> bool {
        self.maps().iter().flatten().any(|t| t.second_uv_set)
    }
}

impl Default for SurfaceMaterial {
    fn default() -> Self {
        Self {
            base_color: [0.8, 0.8, 0.8, 1.0],
            emissive: [0.0; 3],
            metallic: 0.0,
            perceptual_roughness: 0.5,
            reflectance: 0.5,
            specular_tint: [1.0; 3],
            transmission: 0.0,
            clearcoat: 0.0,
            clearcoat_roughness: 0.5,
            alpha: SurfaceAlpha::Opaque,
            base_color_texture: None,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_y: 1.0,
            occlusion_texture: None,
            emissive_texture: None,
            uv_transform: Affine2::IDENTITY,
            map_uv_transforms: None,
        }
    }
}

/// One group's record: the normal matrix of its object-to-world transform, and its material. A
/// material whose maps have different UV transforms names their set in `transforms`, which the
/// kernel must be given too.
pub fn object_bytes(
    object_to_world: Mat3,
    m: &SurfaceMaterial,
    transforms: &mut MapTransformTable,
) -> Vec<u8> {
    let inv = object_to_world.inverse();
    // The inverse transpose's rows are the inverse's columns.
    let normal = if inv.is_finite() { inv } else { Mat3::IDENTITY };
    let row = |c: Vec3| [c.x, c.y, c.z, 0.0];
    // The maps' transforms: one for all (in the record) where the maps it has agree, else a set.
    let (uv, set) = match m.map_uv_transforms {
        Some(each) => {
            let mut used = m
                .maps()
                .into_iter()
                .zip(each)
                .filter_map(|(map, t)| map.map(|_| t));
            let first = used.next().unwrap_or(m.uv_transform);
            if used.all(|t| t == first) {
                (first, None)
            } else {
                (first, transforms.set_of(&each))
            }
        }
        None => (m.uv_transform, None),
    };
    let mut wrap = m.alpha.code() << 20;
    for (i, t) in m.maps().iter().enumerate() {
        if let Some(t) = t {
            wrap |= (t.wrap[0].code() | (t.wrap[1].code() << 2)) << (4 * i);
            wrap |= u32::from(t.second_uv_set) << (SECOND_SET_BITS + i as u32);
        }
    }
    let layer = |t: Option<LayerTexture>| t.map_or(u32::MAX, |t| t.layer);
    let cutoff = match m.alpha {
        SurfaceAlpha::Mask(c) => c,
        _ => 0.0,
    };
    let record = GpuObject {
        normal_rows: [row(normal.x_axis), row(normal.y_axis), row(normal.z_axis)],
        base_color: m.base_color,
        emissive: [m.emissive[0], m.emissive[1], m.emissive[2], cutoff],
        params: [
            m.metallic,
            m.perceptual_roughness,
            m.reflectance,
            m.transmission,
        ],
        uv_matrix: [
            uv.matrix2.x_axis.x,
            uv.matrix2.x_axis.y,
            uv.matrix2.y_axis.x,
            uv.matrix2.y_axis.y,
        ],
        uv_offset: uv.translation.to_array(),
        texture: layer(m.base_color_texture),
        wrap,
        maps: [
            layer(m.metallic_roughness_texture),
            layer(m.normal_texture),
            layer(m.occlusion_texture),
            layer(m.emissive_texture),
        ],
        coat: [m.clearcoat, m.clearcoat_roughness, m.normal_y],
        map_transforms: set.unwrap_or(u32::MAX),
        specular: m.specular_tint,
        identity: u32::MAX,
    };
    bytemuck::bytes_of(&record).to_vec()
}

/// A light the path tracer samples directly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SceneLight {
    /// Bevy's `PointLight`.
    Point {
        /// World position.
        position: Vec3,
        /// Linear colour times luminous power (lumens).
        power: Vec3,
        /// Radius of the emitting sphere (soft shadows); 0 is a point.
        radius: f32,
        /// Distance at which its light has faded to nothing; `None`: inverse square only.
        range: Option<f32>,
    },
    /// Bevy's `SpotLight`: a point light masked to a cone around its axis.
    Spot {
        /// World position.
        position: Vec3,
        /// Unit direction it shines in.
        direction: Vec3,
        /// Linear colour times luminous power (lumens), as a point light of the same power.
        power: Vec3,
        /// Radius of the emitting sphere (soft shadows); 0 is a point.
        radius: f32,
        /// Distance at which its light has faded to nothing; `None`: inverse square only.
        range: Option<f32>,
        /// Full intensity within this angle of the axis (radians).
        inner_angle: f32,
        /// No light past this angle of the axis (radians).
        outer_angle: f32,
    },
    /// Bevy's `DirectionalLight`.
    Directional {
        /// Unit direction the light travels in.
        direction: Vec3,
        /// Linear colour times illuminance (lux).
        illuminance: Vec3,
    },
}

/// One light's record.
pub fn light_bytes(l: &SceneLight) -> Vec<u8> {
    // Intensity: luminous power spread over the sphere, as Bevy's point and spot lights do.
    let intensity = |power: Vec3| (power / (4.0 * std::f32::consts::PI)).to_array();
    let inv_range2 = |range: Option<f32>| {
        range
            .filter(|r| r.is_finite() && *r > 0.0)
            .map_or(0.0, |r| 1.0 / (r * r))
    };
    let record = match *l {
        SceneLight::Point {
            position,
            power,
            radius,
            range,
        } => GpuLight {
            position: position.to_array(),
            kind: 0,
            radiance: intensity(power),
            radius,
            inv_range2: inv_range2(range),
            ..Default::default()
        },
        SceneLight::Spot {
            position,
            direction,
            power,
            radius,
            range,
            inner_angle,
            outer_angle,
        } => {
            let (cos_outer, cos_inner) = (outer_angle.cos(), inner_angle.min(outer_angle).cos());
            let scale = 1.0 / (cos_inner - cos_outer).max(1e-4);
            GpuLight {
                position: position.to_array(),
                kind: 2,
                radiance: intensity(power),
                radius,
                direction: direction.normalize_or(Vec3::NEG_Z).to_array(),
                inv_range2: inv_range2(range),
                spot_scale: scale,
                spot_offset: -cos_outer * scale,
                ids: [0; 2],
            }
        }
        SceneLight::Directional {
            direction,
            illuminance,
        } => GpuLight {
            position: (-direction.normalize_or(Vec3::NEG_Y)).to_array(),
            kind: 1,
            radiance: illuminance.to_array(),
            ..Default::default()
        },
    };
    bytemuck::bytes_of(&record).to_vec()
}

/// What one dispatch of the trace kernel does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceWork {
    /// Trace `count` tiles from position `start` of the view's [`TileOrder`](crate::types::budget::TileOrder),
    /// each pixel adding [`ViewParams::samples`] samples to its running sum and count.
    Tiles {
        /// First position in the sequence.
        start: u32,
        /// Tiles to trace (at most one sweep).
        count: u32,
    },
    /// Trace one sample per `scale` × `scale` block into the preview buffer, overwriting it.
    Preview {
        /// Pixels per block along each axis (2 or more).
        scale: u32,
        /// Chooses the samples' random sequence.
        seed: u32,
    },
}

impl TraceWork {
    /// Every tile once, as an unbudgeted frame traces (the count is cut to the image's tiles).
    pub const WHOLE_IMAGE: TraceWork = TraceWork::Tiles {
        start: 0,
        count: u32::MAX,
    };
}

/// Reflections from which an image's samples are capped: light seen directly or after one reflection
/// (what a light's shadow ray or a BSDF sample finds from the primary hit) is direct light, and
/// always counts in full.
pub const CLAMP_FROM_IMAGE: u32 = 2;

/// Reflections from which the preview's samples are capped: it shows one sample a block for one
/// frame while the camera moves, so light found by chance after one reflection is capped too.
pub const CLAMP_FROM_PREVIEW: u32 = 1;

/// The path tracer's per-view uniform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewParams {
    /// Clip space to world space relative to `origin` (the inverse of the view-projection, the
    /// camera's translation taken out): camera rays are made from it near the camera, where
    /// numbers are small, so a scene far from the world's origin (a site in millimetres, 1e7
    /// units across) keeps its rays' directions.
    pub world_from_clip: Mat4,
    /// The world point `world_from_clip` is relative to: the camera's position (zero for a
    /// matrix that is the whole view-projection's inverse).
    pub origin: Vec3,
    /// Sky radiance, linear RGB, before exposure.
    pub sky: Vec3,
    /// The camera's exposure multiplier.
    pub exposure: f32,
    /// Accumulation buffer width in pixels.
    pub width: u32,
    /// Accumulation buffer height.
    pub height: u32,
    /// The tree's root reference.
    pub root: u32,
    /// Bounces after the primary hit.
    pub max_bounces: u32,
    /// Samples each traced pixel adds (a pixel's `n`-th sample is the same whichever dispatch
    /// traces it).
    pub samples: u32,
    /// What to show ([`crate::types::view::DebugView::shader_index`]).
    pub mode: u32,
    /// Lights in the light buffer.
    pub light_count: u32,
    /// Groups in the emitters' table after the lights (`EmitterList`), and the sum of their
    /// triangles' weights; `(0, 0.0)` samples none directly.
    pub emitters: (u32, f32),
    /// Largest luminance, in nits (scene units: the exposure does not change it), that light
    /// reflected twice or more may add to a sample (the preview caps light reflected once too);
    /// 0 disables.
    pub indirect_clamp: f32,
    /// What this dispatch traces.
    pub work: TraceWork,
    /// Records per part of the split buffers, as a power of two (`PartLayout`).
    pub part_shift: u32,
    /// The samples' seed: a pixel's `n`-th sample draws its random numbers from the pixel, `n` and
    /// this alone ([`crate::types::view::PathTraced::seed`]).
    pub seed: u32,
    /// The panorama sky's uniform word (zero for the flat `sky`; see
    /// the `PathTracedEnvironment` resource).
    pub environment: Vec4,
}

impl ViewParams {
    /// The uniform as the kernel reads it.
    pub fn record(&self) -> GpuView {
        let order = crate::types::budget::TileOrder::new(self.width, self.height);
        let (preview_scale, preview_seed, tile_start, tile_count) = match self.work {
            TraceWork::Tiles { start, count } => {
                (0, 0, start % order.total, count.min(order.total))
            }
            TraceWork::Preview { scale, seed } => (scale.max(2), seed, 0, 0),
        };
        GpuView {
            world_from_clip: self.world_from_clip.to_cols_array_2d(),
            clip_from_world: self.world_from_clip.inverse().to_cols_array_2d(),
            sky: [self.sky.x, self.sky.y, self.sky.z, self.exposure],
            width: self.width,
            height: self.height,
            root: self.root,
            max_bounces: self.max_bounces,
            samples: self.samples,
            mode: self.mode,
            light_count: self.light_count,
            indirect_clamp: self.indirect_clamp,
            preview_scale,
            preview_seed,
            tile_start,
            tile_count,
            tiles_x: order.tiles_x,
            tile_total: order.total,
            tile_stride: order.stride,
            part_shift: self.part_shift,
            sample_seed: self.seed,
            clamp_from: match self.work {
                TraceWork::Preview { .. } => CLAMP_FROM_PREVIEW,
                TraceWork::Tiles { .. } => CLAMP_FROM_IMAGE,
            },
            emitter_groups: self.emitters.0,
            emitter_weight: self.emitters.1,
            environment: self.environment.to_array(),
            origin: self.origin.extend(0.0).to_array(),
        }
    }

    /// The uniform's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        bytemuck::bytes_of(&self.record()).to_vec()
    }

    /// Workgroups of the dispatch: one per tile (rows of at most 65,535), or one per 8 × 8 preview
    /// pixels.
    pub fn workgroups(&self) -> (u32, u32) {
        match self.work {
            TraceWork::Tiles { count, .. } => {
                let count =
                    count.min(crate::types::budget::TileOrder::new(self.width, self.height).total);
                let x = count.clamp(1, 65_535);
                (x, count.div_ceil(x).max(1))
            }
            TraceWork::Preview { scale, .. } => {
                let scale = scale.max(2);
                let t = crate::types::budget::TILE * scale;
                (self.width.div_ceil(t), self.height.div_ceil(t))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_with_different_transforms_name_a_set_and_agreeing_ones_do_not() {
        let map = Some(LayerTexture {
            layer: 0,
            wrap: [TextureWrap::Clamp; 2],
            second_uv_set: false,
        });
        let shift = |x: f32| Affine2::from_translation(Vec2::new(x, 0.0));
        let record = |m: &SurfaceMaterial, table: &mut MapTransformTable| -> GpuObject {
            bytemuck::pod_read_unaligned(&object_bytes(Mat3::IDENTITY, m, table))
        };
        let mut table = MapTransformTable::default();
        // Base colour and emission differ: a set, and the record's own transform is the first map's.
        let each = [shift(1.0), shift(2.0), shift(3.0), shift(4.0), shift(5.0)];
        let differing = SurfaceMaterial {
            base_color_texture: map,
            emissive_texture: map,
            map_uv_transforms: Some(each),
            ..Default::default()
        };
        let o = record(&differing, &mut table);
        assert_eq!(o.map_transforms, 0);
        assert_eq!(o.uv_offset, [1.0, 0.0]);
        assert_eq!(table.len(), 1);
        // Only the maps a material has count: base colour and occlusion at 7 agree.
        let mut agreeing = each;
        agreeing[0] = shift(7.0);
        agreeing[3] = shift(7.0);
        let m = SurfaceMaterial {
            base_color_texture: map,
            occlusion_texture: map,
            map_uv_transforms: Some(agreeing),
            ..Default::default()
        };
        let o = record(&m, &mut table);
        assert_eq!((o.map_transforms, o.uv_offset), (u32::MAX, [7.0, 0.0]));
        assert_eq!(table.len(), 1);
        // The same differing set again: the same index.
        assert_eq!(record(&differing, &mut table).map_transforms, 0);
        assert_eq!(
            record(&SurfaceMaterial::default(), &mut table).map_transforms,
            u32::MAX
        );
    }

    #[test]
    fn normals_survive_the_octahedral_round_trip() {
        let mut worst: f32 = 1.0;
        for i in 0..2000 {
            // A spiral over the sphere, poles and the z < 0 fold included.
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 2000.0;
            let r = (1.0 - z * z).sqrt();
            let phi = i as f32 * 2.399_963;
            let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            worst = worst.min(decode_normal(encode_normal(n)).dot(n));
        }
        for n in [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ] {
            worst = worst.min(decode_normal(encode_normal(n)).dot(n));
        }
        assert!(worst > 0.99999, "worst cosine {worst}");
    }

    #[test]
    fn tangents_survive_their_packing_with_their_sign() {
        let mut worst: f32 = 1.0;
        for i in 0..600 {
            let dir = |k: usize| {
                let j = (3 * i + k) as f32;
                let z = 1.0 - 2.0 * (j + 0.5) / 1800.0;
                let r = (1.0 - z * z).sqrt();
                Vec3::new(r * (j * 2.399_963).cos(), r * (j * 2.399_963).sin(), z)
            };
            let w = if i % 2 == 0 { 1.0 } else { -1.0 };
            let t = [0, 1, 2].map(|k| dir(k).extend(w));
            let (got, sign) = decode_tangents(encode_tangents(t)).expect("tangents");
            assert_eq!(sign, w);
            for k in 0..3 {
                worst = worst.min(got[k].dot(t[k].truncate()));
            }
        }
        for axis in [Vec3::X, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z] {
            let (got, _) = decode_tangents(encode_tangents([axis.extend(1.0); 3])).unwrap();
            assert!(got.iter().all(|g| g.dot(axis) > 0.99999), "{axis}: {got:?}");
        }
        assert!(worst > 0.25f32.to_radians().cos(), "worst cosine {worst}");
    }

    #[test]
    fn the_denoiser_reaches_less_far_as_samples_grow_and_ends_in_the_first_image() {
        let passes: Vec<u32> = [1, 2, 3, 8, 9, 32, 33, 128, 129, 100_000]
            .iter()
            .map(|&n| denoise_passes(n))
            .collect();
        assert_eq!(passes, [6, 6, 5, 5, 4, 4, 3, 3, 2, 2]);
        for n in 2..=DENOISE_PASSES {
            // The last pass writes the first image, and only the last: the result stays whole
            // while a run is spread over frames. Each pass reads what the one before wrote.
            assert_eq!(denoise_target(n - 1, n), 0);
            for k in 0..n {
                let t = denoise_target(k, n);
                assert!(t < DENOISE_IMAGES);
                assert_ne!(denoise_source(t), t);
                assert_eq!(t == 0, k == n - 1, "pass {k} of {n}");
                if k > 0 {
                    assert_eq!(
                        denoise_source(t),
                        denoise_target(k - 1, n),
                        "pass {k} of {n}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_denoiser_s_tap_words_are_its_kernel_s() {
        let kernel = include_str!("../../shaders/denoise.wgsl");
        assert!(kernel.contains(&format!("const TAP_WORDS: u32 = {DENOISE_TAP_WORDS}u;")));
    }

    #[test]
    fn the_guides_words_are_the_kernels() {
        let layout = include_str!("../../shaders/guide_layout.wgsl");
        assert!(layout.contains(&format!("const GUIDE_WORDS: u32 = {GUIDE_WORDS}u;")));
        assert_eq!(guide_bytes(3, 2), 6 * GUIDE_WORDS * 4);
    }

    #[test]
    fn an_object_known_by_another_slot_draws_the_same() {
        let plain = object_bytes(
            Mat3::IDENTITY,
            &SurfaceMaterial::default(),
            &mut MapTransformTable::default(),
        );
        let known = with_identity(plain.clone(), Some(7));
        assert_ne!(known, plain);
        assert!(same_drawing(&known, &plain));
        let record: GpuObject = bytemuck::pod_read_unaligned(&known);
        assert_eq!(record.identity, 7);
        assert_eq!(with_identity(known, None), plain);
        let red = SurfaceMaterial {
            base_color: [1.0, 0.0, 0.0, 1.0],
            ..Default::default()
        };
        assert!(!same_drawing(
            &object_bytes(Mat3::IDENTITY, &red, &mut MapTransformTable::default()),
            &plain
        ));
    }

    #[test]
    fn records_have_the_shader_sizes() {
        assert_eq!(
            object_bytes(
                Mat3::IDENTITY,
                &SurfaceMaterial::default(),
                &mut MapTransformTable::default()
            )
            .len() as u64,
            OBJECT_BYTES
        );
        let l = SceneLight::Directional {
            direction: Vec3::NEG_Y,
            illuminance: Vec3::ONE,
        };
        assert_eq!(light_bytes(&l).len() as u64, LIGHT_BYTES);
        let v = ViewParams {
            world_from_clip: Mat4::IDENTITY,
            origin: Vec3::ZERO,
            sky: Vec3::ZERO,
            exposure: 1.0,
            width: 1,
            height: 1,
            root: 0,
            max_bounces: 1,
            samples: 1,
            mode: 0,
            light_count: 0,
            emitters: (0, 0.0),
            indirect_clamp: 0.0,
            work: TraceWork::Tiles { start: 0, count: 1 },
            part_shift: 30,
            seed: 0,
            environment: Vec4::ZERO,
        };
        assert_eq!(v.to_bytes().len() as u64, VIEW_BYTES);
    }

    #[test]
    fn normal_matrix_keeps_normals_perpendicular_under_non_uniform_scale() {
        let m = Mat3::from_diagonal(Vec3::new(4.0, 1.0, 1.0)) * Mat3::from_rotation_z(0.3);
        let bytes = object_bytes(
            m,
            &SurfaceMaterial::default(),
            &mut MapTransformTable::default(),
        );
        let f = |k: usize| f32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().unwrap());
        let rows = [0, 4, 8].map(|o| Vec3::new(f(o), f(o + 1), f(o + 2)));
        let apply = |v: Vec3| Vec3::new(rows[0].dot(v), rows[1].dot(v), rows[2].dot(v));
        // A surface spanned by two tangents, and its normal.
        let (t1, t2) = (Vec3::new(1.0, 0.2, 0.0), Vec3::new(0.0, 0.3, 1.0));
        let n = t1.cross(t2);
        let nw = apply(n);
        assert!(nw.dot(m * t1).abs() < 1e-4 && nw.dot(m * t2).abs() < 1e-4);
    }
}
