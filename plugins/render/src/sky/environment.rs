//! The sky as an equirectangular panorama ([`PathTracedEnvironment`]): every path-traced view sees
//! it where rays leave the scene, and each bounce samples it directly, in proportion to its
//! brightness (a piecewise-constant distribution over a grid of cells, the marginal over rows and
//! each row's conditional), weighed against the BSDF's own samples by multiple importance sampling.
//!
//! The main world turns the image into [`EnvironmentTexels`] on a thread of its own (half floats and
//! the distribution's cumulative sums); extraction hands them over; the render world uploads them
//! into a texture and the distribution into a second one, bound in the scene's group.

use bevy::asset::AssetEvent;
use bevy::prelude::*;
use bevy::render::render_resource::{
    AddressMode, Extent3d, FilterMode, Origin3d, Sampler, SamplerDescriptor, TexelCopyBufferLayout,
    TexelCopyTextureInfo, TextureAspect, TextureDescriptor, TextureDimension, TextureFormat,
    TextureUsages, TextureView, TextureViewDescriptor,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::{Extract, ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems};
use std::f32::consts::{PI, TAU};
use std::sync::{Arc, OnceLock};

/// A conversion's result, set by its thread once (`None`: the image could not be read).
type Conversion = Arc<OnceLock<Option<Arc<EnvironmentTexels>>>>;

pub use crate::types::bindings::ENVIRONMENT_BINDINGS;

/// Widest distribution grid: enough cells that a small sun gets cells of its own.
pub const MAX_DISTRIBUTION_WIDTH: u32 = 512;

/// Largest value kept in the half-float texture; brighter panoramas are stored scaled down.
const HALF_CEILING: f32 = 60_000.0;

/// An environment panorama lighting every [`PathTraced`](crate::types::view::PathTraced) view, in place of the
/// views' flat `sky` colour.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct PathTracedEnvironment {
    /// An equirectangular panorama of linear radiance (any format [`Image::get_color_at`] reads;
    /// `Rgba32Float` is read fastest): rows from the zenith down, the middle column looking along
    /// −Z. `None`: the views' `sky` colours.
    pub image: Option<Handle<Image>>,
    /// Turn about +Y, radians, counter-clockwise seen from above.
    pub rotation: f32,
    /// Multiplies the panorama's radiance.
    pub intensity: f32,
    /// Whether rays from the camera that leave the scene see the panorama; hidden, they see the
    /// view's `sky` colour, while the panorama still lights the scene.
    pub shown: bool,
}

impl Default for PathTracedEnvironment {
    fn default() -> Self {
        Self {
            image: None,
            rotation: 0.0,
            intensity: 1.0,
            shown: true,
        }
    }
}

/// A panorama ready for the GPU: half-float texels and the sampling distribution.
#[derive(Clone, PartialEq)]
pub struct EnvironmentTexels {
    /// The panorama's width and height.
    pub width: u32,
    /// Its height.
    pub height: u32,
    /// RGBA half floats (as bits), `width * height * 4`; radiance is these times `scale`.
    pub rgba16: Vec<u16>,
    /// What the stored values are multiplied by (1 unless the panorama is brighter than a half
    /// float holds).
    pub scale: f32,
    /// The distribution's cells across and down.
    pub cells: [u32; 2],
    /// `(cells[0] + 1) * cells[1]` values, a row per cell row: the row's conditional cumulative
    /// distribution over its cells (each the sum up to and including it, the last 1), then the
    /// marginal's cumulative sum up to and including the row.
    pub cdf: Vec<f32>,
    /// Whether any cell is bright (a black panorama is not sampled).
    pub sampled: bool,
}

impl std::fmt::Debug for EnvironmentTexels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "EnvironmentTexels({}×{})", self.width, self.height)
    }
}

/// The panorama's direction at `(u, v)` (0..1 across, 0..1 down), before its rotation: v = 0 is
/// +Y, u = 0.5 looks along −Z, u = 0.75 along +X (as `treelight_import::direction_of`).
pub fn panorama_direction(u: f32, v: f32) -> Vec3 {
    let (st, ct) = (v * PI).sin_cos();
    let (sp, cp) = ((u - 0.5) * TAU).sin_cos();
    Vec3::new(st * sp, ct, -st * cp)
}

