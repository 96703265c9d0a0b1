//! `treelight compare REFERENCE IMAGE...`: how far images are from a reference of the same frame
//! (a render at many samples), as the relative mean squared error: the sum of squared differences
//! over the sum of the reference's squares, on linear colour decoded from the PNGs' sRGB.

use std::path::Path;

/// Largest image side read: a hostile header cannot ask for gigabytes.
const MAX_SIDE: u32 = 16_384;

/// An image's linear RGB, row by row.
fn linear_rgb(path: &Path) -> Result<(u32, u32, Vec<f32>), String> {
    let reader = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let (w, h) = reader
        .into_dimensions()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    if w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!(
            "{}: {w}×{h} pixels is over the limit of {MAX_SIDE} a side",
            path.display()
        ));
    }
    let decoded = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| format!("{}: {e}", path.display()))?
        .decode()
        .map_err(|e| format!("{}: cannot decode: {e}", path.display()))?
        .into_rgb8();
    let to_linear = |v: u8| {
        let c = f32::from(v) / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    Ok((
        w,
        h,
        decoded.into_raw().into_iter().map(to_linear).collect(),
    ))
}

/// The relative MSE of `image` against `reference`.
pub fn relative_mse(reference: &Path, image: &Path) -> Result<f64, String> {
    let (rw, rh, r) = linear_rgb(reference)?;
    let (w, h, x) = linear_rgb(image)?;
    if (w, h) != (rw, rh) {
        return Err(format!(
            "{} is {w}×{h} pixels, the reference {rw}×{rh}",
            image.display()
        ));
    }
    let num: f64 = r
        .iter()
        .zip(&x)
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum();
    let den: f64 = r.iter().map(|a| f64::from(*a).powi(2)).sum();
    if den == 0.0 {
        return Err(format!("{} is black", reference.display()));
    }
    Ok(num / den)
}
