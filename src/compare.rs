//! `treelight compare REFERENCE IMAGE... [--residuals DIR]`: how far images are from a reference
//! of the same frame (a render at many samples). Four figures an image:
//!
//! - **linear**: the relative mean squared error (the sum of squared differences over the sum of
//!   the reference's squares) of linear colour, decoded from the PNGs' sRGB;
//! - **display**: the same of the 8-bit values a user sees (sRGB, as stored);
//! - **detail**: the display figure over the reference's detail only, the tenth of its pixels
//!   where its luminance changes most from pixel to pixel (texture and geometric edges): what a
//!   filter that blurs loses first;
//! - **ssim**: the mean structural similarity of the display luminance (Wang et al. 2004, 11 × 11
//!   Gaussian windows of σ 1.5), 1 for an image equal to the reference.
//!
//! With `--residuals`, each image's signed difference from the reference is drawn to
//! `DIR/<image>-residual.png`: red where the image is brighter, blue where darker, eight times
//! the display difference, so a blur shows as the pattern of the detail it lost.

use std::io::Cursor;
use std::path::{Path, PathBuf};

/// Largest image side read: a hostile header cannot ask for gigabytes.
const MAX_SIDE: u32 = 16_384;
/// Largest image file read (a PNG of the largest side is far smaller in practice).
const MAX_FILE_BYTES: u64 = 1 << 30;
/// The share of the reference's pixels the detail figure covers.
const DETAIL_SHARE: f64 = 0.1;
/// How much the residual pictures magnify a difference.
const RESIDUAL_GAIN: f32 = 8.0;

/// An image's display values (sRGB in 0..1), row by row.
struct Picture {
    width: u32,
    height: u32,
    rgb: Vec<f32>,
}

impl Picture {
    fn read(path: &Path) -> Result<Picture, String> {
        let fail = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
        let bytes = treelight_document::files::own_file::read_bounded(path, MAX_FILE_BYTES)
            .map_err(|e| fail(&e))?;
        let reader = image::ImageReader::new(Cursor::new(&bytes[..]))
            .with_guessed_format()
            .map_err(|e| fail(&e))?;
        let (w, h) = reader.into_dimensions().map_err(|e| fail(&e))?;
        if w > MAX_SIDE || h > MAX_SIDE {
            return Err(fail(&format!(
                "{w}×{h} pixels is over the limit of {MAX_SIDE} a side"
            )));
        }
        let decoded = image::ImageReader::new(Cursor::new(&bytes[..]))
            .with_guessed_format()
            .map_err(|e| fail(&e))?
            .decode()
            .map_err(|e| fail(&format!("cannot decode: {e}")))?
            .into_rgb8();
        Ok(Picture {
            width: w,
            height: h,
            rgb: decoded
                .into_raw()
                .into_iter()
                .map(|v| f32::from(v) / 255.0)
                .collect(),
        })
    }

    /// Each pixel's luminance of display values.
    fn luminance(&self) -> Vec<f32> {
        self.rgb
            .chunks_exact(3)
            .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
            .collect()
    }
}

fn to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The relative MSE of `image` against `reference` over the pixels `keep` accepts.
fn relative_error(
    reference: &[f32],
    image: &[f32],
    keep: impl Fn(usize) -> bool,
    map: impl Fn(f32) -> f32,
) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (k, (a, b)) in reference.iter().zip(image).enumerate() {
        if keep(k / 3) {
            let (a, b) = (f64::from(map(*a)), f64::from(map(*b)));
            num += (a - b).powi(2);
            den += a * a;
        }
    }
    if den == 0.0 { 0.0 } else { num / den }
}

/// Which pixels of an image of `width` × `height` with luminance `l` are its detail: the
/// [`DETAIL_SHARE`] of them where the luminance differs most from their right and lower
/// neighbours' (fewer where fewer differ at all).
fn detail_pixels(width: usize, height: usize, l: &[f32]) -> Vec<bool> {
    let change: Vec<f32> = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let dx = if x + 1 < width { l[i + 1] - l[i] } else { 0.0 };
            let dy = if y + 1 < height {
                l[i + width] - l[i]
            } else {
                0.0
            };
            dx.hypot(dy)
        })
        .collect();
    let mut sorted = change.clone();
    sorted.sort_by(f32::total_cmp);
    let at = ((sorted.len() as f64) * (1.0 - DETAIL_SHARE)) as usize;
    let threshold = sorted.get(at.min(sorted.len().saturating_sub(1))).copied();
    // Where fewer pixels change at all, those are the detail; a flat reference has none.
    let t = threshold.unwrap_or(0.0);
    change.iter().map(|c| *c > 0.0 && *c >= t).collect()
}