/// The panorama coordinates of a unit direction (before rotation).
pub fn panorama_coordinates(d: Vec3) -> Vec2 {
    Vec2::new(
        0.5 + d.x.atan2(-d.z) / TAU,
        d.y.clamp(-1.0, 1.0).acos() / PI,
    )
}

fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Each texel's luminance as the kernel's bilinear sampler spreads it: the mean of the filtered
/// image over the texel's square, which takes 3/4 of the texel and 1/8 of each neighbour along each
/// axis (wrapping around the horizon, holding the poles). A bright texel's light reaches half a
/// texel into its neighbours; built from the texels alone, the distribution would leave that
/// light to the BSDF's samples, which find a small sun only by chance.
fn filtered_luminance(rgb: &[[f32; 3]], width: u32, height: u32) -> Vec<f32> {
    let (w, h) = (width as usize, height as usize);
    let lum: Vec<f32> = rgb.iter().map(|&c| luminance(c)).collect();
    let mut across = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let left = lum[y * w + (x + w - 1) % w];
            let right = lum[y * w + (x + 1) % w];
            across[y * w + x] = 0.75 * lum[y * w + x] + 0.125 * (left + right);
        }
    }
    let mut out = vec![0.0f32; w * h];
    for y in 0..h {
        let (up, down) = (y.saturating_sub(1), (y + 1).min(h - 1));
        for x in 0..w {
            out[y * w + x] =
                0.75 * across[y * w + x] + 0.125 * (across[up * w + x] + across[down * w + x]);
        }
    }
    out
}

