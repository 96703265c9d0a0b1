//! Radiance `.hdr` (RGBE) panoramas read a scanline at a time and shrunk as they are read: each
//! kept texel is the mean of the file's texels in its block, so a sky of any declared size takes
//! only the kept image and one scanline in memory (a 98 KB file may declare 16384×8192 pixels,
//! which decoded whole would take gigabytes). The header and both run-length encodings of the
//! format are read as Greg Ward's `color.c` writes them.

use crate::types::error::ImportError;
use std::io::{BufRead, Read};
use std::path::Path;

/// A panorama read: its kept size, texels (row by row), and the size the file declared.
pub(crate) struct ShrunkImage {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<[f32; 3]>,
    pub declared: (u32, u32),
}

/// The longest header line read: real headers have short lines.
const MAX_HEADER_LINE: usize = 4096;
/// The most header lines read.
const MAX_HEADER_LINES: usize = 256;

fn line(r: &mut impl BufRead, path: &Path) -> Result<String, ImportError> {
    let mut bytes = Vec::new();
    r.take(MAX_HEADER_LINE as u64 + 1)
        .read_until(b'\n', &mut bytes)
        .map_err(|e| ImportError::new(path, format!("cannot read its header: {e}")))?;
    if bytes.len() > MAX_HEADER_LINE {
        return Err(ImportError::new(path, "its header has a line too long"));
    }
    if bytes.pop() != Some(b'\n') {
        return Err(ImportError::new(
            path,
            "its header ends before the image size",
        ));
    }
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// Reads the header: the declared width and height (only the standard `-Y H +X W` orientation).
pub(crate) fn read_header(r: &mut impl BufRead, path: &Path) -> Result<(u32, u32), ImportError> {
    let first = line(r, path)?;
    if !(first.starts_with("#?RADIANCE") || first.starts_with("#?RGBE")) {
        return Err(ImportError::new(path, "not a Radiance .hdr file"));
    }
    for _ in 0..MAX_HEADER_LINES {
        let l = line(r, path)?;
        if l.is_empty() {
            let size = line(r, path)?;
            let words: Vec<&str> = size.split_whitespace().collect();
            let parse = |w: &str| w.parse::<u32>().ok().filter(|v| *v > 0);
            return match words.as_slice() {
                ["-Y", h, "+X", w] => match (parse(w), parse(h)) {
                    (Some(w), Some(h)) => Ok((w, h)),
                    _ => Err(ImportError::new(
                        path,
                        format!("its size '{size}' is not one"),
                    )),
                },
                _ => Err(ImportError::new(
                    path,
                    format!("its orientation '{size}' is not the standard -Y H +X W"),
                )),
            };
        }
        if let Some(format) = l.strip_prefix("FORMAT=")
            && format.trim() != "32-bit_rle_rgbe"
        {
            return Err(ImportError::new(
                path,
                format!("its pixel format {format} is not 32-bit_rle_rgbe"),
            ));
        }
    }
    Err(ImportError::new(path, "its header never ends"))
}

/// For each of `n` source positions, the kept position once `n` is halved `times` times as
/// the environment reader's halving does it (an odd last one folds into its neighbour).
fn fold_map(n: u32, times: u32) -> (Vec<u32>, u32) {
    let mut map: Vec<u32> = (0..n).collect();
    let mut size = n;
    for _ in 0..times {
        let next = (size / 2).max(1);
        for m in &mut map {
            *m = (*m / 2).min(next - 1);
        }
        size = next;
    }
    (map, size)
}

/// Reads the pixels after the header, `width` × `height` declared, shrunk by halving until the
/// width is at most `max_width`.
pub(crate) fn read_shrunk(
    r: &mut impl Read,
    path: &Path,
    (width, height): (u32, u32),
    max_width: u32,
) -> Result<ShrunkImage, ImportError> {
    let mut times = 0;
    while (width >> times).max(1) > max_width {
        times += 1;
    }
    let (columns, kw) = fold_map(width, times);
    let (rows, kh) = fold_map(height, times);
    let mut sum = vec![[0.0f64; 3]; kw as usize * kh as usize];
    let mut count = vec![0u32; sum.len()];
    let mut scanline = vec![[0u8; 4]; width as usize];
    for y in 0..height {
        read_scanline(r, &mut scanline).map_err(|e| {
            ImportError::new(path, format!("cannot decode scanline {y} of {height}: {e}"))
        })?;
        let base = rows[y as usize] as usize * kw as usize;
        for (x, px) in scanline.iter().enumerate() {
            let i = base + columns[x] as usize;
            let rgb = rgbe_to_rgb(*px);
            for c in 0..3 {
                sum[i][c] += f64::from(rgb[c]);
            }
            count[i] += 1;
        }
    }
    let rgb = sum
        .iter()
        .zip(&count)
        .map(|(s, &n)| s.map(|v| (v / f64::from(n.max(1))) as f32))
        .collect();
    Ok(ShrunkImage {
        width: kw,
        height: kh,
        rgb,
        declared: (width, height),
    })
}

/// An RGBE texel as linear RGB: each 8-bit mantissa times 2^(e - 136), the shared exponent
/// biased by 128 over mantissas of 8 bits (0 for an exponent of 0), as the image crate reads it.
fn rgbe_to_rgb([r, g, b, e]: [u8; 4]) -> [f32; 3] {
    if e == 0 {
        return [0.0; 3];
    }
    // Exact: a power of two in f64, then in f32 (the smallest, 2^-135, a subnormal).
    let scale = (f64::from(e) - 136.0).exp2() as f32;
    [
        f32::from(r) * scale,
        f32::from(g) * scale,
        f32::from(b) * scale,
    ]
}

fn byte(r: &mut impl Read) -> std::io::Result<u8> {
    let mut b = [0u8];
    r.read_exact(&mut b)?;
    Ok(b[0])
}

fn bad(what: &str) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidData, what.to_owned())
}