/// `values` blurred by a separable Gaussian of σ 1.5 over 11 × 11 pixels, the window clipped at
/// the border and renormalised.
fn gaussian(width: usize, height: usize, values: &[f32]) -> Vec<f32> {
    let taps: Vec<f32> = (-5i32..=5)
        .map(|d| (-(d * d) as f32 / (2.0 * 1.5 * 1.5)).exp())
        .collect();
    let pass = |src: &[f32], horizontal: bool| -> Vec<f32> {
        (0..width * height)
            .map(|i| {
                let (x, y) = ((i % width) as i32, (i / width) as i32);
                let (mut sum, mut weight) = (0.0, 0.0);
                for (t, w) in taps.iter().enumerate() {
                    let d = t as i32 - 5;
                    let (qx, qy) = if horizontal { (x + d, y) } else { (x, y + d) };
                    if qx >= 0 && qy >= 0 && (qx as usize) < width && (qy as usize) < height {
                        sum += w * src[qy as usize * width + qx as usize];
                        weight += w;
                    }
                }
                sum / weight
            })
            .collect()
    };
    pass(&pass(values, true), false)
}

/// The mean structural similarity of two luminance images in 0..1.
fn ssim(width: usize, height: usize, a: &[f32], b: &[f32]) -> f64 {
    const C1: f32 = 0.01 * 0.01;
    const C2: f32 = 0.03 * 0.03;
    let product =
        |x: &[f32], y: &[f32]| -> Vec<f32> { x.iter().zip(y).map(|(p, q)| p * q).collect() };
    let (ma, mb) = (gaussian(width, height, a), gaussian(width, height, b));
    let aa = gaussian(width, height, &product(a, a));
    let bb = gaussian(width, height, &product(b, b));
    let ab = gaussian(width, height, &product(a, b));
    let sum: f64 = (0..width * height)
        .map(|i| {
            let (va, vb) = (aa[i] - ma[i] * ma[i], bb[i] - mb[i] * mb[i]);
            let cov = ab[i] - ma[i] * mb[i];
            let s = ((2.0 * ma[i] * mb[i] + C1) * (2.0 * cov + C2))
                / ((ma[i] * ma[i] + mb[i] * mb[i] + C1) * (va + vb + C2));
            f64::from(s)
        })
        .sum();
    sum / (width * height) as f64
}

/// How far an image is from its reference (see the module's description).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Relative MSE of linear colour.
    pub linear: f64,
    /// Relative MSE of display values.
    pub display: f64,
    /// Relative MSE of display values over the reference's detail.
    pub detail: f64,
    /// Mean structural similarity of the display luminance.
    pub ssim: f64,
}

/// The relative MSE of `image` against `reference` in linear colour.
pub fn relative_mse(reference: &Path, image: &Path) -> Result<f64, String> {
    compare(reference, image, None).map(|c| c.linear)
}

/// Compares `image` with `reference`, drawing their residual to `residual` (a new file) if given.
pub fn compare(
    reference: &Path,
    image: &Path,
    residual: Option<&Path>,
) -> Result<Comparison, String> {
    let r = Picture::read(reference)?;
    let x = Picture::read(image)?;
    if (x.width, x.height) != (r.width, r.height) {
        return Err(format!(
            "{} is {}×{} pixels, the reference {}×{}",
            image.display(),
            x.width,
            x.height,
            r.width,
            r.height
        ));
    }
    if r.rgb.iter().all(|v| *v == 0.0) {
        return Err(format!("{} is black", reference.display()));
    }
    let (w, h) = (r.width as usize, r.height as usize);
    let (lr, lx) = (r.luminance(), x.luminance());
    let detail = detail_pixels(w, h, &lr);
    let comparison = Comparison {
        linear: relative_error(&r.rgb, &x.rgb, |_| true, to_linear),
        display: relative_error(&r.rgb, &x.rgb, |_| true, |v| v),
        detail: relative_error(&r.rgb, &x.rgb, |p| detail[p], |v| v),
        ssim: ssim(w, h, &lr, &lx),
    };
    if let Some(path) = residual {
        write_residual(path, &r, &lx, &lr)?;
    }
    Ok(comparison)
}

