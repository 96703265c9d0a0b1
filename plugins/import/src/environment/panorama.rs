//! Environment images: an equirectangular panorama in Radiance HDR (`.hdr`) or OpenEXR (`.exr`),
//! read into linear RGB for a path tracer's sky. The file is checked as a scene file is (a regular
//! file, a bounded size, the header's dimensions before any pixel is decoded), and what is kept is
//! at most [`MAX_ENVIRONMENT_WIDTH`] wide: larger panoramas are box-filtered down.

use crate::files::sandbox::{open_regular, read_at_most};
use crate::scene::texture::decode_limits;
use crate::types::budget::{Budget, ImportOptions};
use crate::types::error::ImportError;
use std::io::Cursor;
use std::path::Path;

/// Widest panorama kept, in pixels (its height is half of it for a 2:1 panorama): a 4K panorama
/// seen through a normal lens is about as sharp as the screen.
pub const MAX_ENVIRONMENT_WIDTH: u32 = 4096;

/// Largest side a file may declare: a hostile header cannot ask for gigabytes of pixels.
pub const MAX_ENVIRONMENT_SIDE: u32 = 32_768;

/// Largest environment file read, bytes.
pub const MAX_ENVIRONMENT_FILE: u64 = 1 << 30;

/// A decoded panorama: `width × height` linear RGB radiance values, rows from the zenith down,
/// the middle column looking along −Z (see [`direction_of`]).
#[derive(Clone, PartialEq)]
pub struct EnvironmentImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` texels, finite and not negative.
    pub rgb: Vec<[f32; 3]>,
    /// What was changed on the way in (pixels that were not finite, a panorama shrunk, a shape
    /// that is not 2:1), for the user to read.
    pub warnings: Vec<String>,
}

impl std::fmt::Debug for EnvironmentImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "EnvironmentImage({}×{})", self.width, self.height)
    }
}

/// The world direction at panorama coordinates `(u, v)` (0..1 across, 0..1 down): `v = 0` is
/// straight up (+Y), `u = 0.5` looks along −Z and `u = 0.75` along +X.
pub fn direction_of(u: f32, v: f32) -> [f32; 3] {
    let theta = v * std::f32::consts::PI;
    let phi = (u - 0.5) * std::f32::consts::TAU;
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [st * sp, ct, -st * cp]
}

/// Panorama coordinates `(u, v)` of a unit world direction (the inverse of [`direction_of`]).
pub fn coordinates_of(d: [f32; 3]) -> (f32, f32) {
    let u = 0.5 + d[0].atan2(-d[2]) / std::f32::consts::TAU;
    let v = d[1].clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
    (u, v)
}

/// Reads an environment panorama. Errors name the file and the problem; a `.hdr` or `.exr` with
/// bad pixels loads with a warning, anything else is refused.
pub fn read_environment(path: &Path) -> Result<EnvironmentImage, ImportError> {
    read_environment_with(path, &ImportOptions::default())
}

/// [`read_environment`] within the memory budget of `options`.
pub fn read_environment_with(
    path: &Path,
    options: &ImportOptions,
) -> Result<EnvironmentImage, ImportError> {
    let mut budget = Budget::new(path, options);
    let format = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("hdr") => image::ImageFormat::Hdr,
        Some("exr") => image::ImageFormat::OpenExr,
        _ => {
            return Err(ImportError::new(
                path,
                "not an environment image: Radiance .hdr and OpenEXR .exr are read",
            ));
        }
    };
    let (handle, len) = open_regular(path, path, "file")?;
    if format == image::ImageFormat::Hdr {
        return read_radiance(path, handle, len, &mut budget);
    }
    if len > MAX_ENVIRONMENT_FILE {
        return Err(ImportError::new(
            path,
            format!(
                "the file is {} MiB, over the limit of {} MiB for an environment",
                len >> 20,
                MAX_ENVIRONMENT_FILE >> 20
            ),
        ));
    }
    let bytes = read_at_most(handle, len, len, path, "the file", &mut budget)?;
    decode_environment(path, &bytes, format, &mut budget)
}

/// A Radiance panorama, read a scanline at a time and shrunk to the width the sky keeps as it is
/// read ([`super::radiance`]): only the kept image is charged and held, whatever size the file
/// declares.
fn read_radiance(
    path: &Path,
    handle: std::fs::File,
    len: u64,
    budget: &mut Budget,
) -> Result<EnvironmentImage, ImportError> {
    use std::io::Read;
    let mut r = std::io::BufReader::new(handle.take(len));
    let (width, height) = crate::environment::radiance::read_header(&mut r, path)?;
    if width > MAX_ENVIRONMENT_SIDE || height > MAX_ENVIRONMENT_SIDE {
        return Err(ImportError::new(
            path,
            format!(
                "its header declares {width}×{height} pixels, over the limit of \
                 {MAX_ENVIRONMENT_SIDE} a side"
            ),
        ));
    }
    // The kept texels' sums (f64) and counts, the kept image, one scanline.
    let mut kept = (width, height);
    while kept.0 > MAX_ENVIRONMENT_WIDTH {
        kept = ((kept.0 / 2).max(1), (kept.1 / 2).max(1));
    }
    let texels = u64::from(kept.0) * u64::from(kept.1);
    budget.charge(texels * (24 + 4 + 12) + u64::from(width) * 4, || {
        format!("its {width}×{height} pixels, kept as {}×{}", kept.0, kept.1)
    })?;
    let image = crate::environment::radiance::read_shrunk(
        &mut r,
        path,
        (width, height),
        MAX_ENVIRONMENT_WIDTH,
    )?;
    let mut warnings = Vec::new();
    if width != 2 * height {
        warnings.push(format!(
            "it is {width}×{height}, not the 2:1 of an equirectangular panorama; it is stretched \
             over the sphere"
        ));
    }
    if (image.width, image.height) != image.declared {
        warnings.push(format!(
            "it is {width}×{height}; the sky keeps {}×{}",
            image.width, image.height
        ));
    }
    Ok(EnvironmentImage {
        width: image.width,
        height: image.height,
        rgb: image.rgb,
        warnings,
    })
}

fn decode_environment(
    path: &Path,
    bytes: &[u8],
    format: image::ImageFormat,
    budget: &mut Budget,
) -> Result<EnvironmentImage, ImportError> {
    let header =
        |e: image::ImageError| ImportError::new(path, format!("cannot read its header: {e}"));
    let (width, height) = image::ImageReader::with_format(Cursor::new(bytes), format)
        .into_dimensions()
        .map_err(header)?;
    if width == 0 || height == 0 {
        return Err(ImportError::new(path, "the image is empty"));
    }
    // The decoder's RGBA f32 image, and the RGB f32 copy.
    let limits = decode_limits(
        path,
        (width, height),
        MAX_ENVIRONMENT_SIDE,
        (28, 16 << 20),
        budget,
        || format!("its {width}×{height} pixels"),
    )?;
    let mut reader = image::ImageReader::with_format(Cursor::new(bytes), format);
    reader.limits(limits);
    let decoded = reader
        .decode()
        .map_err(|e| ImportError::new(path, format!("cannot decode: {e}")))?;
    let rgb = decoded.into_rgb32f();
    let (width, height) = rgb.dimensions();
    let mut warnings = Vec::new();
    let mut bad = 0usize;
    let mut texels: Vec<[f32; 3]> = rgb
        .pixels()
        .map(|p| {
            let c =
                p.0.map(|v| if v.is_finite() { v.max(0.0) } else { f32::NAN });
            if c.iter().any(|v| v.is_nan()) {
                bad += 1;
                [0.0; 3]
            } else {
                c
            }
        })
        .collect();
    drop(rgb);
    if bad > 0 {
        warnings.push(format!(
            "{bad} pixels were not finite numbers; they are black"
        ));
    }
    if width != 2 * height {
        warnings.push(format!(
            "it is {width}×{height}, not the 2:1 of an equirectangular panorama; it is stretched \
             over the sphere"
        ));
    }
    let (mut w, mut h) = (width, height);
    while w > MAX_ENVIRONMENT_WIDTH {
        (texels, w, h) = halve(&texels, w, h);
    }
    if w != width {
        warnings.push(format!("it is {width}×{height}; the sky keeps {w}×{h}"));
    }
    Ok(EnvironmentImage {
        width: w,
        height: h,
        rgb: texels,
        warnings,
    })
}

/// Halves a panorama's width and height (an odd last column or row folds into its neighbour):
/// the mean of each 2×2 block, so the sky's total light stays what it was.
fn halve(texels: &[[f32; 3]], w: u32, h: u32) -> (Vec<[f32; 3]>, u32, u32) {
    let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
    let mut sum = vec![[0.0f32; 3]; (nw * nh) as usize];
    let mut count = vec![0u32; (nw * nh) as usize];
    for y in 0..h {
        let ny = (y / 2).min(nh - 1);
        for x in 0..w {
            let nx = (x / 2).min(nw - 1);
            let i = (ny * nw + nx) as usize;
            let t = texels[(y * w + x) as usize];
            for c in 0..3 {
                sum[i][c] += t[c];
            }
            count[i] += 1;
        }
    }
    for (s, n) in sum.iter_mut().zip(&count) {
        *s = s.map(|v| v / *n as f32);
    }
    (sum, nw, nh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_and_coordinates_are_inverse() {
        for &(u, v) in &[(0.5, 0.5), (0.75, 0.5), (0.1, 0.2), (0.9, 0.8), (0.3, 0.01)] {
            let (u2, v2) = coordinates_of(direction_of(u, v));
            assert!(
                (u - u2).abs() < 1e-5 && (v - v2).abs() < 1e-5,
                "{u},{v} -> {u2},{v2}"
            );
        }
        let forward = direction_of(0.5, 0.5);
        assert!((forward[2] + 1.0).abs() < 1e-6);
        let right = direction_of(0.75, 0.5);
        assert!((right[0] - 1.0).abs() < 1e-6);
        assert!((direction_of(0.3, 0.0)[1] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn halving_keeps_the_mean_with_odd_sides() {
        let (w, h) = (5, 3);
        let texels: Vec<[f32; 3]> = (0..w * h).map(|i| [i as f32, 1.0, 0.0]).collect();
        let (out, nw, nh) = halve(&texels, w, h);
        assert_eq!((nw, nh), (2, 1));
        let mean_in: f32 = texels.iter().map(|t| t[0]).sum::<f32>() / (w * h) as f32;
        // Blocks of unequal size: weight each by the texels it took.
        let weights = [6.0, 9.0];
        let mean_out: f32 =
            out.iter().zip(weights).map(|(t, n)| t[0] * n).sum::<f32>() / (w * h) as f32;
        assert!((mean_in - mean_out).abs() < 1e-4);
        assert!(out.iter().all(|t| t[1] == 1.0));
    }
}