/// One scanline into `out`: the per-component run-length encoding where the line starts
/// `2 2 hi lo`, else flat or old-style run-length texels.
fn read_scanline(r: &mut impl Read, out: &mut [[u8; 4]]) -> std::io::Result<()> {
    let width = out.len();
    let mut first = [0u8; 4];
    r.read_exact(&mut first)?;
    let new_rle = (8..0x8000).contains(&width) && first[0] == 2 && first[1] == 2 && first[2] < 128;
    if !new_rle {
        return read_old(r, out, first);
    }
    if (usize::from(first[2]) << 8 | usize::from(first[3])) != width {
        return Err(bad("a scanline's width differs from the image's"));
    }
    for c in 0..4 {
        let mut x = 0;
        while x < width {
            let n = byte(r)?;
            if n > 128 {
                let run = usize::from(n - 128);
                let v = byte(r)?;
                if x + run > width {
                    return Err(bad("a run passes the scanline's end"));
                }
                out[x..x + run].iter_mut().for_each(|p| p[c] = v);
                x += run;
            } else {
                let run = usize::from(n);
                if run == 0 || x + run > width {
                    return Err(bad("a literal run is empty or passes the scanline's end"));
                }
                for p in &mut out[x..x + run] {
                    p[c] = byte(r)?;
                }
                x += run;
            }
        }
    }
    Ok(())
}