impl EnvironmentTexels {
    /// The panorama of `width × height` texels that `texel(x, y)` gives (linear RGB; anything not
    /// finite or negative counts as black).
    pub fn new(width: u32, height: u32, texel: impl Fn(u32, u32) -> [f32; 3]) -> Self {
        let (width, height) = (width.max(1), height.max(1));
        let mut rgb = Vec::with_capacity((width * height) as usize);
        let mut brightest = 0.0f32;
        for y in 0..height {
            for x in 0..width {
                let c = texel(x, y).map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 });
                brightest = brightest.max(c[0].max(c[1]).max(c[2]));
                rgb.push(c);
            }
        }
        let scale = (brightest / HALF_CEILING).max(1.0);
        let rgba16 = rgb
            .iter()
            .flat_map(|c| {
                let [r, g, b] = c.map(|v| half::f16::from_f32(v / scale).to_bits());
                [r, g, b, half::f16::ONE.to_bits()]
            })
            .collect();
        let cw = width.min(MAX_DISTRIBUTION_WIDTH);
        let ch = height.clamp(1, MAX_DISTRIBUTION_WIDTH / 2);
        let lit = filtered_luminance(&rgb, width, height);
        // Each cell's mean luminance, times the solid angle its rows cover (sin θ).
        let mut weight = vec![0.0f64; (cw * ch) as usize];
        let mut count = vec![0u32; (cw * ch) as usize];
        for y in 0..height {
            let cy = (u64::from(y) * u64::from(ch) / u64::from(height)) as u32;
            for x in 0..width {
                let cx = (u64::from(x) * u64::from(cw) / u64::from(width)) as u32;
                let i = (cy * cw + cx) as usize;
                weight[i] += f64::from(lit[(y * width + x) as usize]);
                count[i] += 1;
            }
        }
        let row_stride = (cw + 1) as usize;
        let mut cdf = vec![0.0f32; row_stride * ch as usize];
        let mut rows = vec![0.0f64; ch as usize];
        for cy in 0..ch as usize {
            let sin = ((cy as f64 + 0.5) / f64::from(ch) * std::f64::consts::PI).sin();
            let mut sum = 0.0;
            for cx in 0..cw as usize {
                let i = cy * cw as usize + cx;
                sum += weight[i] / f64::from(count[i].max(1)) * sin;
                cdf[cy * row_stride + cx] = sum as f32;
            }
            rows[cy] = sum;
            for cx in 0..cw as usize {
                let v = &mut cdf[cy * row_stride + cx];
                // A black row is sampled uniformly, should the marginal ever pick it.
                *v = if sum > 0.0 {
                    (f64::from(*v) / sum) as f32
                } else {
                    (cx + 1) as f32 / cw as f32
                };
            }
            cdf[cy * row_stride + cw as usize - 1] = 1.0;
        }
        let total: f64 = rows.iter().sum();
        let mut running = 0.0;
        for (cy, r) in rows.iter().enumerate() {
            running += r;
            cdf[cy * row_stride + cw as usize] = if total > 0.0 {
                (running / total) as f32
            } else {
                (cy + 1) as f32 / ch as f32
            };
        }
        cdf[(ch as usize - 1) * row_stride + cw as usize] = 1.0;
        Self {
            width,
            height,
            rgba16,
            scale,
            cells: [cw, ch],
            cdf,
            sampled: total > 0.0,
        }
    }

    /// The panorama from a Bevy image (`None` if it has no pixel data or a format that cannot be
    /// read).
    pub fn from_image(image: &Image) -> Option<Self> {
        let (w, h) = (image.width(), image.height());
        let data = image.data.as_ref()?;
        if image.texture_descriptor.format == TextureFormat::Rgba32Float
            && data.len() >= (w * h * 16) as usize
        {
            let floats: &[f32] = bytemuck::try_cast_slice(&data[..(w * h * 16) as usize]).ok()?;
            return Some(Self::new(w, h, |x, y| {
                let i = ((y * w + x) * 4) as usize;
                [floats[i], floats[i + 1], floats[i + 2]]
            }));
        }
        image.get_color_at(0, 0).ok()?;
        Some(Self::new(w, h, |x, y| {
            let c = image
                .get_color_at(x, y)
                .map(|c| c.to_linear())
                .unwrap_or(LinearRgba::BLACK);
            [c.red, c.green, c.blue]
        }))
    }

    fn cdf_at(&self, x: u32, y: u32) -> f32 {
        self.cdf[(y * (self.cells[0] + 1) + x) as usize]
    }

    /// The probability of cell `(x, y)`.
    fn cell_probability(&self, x: u32, y: u32) -> f32 {
        let cw = self.cells[0];
        let row = self.cdf_at(cw, y) - if y > 0 { self.cdf_at(cw, y - 1) } else { 0.0 };
        let cell = self.cdf_at(x, y) - if x > 0 { self.cdf_at(x - 1, y) } else { 0.0 };
        row * cell
    }

    /// The density (per steradian) of [`Self::sample`] drawing the unrotated direction `d`, as
    /// the kernel computes it.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let [cw, ch] = self.cells;
        let uv = panorama_coordinates(d);
        let x = ((uv.x.rem_euclid(1.0) * cw as f32) as u32).min(cw - 1);
        let y = ((uv.y * ch as f32) as u32).min(ch - 1);
        let sin = (uv.y * PI).sin();
        if sin <= 0.0 {
            return 0.0;
        }
        self.cell_probability(x, y) * (cw * ch) as f32 / (2.0 * PI * PI * sin)
    }

    /// The unrotated direction drawn for the uniform numbers `r` (as the kernel draws it).
    pub fn sample(&self, r: Vec2) -> Vec3 {
        let [cw, ch] = self.cells;
        let search = |n: u32, value: f32, at: &dyn Fn(u32) -> f32| {
            let (mut lo, mut hi) = (0u32, n - 1);
            while lo < hi {
                let mid = (lo + hi) / 2;
                if at(mid) > value {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            lo
        };
        let y = search(ch, r.y, &|i| self.cdf_at(cw, i));
        let below = if y > 0 { self.cdf_at(cw, y - 1) } else { 0.0 };
        let fy = ((r.y - below) / (self.cdf_at(cw, y) - below)).clamp(0.0, 0.999_999);
        let x = search(cw, r.x, &|i| self.cdf_at(i, y));
        let left = if x > 0 { self.cdf_at(x - 1, y) } else { 0.0 };
        let fx = ((r.x - left) / (self.cdf_at(x, y) - left)).clamp(0.0, 0.999_999);
        panorama_direction((x as f32 + fx) / cw as f32, (y as f32 + fy) / ch as f32)
    }
}

/// The main world's copy of the panorama as the path tracer takes it, made from
/// [`PathTracedEnvironment::image`] on a thread of its own.
#[derive(Resource, Default)]
pub struct PreparedEnvironment {
    /// Counts the panoramas prepared, so the render world knows when to upload.
    generation: u64,
    texels: Option<Arc<EnvironmentTexels>>,
    /// The image the texels are from.
    source: Option<AssetId<Image>>,
    /// A conversion under way on its own thread.
    pending: Option<(AssetId<Image>, Conversion)>,
}

impl PreparedEnvironment {
    /// Whether the panorama `environment` names is ready for the views (or none is named): a
    /// render that must show it waits for this.
    pub fn ready_for(&self, environment: &PathTracedEnvironment) -> bool {
        match &environment.image {
            None => self.pending.is_none() && self.source.is_none(),
            Some(handle) => self.pending.is_none() && self.source == Some(handle.id()),
        }
    }
}

pub(crate) fn build(app: &mut App) {
    app.init_resource::<PathTracedEnvironment>()
        .init_resource::<PreparedEnvironment>()
        .add_systems(PostUpdate, prepare_texels);
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .init_resource::<ExtractedEnvironment>()
        .add_systems(RenderStartup, init_gpu_environment)
        .add_systems(ExtractSchedule, extract_environment)
        .add_systems(
            Render,
            upload_environment.in_set(RenderSystems::PrepareResources),
        );
}

/// Starts converting the image when it or the resource's handle changed, and takes the result.
fn prepare_texels(
    environment: Res<PathTracedEnvironment>,
    images: Res<Assets<Image>>,
    mut events: MessageReader<AssetEvent<Image>>,
    mut prepared: ResMut<PreparedEnvironment>,
) {
    let wanted = environment.image.as_ref().map(Handle::id);
    let modified = events.read().any(|e| match e {
        AssetEvent::Modified { id } | AssetEvent::Added { id } => Some(*id) == wanted,
        _ => false,
    });
    if let Some((id, slot)) = &prepared.pending {
        let id = *id;
        if Some(id) != wanted {
            prepared.pending = None;
        } else if let Some(texels) = slot.get() {
            prepared.texels = texels.clone();
            prepared.source = Some(id);
            prepared.generation += 1;
            prepared.pending = None;
        }
    }
    let Some(id) = wanted else {
        if prepared.texels.is_some() || prepared.source.is_some() {
            prepared.texels = None;
            prepared.source = None;
            prepared.pending = None;
            prepared.generation += 1;
        }
        return;
    };
    let current = prepared.source == Some(id) && !modified;
    let converting = prepared.pending.as_ref().is_some_and(|(p, _)| *p == id) && !modified;
    if current || converting {
        return;
    }
    // Not loaded yet: an Added or Modified message starts the conversion when it is.
    let Some(image) = images.get(id) else {
        return;
    };
    let image = image.clone();
    let slot = Conversion::default();
    let result = slot.clone();
    let spawned = std::thread::Builder::new()
        .name("treelight environment".into())
        .spawn(move || {
            // A panic converting the image leaves the flat sky, not a conversion that never ends.
            let texels = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                EnvironmentTexels::from_image(&image)
            }))
            .ok()
            .flatten();
            let _ = result.set(texels.map(Arc::new));
        });
    if spawned.is_ok() {
        prepared.pending = Some((id, slot));
    }
}

