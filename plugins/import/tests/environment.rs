//! Sky panoramas: Radiance HDR and OpenEXR files written by the tests themselves read back as
//! written; wide ones are shrunk keeping their mean; hostile ones are refused within bounded time
//! and memory with an error naming the file.

use image::{DynamicImage, Rgb32FImage};
use std::path::{Path, PathBuf};
use treelight_import::{MAX_ENVIRONMENT_WIDTH, coordinates_of, direction_of, read_environment};
use treelight_test_support::Xorshift;

fn folder(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("treelight-sky-{tag}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A `w × h` panorama whose texels say where they are (red across, green down) and how bright.
fn panorama(w: u32, h: u32, bright: f32) -> Rgb32FImage {
    Rgb32FImage::from_fn(w, h, |x, y| {
        image::Rgb([
            (x as f32 + 0.5) / w as f32,
            (y as f32 + 0.5) / h as f32,
            bright,
        ])
    })
}

fn save(img: Rgb32FImage, path: &Path) {
    DynamicImage::ImageRgb32F(img).save(path).unwrap();
}

#[test]
fn hdr_and_exr_panoramas_read_back_as_written() {
    let dir = folder("formats");
    // RGBE keeps 8 bits of mantissa under each pixel's largest channel; EXR keeps the floats.
    for (name, tolerance) in [("sky.hdr", 1.0 / 128.0), ("sky.exr", 1e-6)] {
        let path = dir.join(name);
        save(panorama(64, 32, 0.75), &path);
        let sky = read_environment(&path).unwrap();
        assert_eq!((sky.width, sky.height), (64, 32), "{name}");
        assert!(sky.warnings.is_empty(), "{name}: {:?}", sky.warnings);
        for (i, t) in sky.rgb.iter().enumerate() {
            let (x, y) = (i as u32 % 64, i as u32 / 64);
            let want = [(x as f32 + 0.5) / 64.0, (y as f32 + 0.5) / 32.0, 0.75];
            for c in 0..3 {
                assert!(
                    (t[c] - want[c]).abs() <= tolerance,
                    "{name} texel {x},{y} channel {c}: {} vs {}",
                    t[c],
                    want[c]
                );
            }
        }
    }
    // The texel in the middle of the panorama looks along −Z, and back.
    let d = direction_of(0.5, 0.5);
    assert!((d[2] + 1.0).abs() < 1e-6);
    let (u, v) = coordinates_of(d);
    assert!((u - 0.5).abs() < 1e-6 && (v - 0.5).abs() < 1e-6);
}

#[test]
fn a_panorama_wider_than_kept_is_shrunk_keeping_its_light() {
    let dir = folder("wide");
    let path = dir.join("wide.exr");
    let w = MAX_ENVIRONMENT_WIDTH * 2;
    save(panorama(w, 8, 2.0), &path);
    let sky = read_environment(&path).unwrap();
    assert_eq!((sky.width, sky.height), (MAX_ENVIRONMENT_WIDTH, 4));
    let mean =
        |f: &dyn Fn(&[f32; 3]) -> f32| sky.rgb.iter().map(f).sum::<f32>() / sky.rgb.len() as f32;
    assert!((mean(&|t| t[0]) - 0.5).abs() < 1e-3);
    assert!((mean(&|t| t[2]) - 2.0).abs() < 1e-4);
    // Said, with the shape's warning (8192×8 is not 2:1).
    assert!(
        sky.warnings.iter().any(|w| w.contains("keeps 4096×4")),
        "{:?}",
        sky.warnings
    );
    assert!(
        sky.warnings.iter().any(|w| w.contains("not the 2:1")),
        "{:?}",
        sky.warnings
    );
}

#[test]
fn bad_pixels_turn_black_with_a_warning() {
    let dir = folder("nan");
    let path = dir.join("nan.exr");
    let mut img = panorama(16, 8, 1.0);
    img.put_pixel(3, 2, image::Rgb([f32::NAN, 1.0, 1.0]));
    img.put_pixel(4, 2, image::Rgb([f32::INFINITY, 1.0, 1.0]));
    img.put_pixel(5, 2, image::Rgb([-4.0, 1.0, 1.0]));
    save(img, &path);
    let sky = read_environment(&path).unwrap();
    assert_eq!(sky.rgb[2 * 16 + 3], [0.0; 3]);
    assert_eq!(sky.rgb[2 * 16 + 4], [0.0; 3]);
    // A negative channel is clamped, the pixel kept.
    assert_eq!(sky.rgb[2 * 16 + 5], [0.0, 1.0, 1.0]);
    assert!(sky.rgb.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    assert!(
        sky.warnings.iter().any(|w| w.contains("2 pixels")),
        "{:?}",
        sky.warnings
    );
}

#[test]
fn hostile_panoramas_are_refused_naming_the_file() {
    let dir = folder("hostile");
    let started = std::time::Instant::now();
    let cases: Vec<(PathBuf, &str)> = {
        let garbage = dir.join("garbage.hdr");
        std::fs::write(&garbage, b"not a radiance file at all").unwrap();
        // A header that asks for 4 billion pixels, and no pixels.
        let huge = dir.join("huge.hdr");
        std::fs::write(
            &huge,
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 65536 +X 65536\n",
        )
        .unwrap();
        // Pixels cut off halfway.
        let cut = dir.join("cut.hdr");
        let whole = dir.join("whole.hdr");
        save(panorama(64, 32, 1.0), &whole);
        let bytes = std::fs::read(&whole).unwrap();
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let exr = dir.join("garbage.exr");
        std::fs::write(&exr, [0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, 0xff, 0xff]).unwrap();
        let folder_named = dir.join("folder.hdr");
        std::fs::create_dir_all(&folder_named).unwrap();
        let png = dir.join("sky.png");
        std::fs::write(&png, b"\x89PNG\r\n\x1a\n").unwrap();
        let mut cases = vec![
            (garbage, "garbage.hdr"),
            (huge, "huge.hdr"),
            (cut, "cut.hdr"),
            (exr, "garbage.exr"),
            (folder_named, "not a regular file"),
            (png, ".hdr and OpenEXR .exr are read"),
            (dir.join("missing.hdr"), "missing.hdr"),
        ];
        #[cfg(unix)]
        {
            let device = dir.join("zero.hdr");
            std::os::unix::fs::symlink("/dev/zero", &device).unwrap();
            cases.push((device, "a device"));
        }
        cases
    };
    for (path, says) in cases {
        let e = read_environment(&path).expect_err(&path.display().to_string());
        let text = e.to_string();
        assert!(
            text.contains(path.file_name().unwrap().to_str().unwrap()) && text.contains(says),
            "{}: {text}",
            path.display()
        );
    }
    assert!(started.elapsed().as_secs() < 10, "{:?}", started.elapsed());
}

/// A small generator of mutations, seeded so a failure names its case.
struct Mutator(Xorshift);

impl Mutator {
    /// Flips, overwrites, inserts or cuts bytes; header numbers get large values.
    fn damage(&mut self, bytes: &mut Vec<u8>) {
        for _ in 0..1 + self.0.below(4) {
            let at = self.0.below(bytes.len());
            match self.0.below(6) {
                0 => bytes[at] ^= 1 << self.0.below(8),
                1 => bytes[at] = self.0.next_u64() as u8,
                2 => bytes.truncate(at),
                3 => bytes
                    .splice(at..at, b"99999".iter().copied())
                    .for_each(drop),
                4 => bytes[at..].iter_mut().take(4).for_each(|b| *b = 0xff),
                _ => bytes
                    .splice(at..at, (0..16).map(|_| self.0.next_u64() as u8))
                    .for_each(drop),
            }
            if bytes.is_empty() {
                return;
            }
        }
    }
}

#[test]
fn mutated_panoramas_never_panic_and_stay_within_bounds() {
    let dir = folder("mutations");
    let cases: usize = std::env::var("TREELIGHT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(300);
    let mut seeds = Vec::new();
    for name in ["seed.hdr", "seed.exr"] {
        let path = dir.join(name);
        save(panorama(32, 16, 3.0), &path);
        seeds.push((name, std::fs::read(&path).unwrap()));
    }
    let started = std::time::Instant::now();
    let mut failures = Vec::new();
    let mut read = 0;
    for k in 0..cases {
        let mut m = Mutator(Xorshift(
            0x9e37_79b9_7f4a_7c15 ^ (k as u64 + 1).wrapping_mul(0xff51_afd7),
        ));
        let (name, seed) = &seeds[k % seeds.len()];
        let mut bytes = seed.clone();
        m.damage(&mut bytes);
        let path = dir.join(format!("{k}-{name}"));
        std::fs::write(&path, &bytes).unwrap();
        match std::panic::catch_unwind(|| read_environment(&path)) {
            Ok(Ok(sky)) => {
                read += 1;
                // What loads is what a panorama must be: finite, not negative, at most 4096 wide.
                if sky.width > MAX_ENVIRONMENT_WIDTH
                    || sky.rgb.len() != (sky.width * sky.height) as usize
                    || sky.rgb.iter().flatten().any(|v| !v.is_finite() || *v < 0.0)
                {
                    failures.push(format!("case {k} ({name}) loaded out of bounds"));
                }
            }
            Ok(Err(e)) if !e.to_string().contains(&format!("{k}-{name}")) => {
                failures.push(format!(
                    "case {k} ({name}): the error does not name it: {e}"
                ));
            }
            Ok(Err(_)) => {}
            Err(_) => failures.push(format!("case {k} ({name}) panicked")),
        }
        std::fs::remove_file(&path).ok();
    }
    eprintln!(
        "{cases} mutated panoramas, {read} read, in {:?}",
        started.elapsed()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