/// Flat texels, where `1 1 1 n` repeats the last texel `n << shift` times (shift growing by 8
/// for consecutive repeats).
fn read_old(r: &mut impl Read, out: &mut [[u8; 4]], first: [u8; 4]) -> std::io::Result<()> {
    let mut x = 0;
    let mut shift = 0u32;
    let mut next = Some(first);
    while x < out.len() {
        let px = match next.take() {
            Some(p) => p,
            None => {
                let mut p = [0u8; 4];
                r.read_exact(&mut p)?;
                p
            }
        };
        if px[0] == 1 && px[1] == 1 && px[2] == 1 {
            if x == 0 || shift > 16 {
                return Err(bad("a repeat with nothing to repeat"));
            }
            let run = usize::from(px[3]) << shift;
            if x + run > out.len() {
                return Err(bad("a repeat passes the scanline's end"));
            }
            let last = out[x - 1];
            out[x..x + run].iter_mut().for_each(|p| *p = last);
            x += run;
            shift += 8;
        } else {
            out[x] = px;
            x += 1;
            shift = 0;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An RGBE file of `w` × `h` texels given by `texel`, written by the image crate.
    fn written(w: u32, h: u32, texel: impl Fn(u32, u32) -> [f32; 3]) -> Vec<u8> {
        let pixels: Vec<image::Rgb<f32>> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| image::Rgb(texel(x, y)))
            .collect();
        let mut bytes = Vec::new();
        image::codecs::hdr::HdrEncoder::new(&mut bytes)
            .encode(&pixels, w as usize, h as usize)
            .unwrap();
        bytes
    }

    fn read(bytes: &[u8], max_width: u32) -> ShrunkImage {
        let path = Path::new("sky.hdr");
        let mut r = std::io::BufReader::new(bytes);
        let size = read_header(&mut r, path).unwrap();
        read_shrunk(&mut r, path, size, max_width).unwrap()
    }

    #[test]
    fn a_sky_read_whole_matches_the_image_crates_decoder() {
        let texel = |x: u32, y: u32| [x as f32 * 0.25, y as f32 + 0.5, 3.0 / (1.0 + x as f32)];
        for (w, h) in [(40, 20), (5, 3), (300, 150)] {
            let bytes = written(w, h, texel);
            let ours = read(&bytes, 4096);
            let theirs = image::load_from_memory_with_format(&bytes, image::ImageFormat::Hdr)
                .unwrap()
                .into_rgb32f();
            assert_eq!((ours.width, ours.height), (w, h));
            for (a, b) in ours.rgb.iter().zip(theirs.pixels()) {
                for c in 0..3 {
                    assert!(
                        (a[c] - b.0[c]).abs() <= 1e-6 * b.0[c].abs().max(1.0),
                        "{a:?} {b:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_sky_shrunk_as_read_keeps_its_mean_light() {
        let texel = |x: u32, y: u32| [((x * 7 + y * 3) % 11) as f32, 1.0, (y % 5) as f32];
        let (w, h) = (301, 151);
        let bytes = written(w, h, texel);
        let whole = read(&bytes, 4096);
        let shrunk = read(&bytes, 64);
        assert!(shrunk.width <= 64 && shrunk.width == (w >> 3).max(1));
        let mean = |img: &ShrunkImage, weight: &dyn Fn(usize) -> f64| {
            img.rgb
                .iter()
                .enumerate()
                .map(|(i, t)| f64::from(t[0]) * weight(i))
                .sum::<f64>()
        };
        let total = mean(&whole, &|_| 1.0) / f64::from(w * h);
        // Each kept texel weighted by the source texels it took.
        let (cols, kw) = fold_map(w, 3);
        let (rows, _) = fold_map(h, 3);
        let mut taken = vec![0f64; shrunk.rgb.len()];
        for y in 0..h as usize {
            for x in 0..w as usize {
                taken[rows[y] as usize * kw as usize + cols[x] as usize] += 1.0;
            }
        }
        let kept = mean(&shrunk, &|i| taken[i]) / f64::from(w * h);
        assert!((total - kept).abs() < 1e-4 * total, "{total} vs {kept}");
    }

    #[test]
    fn broken_files_are_refused_not_read_past() {
        let path = Path::new("sky.hdr");
        let bytes = written(40, 20, |_, _| [1.0; 3]);
        for cut in [5, 30, bytes.len() - 10] {
            let mut r = std::io::BufReader::new(&bytes[..cut]);
            let result = read_header(&mut r, path)
                .and_then(|size| read_shrunk(&mut r, path, size, 4096).map(|_| ()));
            assert!(result.is_err(), "cut at {cut}");
        }
        let flipped = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 4 +X 8\n";
        let mut r = std::io::BufReader::new(&flipped[..]);
        assert!(
            read_header(&mut r, path)
                .unwrap_err()
                .problem
                .contains("orientation")
        );
    }
}
