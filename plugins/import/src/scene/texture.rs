//! The textures of glTF materials (base colour, metallic-roughness, normal, occlusion, emission):
//! images decoded once each to RGBA8, with the sampler's wrap modes. A texture that cannot be used becomes a warning and its material is drawn without it,
//! so one bad PNG does not cost the user the whole assembly.

use crate::files::sandbox::read_uri;
use crate::types::budget::Budget;
use crate::types::error::ImportError;
use gltf::texture::WrappingMode;
use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

/// Largest accepted image side, in pixels: a hostile header cannot ask for gigabytes.
pub const MAX_TEXTURE_SIDE: u32 = 16_384;

/// The largest side an image is kept at once decoded: the raster view draws it at most so (the
/// path tracer keeps 1024 texels a side), so a larger one is scaled down as it is read.
pub const MAX_KEPT_TEXTURE_SIDE: u32 = 4096;

/// How texture coordinates outside 0..1 fold back into the image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum WrapMode {
    /// Tile (glTF's default).
    #[default]
    Repeat,
    /// Hold the edge texel.
    ClampToEdge,
    /// Tile, every other copy mirrored.
    MirroredRepeat,
}

/// A decoded image: `width × height` RGBA8 pixels, rows top to bottom, colour sRGB-encoded as stored.
#[derive(Clone, PartialEq)]
pub struct ImportedTexture {
    /// The image's name or URI, for messages and editor labels.
    pub name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba8: Vec<u8>,
}

impl std::fmt::Debug for ImportedTexture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Millions of pixel bytes would drown any assertion message.
        write!(
            f,
            "ImportedTexture({:?}, {}×{})",
            self.name, self.width, self.height
        )
    }
}

/// A material's use of a texture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into `ImportedScene::textures`.
    pub texture: usize,
    /// Wrap modes along u and v.
    pub wrap: [WrapMode; 2],
    /// The map from the mesh's UVs to the texture's (`KHR_texture_transform`), as the columns of a
    /// 2×3 affine matrix: x axis, y axis, translation. The identity without the extension.
    pub uv_transform: [[f32; 2]; 3],
    /// The set of texture coordinates it reads: 0 (`MeshGeometry::uvs`) or 1
    /// (`MeshGeometry::uvs1`).
    pub tex_coord: u32,
}

/// The identity UV map.
pub const UV_IDENTITY: [[f32; 2]; 3] = [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]];

/// `KHR_texture_transform`'s offset, rotation and scale as one affine map: translation × rotation ×
/// scale, the rotation turning UVs counter-clockwise by `rotation` radians as the extension defines.
pub fn uv_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> [[f32; 2]; 3] {
    let (sin, cos) = rotation.sin_cos();
    [
        [cos * scale[0], -sin * scale[0]],
        [sin * scale[1], cos * scale[1]],
        offset,
    ]
}

/// Where an image's bytes come from: one image may be named by many glTF images (a file of
/// 100,000 images of one PNG is one decode).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum ImageSource {
    /// A buffer view, by index.
    View(usize),
    /// A file beside the opened one, by its URI.
    File(String),
    /// A data URI, by its length and hash (the text itself may be large).
    Data(usize, u64),
}

impl ImageSource {
    fn of(image: &gltf::Image) -> Self {
        match image.source() {
            gltf::image::Source::View { view, .. } => Self::View(view.index()),
            gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
                use std::hash::{Hash, Hasher};
                let mut h = std::collections::hash_map::DefaultHasher::new();
                uri.hash(&mut h);
                Self::Data(uri.len(), h.finish())
            }
            gltf::image::Source::Uri { uri, .. } => Self::File(uri.to_owned()),
        }
    }
}

/// Images decoded so far, by where their bytes come from (`None`: it failed and was reported).
#[derive(Default)]
pub(crate) struct ImageCache {
    decoded: HashMap<ImageSource, Option<usize>>,
}

impl ImageCache {
    /// The texture reference for one of a material's maps (`role` names it in warnings: "normal
    /// map"), read with UV set `tex_coord` through `map` (`KHR_texture_transform`), decoding its
    /// image on first use. A texture that cannot be used is a warning (`Ok(None)`); one that would
    /// pass the import's memory budget refuses the file.
    #[allow(clippy::too_many_arguments)]
    pub fn map(
        &mut self,
        path: &Path,
        buffers: &[Vec<u8>],
        texture: gltf::Texture,
        tex_coord: u32,
        map: [[f32; 2]; 3],
        role: &str,
        textures: &mut Vec<ImportedTexture>,
        warnings: &mut Vec<String>,
        budget: &mut Budget,
    ) -> Result<Option<TextureRef>, ImportError> {
        let image = texture.source();
        let name = image
            .name()
            .map(str::to_owned)
            .or_else(|| match image.source() {
                gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => {
                    Some(uri.to_owned())
                }
                _ => None,
            })
            .unwrap_or_else(|| format!("image {}", image.index()));
        if tex_coord > 1 {
            warnings.push(format!(
                "{role} '{name}' uses texture coordinate set {tex_coord}, only sets 0 and 1 are \
                 read; its material is drawn without it"
            ));
            return Ok(None);
        }
        if map.iter().flatten().any(|v| !v.is_finite()) {
            warnings.push(format!(
                "{role} '{name}' has a non-finite KHR_texture_transform; its material is drawn \
                 without it"
            ));
            return Ok(None);
        }
        let source = ImageSource::of(&image);
        let slot = match self.decoded.get(&source) {
            Some(&slot) => slot,
            None => {
                let slot = match decode(path, buffers, &image, &name, budget) {
                    Ok(t) => {
                        textures.push(t);
                        Some(textures.len() - 1)
                    }
                    Err(e) if budget.refused() => return Err(e),
                    Err(e) => {
                        warnings.push(format!(
                            "texture '{name}': {}; its materials are drawn without it",
                            e.problem
                        ));
                        None
                    }
                };
                self.decoded.insert(source, slot);
                slot
            }
        };
        let Some(index) = slot else {
            return Ok(None);
        };
        let sampler = texture.sampler();
        Ok(Some(TextureRef {
            texture: index,
            wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
            uv_transform: map,
            tex_coord,
        }))
    }
}