/// Draws the signed luminance difference `image − reference` to the new file `path`.
fn write_residual(
    path: &Path,
    r: &Picture,
    image: &[f32],
    reference: &[f32],
) -> Result<(), String> {
    let pixels: Vec<u8> = image
        .iter()
        .zip(reference)
        .flat_map(|(x, r)| {
            let d = ((x - r) * RESIDUAL_GAIN).clamp(-1.0, 1.0);
            let level = |v: f32| (v * 255.0).round() as u8;
            if d >= 0.0 {
                [level(d), 0, 0]
            } else {
                [0, 0, level(-d)]
            }
        })
        .collect();
    let mut png = Vec::new();
    image::RgbImage::from_raw(r.width, r.height, pixels)
        .ok_or_else(|| format!("{}: the residual has the wrong size", path.display()))?
        .write_to(&mut Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    treelight_document::files::own_file::write_new(path, &png).map_err(|e| {
        if e.kind() == std::io::ErrorKind::AlreadyExists {
            format!("{}: the file exists; it is not replaced", path.display())
        } else {
            format!("{}: {e}", path.display())
        }
    })
}

/// Where the residual of `image` goes in the folder `dir`: `<image's stem>-residual.png`.
pub fn residual_path(dir: &Path, image: &Path) -> PathBuf {
    let stem = image
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image".into());
    dir.join(format!("{stem}-residual.png"))
}

/// `treelight compare`: prints a header, then each image's figures, one line an image; drawing
/// residuals into `residuals` if given. Fails (status 1) at the first image that cannot be
/// compared.
pub fn print_comparisons(
    reference: &Path,
    images: &[PathBuf],
    residuals: Option<&Path>,
) -> std::process::ExitCode {
    if let Some(dir) = residuals.filter(|d| !d.is_dir()) {
        eprintln!("treelight: {}: not a folder", dir.display());
        return std::process::ExitCode::from(2);
    }
    println!("# linear    display   detail    ssim    image");
    for image in images {
        let residual = residuals.map(|dir| residual_path(dir, image));
        match compare(reference, image, residual.as_deref()) {
            Ok(c) => println!(
                "{:.6}  {:.6}  {:.6}  {:.4}  {}",
                c.linear,
                c.display,
                c.detail,
                c.ssim,
                image.display()
            ),
            Err(e) => {
                eprintln!("treelight: {e}");
                return std::process::ExitCode::from(1);
            }
        }
    }
    std::process::ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(n: usize, seed: u32) -> Vec<f32> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 8) as f32 / (1u32 << 24) as f32
            })
            .collect()
    }

    #[test]
    fn an_image_is_perfectly_similar_to_itself_and_less_to_a_noisier_one() {
        let (w, h) = (40, 30);
        let a = noise(w * h, 1);
        assert!((ssim(w, h, &a, &a) - 1.0).abs() < 1e-6);
        let b: Vec<f32> = a
            .iter()
            .zip(noise(w * h, 2))
            .map(|(x, n)| (x + 0.2 * (n - 0.5)).clamp(0.0, 1.0))
            .collect();
        let c: Vec<f32> = a
            .iter()
            .zip(noise(w * h, 3))
            .map(|(x, n)| (x + 0.6 * (n - 0.5)).clamp(0.0, 1.0))
            .collect();
        let (sb, sc) = (ssim(w, h, &a, &b), ssim(w, h, &a, &c));
        assert!(sb < 1.0 && sc < sb, "{sb} {sc}");
    }

    #[test]
    fn a_blur_shows_on_the_detail_more_than_on_the_whole() {
        // A flat field with one sharp stripe: a blur of the stripe is all on its edges.
        let (w, h) = (32, 32);
        let sharp: Vec<f32> = (0..w * h)
            .map(|i| {
                if (12..16).contains(&(i % w)) {
                    0.9
                } else {
                    0.3
                }
            })
            .collect();
        let blurred = gaussian(w, h, &sharp);
        let detail = detail_pixels(w, h, &sharp);
        let rgb = |l: &[f32]| -> Vec<f32> { l.iter().flat_map(|v| [*v; 3]).collect() };
        let (rs, rb) = (rgb(&sharp), rgb(&blurred));
        let whole = relative_error(&rs, &rb, |_| true, |v| v);
        let edges = relative_error(&rs, &rb, |p| detail[p], |v| v);
        assert!(whole > 0.0 && edges > 2.0 * whole, "{whole} {edges}");
        // A flat picture has no detail.
        assert!(detail_pixels(w, h, &vec![0.5; w * h]).iter().all(|d| !d));
    }

    #[test]
    fn the_command_s_files_are_read_and_written_only_as_the_user_meant() {
        let dir = std::env::temp_dir().join(format!("treelight-compare-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = |name: &str, level: u8| {
            let path = dir.join(name);
            image::RgbImage::from_pixel(8, 6, image::Rgb([level, level, level]))
                .save(&path)
                .unwrap();
            path
        };
        let (reference, image) = (png("ref.png", 100), png("x.png", 110));
        let residual = residual_path(&dir, &image);
        let c = compare(&reference, &image, Some(&residual)).unwrap();
        assert!(
            c.display > 0.0 && c.linear > 0.0 && c.detail == 0.0,
            "{c:?}"
        );
        // An existing residual is not replaced, and the figures are not printed as if it were.
        let again = compare(&reference, &image, Some(&residual)).unwrap_err();
        assert!(again.contains("exists"), "{again}");
        // Another size, a missing file and a pipe are refused with the file's name, at once.
        let small = dir.join("small.png");
        image::RgbImage::new(4, 4).save(&small).unwrap();
        assert!(
            compare(&reference, &small, None)
                .unwrap_err()
                .contains("small.png")
        );
        assert!(compare(&reference, &dir.join("none.png"), None).is_err());
        #[cfg(unix)]
        {
            let fifo = dir.join("fifo.png");
            let path = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path; mkfifo only creates the pipe.
            assert_eq!(unsafe { libc::mkfifo(path.as_ptr(), 0o600) }, 0);
            let e = compare(&reference, &fifo, None).unwrap_err();
            assert!(
                e.contains("fifo.png") && e.contains("not a regular file"),
                "{e}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