/// The panorama and its settings in the render world.
#[derive(Resource, Default)]
pub(crate) struct ExtractedEnvironment {
    pub generation: u64,
    pub texels: Option<Arc<EnvironmentTexels>>,
    pub rotation: f32,
    pub intensity: f32,
    pub shown: bool,
}

impl ExtractedEnvironment {
    /// The view uniform's environment word ([`environment_uniform`]).
    pub fn uniform(&self) -> Vec4 {
        environment_uniform(
            self.texels.as_deref(),
            self.rotation,
            self.intensity,
            self.shown,
        )
    }
}

/// The view uniform's environment word for a panorama (`None`: the flat sky colour) turned by
/// `rotation` and scaled by `intensity`: cos and sin of the rotation, the radiance scale, and flags
/// as a whole number (1: a panorama, 2: shown to the camera, 4: sampled).
pub fn environment_uniform(
    texels: Option<&EnvironmentTexels>,
    rotation: f32,
    intensity: f32,
    shown: bool,
) -> Vec4 {
    let Some(texels) = texels else {
        return Vec4::ZERO;
    };
    let intensity = if intensity.is_finite() {
        intensity.max(0.0)
    } else {
        0.0
    };
    let flags = 1 | if shown { 2 } else { 0 } | if texels.sampled { 4 } else { 0 };
    let rotation = if rotation.is_finite() { rotation } else { 0.0 };
    Vec4::new(
        rotation.cos(),
        rotation.sin(),
        intensity * texels.scale,
        flags as f32,
    )
}