fn wrap(mode: WrappingMode) -> WrapMode {
    match mode {
        WrappingMode::Repeat => WrapMode::Repeat,
        WrappingMode::ClampToEdge => WrapMode::ClampToEdge,
        WrappingMode::MirroredRepeat => WrapMode::MirroredRepeat,
    }
}

/// The image's bytes (a buffer view, a data URI or a file beside the opened one), decoded.
fn decode(
    path: &Path,
    buffers: &[Vec<u8>],
    image: &gltf::Image,
    name: &str,
    budget: &mut Budget,
) -> Result<ImportedTexture, ImportError> {
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let start = view.offset();
            let end = start.checked_add(view.length());
            let bytes = buffers
                .get(view.buffer().index())
                .and_then(|b| b.get(start..end?))
                .ok_or_else(|| ImportError::new(path, "its buffer view reads past the buffer"))?;
            decode_bytes(path, bytes, name, budget)
        }
        gltf::image::Source::Uri { uri, .. } => {
            let dir = path.parent().unwrap_or(Path::new("."));
            let bytes = read_uri(path, dir, uri, "image", u64::MAX, budget)?;
            decode_bytes(path, &bytes, name, budget)
        }
    }
}

/// The decoder's limits for an image whose header declares `size`: refused past `max_side` a side,
/// its decoded `bytes_per_pixel` charged to `budget` (as `what`) before any pixel is decoded, and the
/// decoder held to that much and `scratch` bytes for its own use.
pub(crate) fn decode_limits(
    path: &Path,
    (width, height): (u32, u32),
    max_side: u32,
    (bytes_per_pixel, scratch): (u64, u64),
    budget: &mut Budget,
    what: impl FnOnce() -> String,
) -> Result<image::Limits, ImportError> {
    if width > max_side || height > max_side {
        return Err(ImportError::new(
            path,
            format!(
                "its header declares {width}×{height} pixels, over the limit of {max_side} a side"
            ),
        ));
    }
    let bytes = u64::from(width) * u64::from(height) * bytes_per_pixel;
    budget.charge(bytes, what)?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(max_side);
    limits.max_image_height = Some(max_side);
    limits.max_alloc = Some(bytes + scratch);
    Ok(limits)
}

/// Decodes PNG or JPEG bytes: the header's dimensions are checked against [`MAX_TEXTURE_SIDE`]
/// and the decoded size charged to `budget` before any pixel is decoded.
pub(crate) fn decode_bytes(
    path: &Path,
    bytes: &[u8],
    name: &str,
    budget: &mut Budget,
) -> Result<ImportedTexture, ImportError> {
    let open = || {
        image::ImageReader::new(Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| ImportError::new(path, format!("cannot read its header: {e}")))
    };
    let probe = open()?;
    if probe.format().is_none() {
        return Err(ImportError::new(
            path,
            "not a PNG or JPEG image (KTX2 and other formats are not supported)",
        ));
    }
    let (width, height) = probe
        .into_dimensions()
        .map_err(|e| ImportError::new(path, format!("cannot read its header: {e}")))?;
    let declared = (width, height);
    // The decoder's image (up to 16-bit RGBA) and the RGBA8 copy made of any other layout.
    let limits = decode_limits(
        path,
        (width, height),
        MAX_TEXTURE_SIDE,
        (12, 1 << 20),
        budget,
        || format!("image '{name}' ({width}×{height})"),
    )?;
    let mut reader = open()?;
    reader.limits(limits);
    let decoded = reader
        .decode()
        .map_err(|e| ImportError::new(path, format!("cannot decode: {e}")))?;
    let mut rgba = decoded.into_rgba8();
    let (mut width, mut height) = rgba.dimensions();
    if width == 0 || height == 0 {
        return Err(ImportError::new(path, "the image is empty"));
    }
    if width.max(height) > MAX_KEPT_TEXTURE_SIDE {
        let scale = MAX_KEPT_TEXTURE_SIDE as f64 / f64::from(width.max(height));
        let w = ((f64::from(width) * scale).round() as u32).max(1);
        let h = ((f64::from(height) * scale).round() as u32).max(1);
        rgba = image::imageops::resize(&rgba, w, h, image::imageops::FilterType::Triangle);
        (width, height) = (w, h);
    }
    // The decoder's full-size images are gone: only the kept one stays charged.
    let charged = u64::from(declared.0) * u64::from(declared.1) * 12;
    budget.release(charged.saturating_sub(u64::from(width) * u64::from(height) * 4));
    Ok(ImportedTexture {
        name: name.to_owned(),
        width,
        height,
        rgba8: rgba.into_raw(),
    })
}