fn extract_environment(
    environment: Extract<Res<PathTracedEnvironment>>,
    prepared: Extract<Res<PreparedEnvironment>>,
    mut extracted: ResMut<ExtractedEnvironment>,
) {
    if extracted.generation != prepared.generation {
        extracted.generation = prepared.generation;
        extracted.texels = prepared.texels.clone();
    }
    extracted.rotation = environment.rotation;
    extracted.intensity = environment.intensity;
    extracted.shown = environment.shown;
}

/// The panorama's textures and sampler on the GPU.
#[derive(Resource)]
pub(crate) struct GpuEnvironment {
    /// The extraction generation uploaded.
    generation: u64,
    /// Counts uploads, so the scene's bind group is made again.
    pub version: u64,
    pub image: TextureView,
    pub sampler: Sampler,
    pub distribution: TextureView,
}

fn texture(
    device: &RenderDevice,
    label: &'static str,
    size: [u32; 2],
    format: TextureFormat,
) -> bevy::render::render_resource::Texture {
    device.create_texture(&TextureDescriptor {
        label: Some(label),
        size: Extent3d {
            width: size[0],
            height: size[1],
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: TextureDimension::D2,
        format,
        usage: TextureUsages::TEXTURE_BINDING | TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

fn write(
    queue: &RenderQueue,
    texture: &bevy::render::render_resource::Texture,
    bytes: &[u8],
    bytes_per_texel: u32,
) {
    let size = texture.size();
    queue.write_texture(
        TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: Origin3d::ZERO,
            aspect: TextureAspect::All,
        },
        bytes,
        TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(size.width * bytes_per_texel),
            rows_per_image: Some(size.height),
        },
        size,
    );
}

/// The panorama's textures for `texels`, or 1×1 stand-ins without one.
fn make_textures(
    device: &RenderDevice,
    queue: &RenderQueue,
    texels: Option<&EnvironmentTexels>,
) -> (TextureView, TextureView) {
    let (size, rgba, cells, cdf): ([u32; 2], &[u16], [u32; 2], &[f32]) = match texels {
        Some(t) => ([t.width, t.height], &t.rgba16, t.cells, &t.cdf),
        None => ([1, 1], &[0, 0, 0, 0], [1, 1], &[1.0, 1.0]),
    };
    let image = texture(
        device,
        "treelight environment",
        size,
        TextureFormat::Rgba16Float,
    );
    write(queue, &image, bytemuck::cast_slice(rgba), 8);
    let distribution = texture(
        device,
        "treelight environment distribution",
        [cells[0] + 1, cells[1]],
        TextureFormat::R32Float,
    );
    write(queue, &distribution, bytemuck::cast_slice(cdf), 4);
    (
        image.create_view(&TextureViewDescriptor::default()),
        distribution.create_view(&TextureViewDescriptor::default()),
    )
}

/// The panorama's sampler: around the horizon the panorama wraps; at the poles it holds its edge.
pub(crate) fn sampler_descriptor() -> SamplerDescriptor<'static> {
    SamplerDescriptor {
        label: Some("treelight environment"),
        address_mode_u: AddressMode::Repeat,
        address_mode_v: AddressMode::ClampToEdge,
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        ..default()
    }
}

fn init_gpu_environment(
    mut commands: Commands,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    let (image, distribution) = make_textures(&device, &queue, None);
    let sampler = device.create_sampler(&sampler_descriptor());
    commands.insert_resource(GpuEnvironment {
        generation: 0,
        version: 0,
        image,
        sampler,
        distribution,
    });
}

fn upload_environment(
    extracted: Res<ExtractedEnvironment>,
    gpu: Option<ResMut<GpuEnvironment>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    let Some(mut gpu) = gpu else {
        return;
    };
    if gpu.generation == extracted.generation {
        return;
    }
    let (image, distribution) = make_textures(&device, &queue, extracted.texels.as_deref());
    gpu.image = image;
    gpu.distribution = distribution;
    gpu.generation = extracted.generation;
    gpu.version += 1;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dim sky with a small bright sun.
    fn sun_sky() -> EnvironmentTexels {
        EnvironmentTexels::new(256, 128, |x, y| {
            if (100..104).contains(&x) && (30..33).contains(&y) {
                [5000.0, 4000.0, 3000.0]
            } else {
                [0.2, 0.3, (y as f32 / 128.0)]
            }
        })
    }

    #[test]
    fn the_density_integrates_to_one_over_the_sphere() {
        let env = sun_sky();
        // Midpoint rule over a fine grid of directions, each weighted by its solid angle.
        let (n, m) = (2048, 1024);
        let mut sum = 0.0f64;
        for j in 0..m {
            let v = (j as f32 + 0.5) / m as f32;
            let solid = (v * PI).sin() as f64 * (PI as f64 / m as f64) * (TAU as f64 / n as f64);
            for i in 0..n {
                let u = (i as f32 + 0.5) / n as f32;
                sum += env.pdf(panorama_direction(u, v)) as f64 * solid;
            }
        }
        assert!((sum - 1.0).abs() < 0.01, "{sum}");
    }

    #[test]
    fn samples_fall_where_the_density_says() {
        let env = sun_sky();
        // The sun's cells: the share of samples in them matches their probability.
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let n = 200_000;
        let mut in_sun = 0;
        let mut mismatch = 0.0f32;
        for _ in 0..n {
            let d = env.sample(Vec2::new(next(), next()));
            assert!((d.length() - 1.0).abs() < 1e-4);
            let uv = panorama_coordinates(d);
            let (x, y) = ((uv.x * 256.0) as u32, (uv.y * 128.0) as u32);
            if (100..104).contains(&x) && (30..33).contains(&y) {
                in_sun += 1;
            }
            mismatch = mismatch.max(if env.pdf(d) > 0.0 { 0.0 } else { 1.0 });
        }
        let expected: f32 = (100..104)
            .flat_map(|x| (30..33).map(move |y| (x, y)))
            .map(|(x, y)| env.cell_probability(x, y))
            .sum();
        let share = in_sun as f32 / n as f32;
        assert!(
            expected > 0.5,
            "the sun carries most of the light: {expected}"
        );
        assert!((share - expected).abs() < 0.01, "{share} vs {expected}");
        assert_eq!(mismatch, 0.0, "a sample where the density is zero");
    }

    #[test]
    fn a_panorama_brighter_than_half_floats_is_stored_scaled() {
        let env = EnvironmentTexels::new(4, 2, |x, _| [if x == 0 { 1e6 } else { 1.0 }; 3]);
        assert!(env.scale > 1.0);
        let back = half::f16::from_bits(env.rgba16[0]).to_f32() * env.scale;
        assert!((back - 1e6).abs() / 1e6 < 1e-3, "{back}");
        let dim = half::f16::from_bits(env.rgba16[4]).to_f32() * env.scale;
        assert!((dim - 1.0).abs() < 0.01, "{dim}");
    }

    #[test]
    fn a_black_panorama_is_not_sampled() {
        let env = EnvironmentTexels::new(8, 4, |_, _| [0.0; 3]);
        assert!(!env.sampled);
        let env = EnvironmentTexels::new(8, 4, |_, _| [f32::NAN, -1.0, f32::INFINITY]);
        assert!(!env.sampled);
    }

    #[test]
    fn the_uniform_carries_rotation_scale_and_flags() {
        let mut e = ExtractedEnvironment::default();
        assert_eq!(e.uniform(), Vec4::ZERO);
        e.texels = Some(Arc::new(sun_sky()));
        e.rotation = PI / 2.0;
        e.intensity = 2.0;
        e.shown = false;
        let u = e.uniform();
        assert!(u.x.abs() < 1e-6 && (u.y - 1.0).abs() < 1e-6 && (u.z - 2.0).abs() < 1e-6);
        assert_eq!(u.w, 5.0);
    }
}
