//! Small files shaped to make a reader allocate far more than they hold, one per way a reader
//! can be fooled (elements that take no bytes in the file, one long line, arrays nobody reads,
//! a long name repeated in every child's key, one image named many times, headers declaring huge
//! images): each is refused with its file named, or read within its memory budget, as the
//! counting allocator measures it, and within seconds.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use treelight_import::{ImportOptions, load_scene_with, read_environment_with};
use treelight_test_support::counting;

#[global_allocator]
static ALLOCATOR: counting::Counting = counting::Counting;

/// The budget each file gets, and the slack over it allowed for small bookkeeping.
const BUDGET: u64 = 64 << 20;
const SLACK: u64 = 8 << 20;

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("treelight-shapes-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn options() -> ImportOptions {
    ImportOptions {
        memory_budget: BUDGET,
    }
}

/// Imports `path` under the budget: whether it was refused, checked to stay within the budget
/// and to name the file.
fn import(what: &str, path: &Path) -> Result<treelight_import::ImportedScene, String> {
    let start = Instant::now();
    let (result, peak) = counting::peak_during(|| load_scene_with(path, &options()));
    assert!(
        peak <= BUDGET + SLACK,
        "{what}: {peak} bytes at the peak, over the budget of {BUDGET}"
    );
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{what}: took {:?}",
        start.elapsed()
    );
    result.map_err(|e| {
        assert_eq!(e.file, path, "{what}: {e}");
        e.to_string()
    })
}

fn ply(header: &str, payload: &[u8]) -> Vec<u8> {
    let mut out = header.as_bytes().to_vec();
    out.extend_from_slice(payload);
    out
}

#[test]
fn every_shape_is_refused_or_read_within_the_budget() {
    // One test at a time: the allocator's counts are the whole process's.
    let d = dir();
    // PLY elements without properties take no bytes in a binary file.
    let p = d.join("sparse.ply");
    std::fs::write(
        &p,
        ply(
            "ply\nformat binary_little_endian 1.0\nelement vertex 50000000\nelement face \
             50000000\nend_header\n",
            &[],
        ),
    )
    .unwrap();
    let e = import("property-less PLY elements", &p).unwrap_err();
    assert!(e.contains("memory"), "{e}");
    // PLY elements of one small property, read past: each becomes a map.
    let p = d.join("edges.ply");
    let n = 4_000_000;
    std::fs::write(
        &p,
        ply(
            &format!(
                "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                 property float y\nproperty float z\nelement edge {n}\nproperty uchar a\n\
                 element face 1\nproperty list uchar uint vertex_indices\nend_header\n"
            ),
            &[
                vec![0u8; 36],
                vec![1u8; n],
                vec![3, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0],
            ]
            .concat(),
        ),
    )
    .unwrap();
    assert!(import("one-property PLY elements", &p).is_err());
    // OBJ: one face of a million corners on one line, and a million faces of one index.
    let p = d.join("line.obj");
    let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf");
    for k in 0..1_000_000 {
        text.push_str(if k % 2 == 0 { " 1" } else { " 2" });
    }
    text.push_str(" 3\n");
    std::fs::write(&p, text).unwrap();
    let _ = import("an OBJ face on one line", &p);
    let p = d.join("ones.obj");
    let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    for _ in 0..1_000_000 {
        text.push_str("f 1\n");
    }
    std::fs::write(&p, text).unwrap();
    let _ = import("OBJ lines of one index", &p);
    // glTF: an array of two million numbers in an extension nobody reads.
    let p = d.join("extension.gltf");
    let zeros = vec!["0"; 2_000_000].join(",");
    std::fs::write(
        &p,
        format!(
            r#"{{"asset":{{"version":"2.0"}},"extensions":{{"X_unknown":{{"a":[{zeros}]}}}},"scenes":[{{"nodes":[]}}],"scene":0}}"#
        ),
    )
    .unwrap();
    let _ = import("a large array in an unknown extension", &p);
    // glTF: a node with a 1 MiB name over 20,000 children: keys never copy the name.
    let p = d.join("long-name.gltf");
    let long = "n".repeat(1 << 20);
    let children: Vec<String> = (1..=20_000).map(|k| k.to_string()).collect();
    let nodes: Vec<String> = std::iter::once(format!(
        r#"{{"name":"{long}","children":[{}]}}"#,
        children.join(",")
    ))
    .chain((1..=20_000).map(|k| format!(r#"{{"name":"c{k}"}}"#)))
    .collect();
    std::fs::write(
        &p,
        format!(
            r#"{{"asset":{{"version":"2.0"}},"nodes":[{}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
            nodes.join(",")
        ),
    )
    .unwrap();
    let scene = import("a long name over many children", &p).unwrap();
    assert!(scene.nodes.iter().all(|n| n.key.len() < 1024));
    images(&d);
    std::fs::remove_dir_all(&d).ok();
}

/// A glTF of `count` materials, each with its own image of the file `uri` as its base colour.
fn materials_of_one_image(uri: &str, count: usize) -> String {
    let list = |f: &dyn Fn(usize) -> String| (0..count).map(f).collect::<Vec<_>>().join(",");
    format!(
        r#"{{"asset":{{"version":"2.0"}},"images":[{}],"textures":[{}],"materials":[{}],"scenes":[{{"nodes":[]}}],"scene":0}}"#,
        list(&|_| format!(r#"{{"uri":"{uri}"}}"#)),
        list(&|k| format!(r#"{{"source":{k}}}"#)),
        list(&|k| format!(r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":{k}}}}}}}"#)),
    )
}

/// Images: one named by thousands is decoded once; one larger than drawn is kept smaller; a
/// header declaring a huge image, or a small sky declaring a huge panorama, is refused before
/// its pixels are decoded.
fn images(d: &Path) {
    image::RgbaImage::from_pixel(128, 128, image::Rgba([200, 100, 50, 255]))
        .save(d.join("small.png"))
        .unwrap();
    let p = d.join("one-image.gltf");
    std::fs::write(&p, materials_of_one_image("small.png", 3000)).unwrap();
    let scene = import("one image named 3000 times", &p).unwrap();
    assert_eq!(scene.textures.len(), 1, "decoded once per name");
    image::RgbaImage::from_pixel(6000, 300, image::Rgba([9, 9, 9, 255]))
        .save(d.join("wide.png"))
        .unwrap();
    let p = d.join("wide.gltf");
    std::fs::write(&p, materials_of_one_image("wide.png", 1)).unwrap();
    let scene = import("an image wider than drawn", &p).unwrap();
    let t = &scene.textures[0];
    assert_eq!(
        (t.width, t.height),
        (4096, 205),
        "kept at the raster view's largest"
    );
    // A PNG whose header declares 16384² pixels, with almost nothing after it.
    let mut png = Vec::new();
    image::RgbaImage::new(1, 1)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    // IHDR's width and height (bytes 16..24), and its CRC recomputed.
    png[16..20].copy_from_slice(&16384u32.to_be_bytes());
    png[20..24].copy_from_slice(&16384u32.to_be_bytes());
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(d.join("huge.png"), &png).unwrap();
    let p = d.join("huge.gltf");
    std::fs::write(&p, materials_of_one_image("huge.png", 3)).unwrap();
    let _ = import("PNG headers declaring 16384² pixels", &p);
    // A Radiance sky whose header declares 16384×8192 pixels, in under a kilobyte.
    let p = d.join("huge.hdr");
    let mut hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8192 +X 16384\n".to_vec();
    hdr.extend_from_slice(&[2, 2, 64, 0]);
    std::fs::write(&p, hdr).unwrap();
    let start = Instant::now();
    let (result, peak) = counting::peak_during(|| read_environment_with(&p, &options()));
    assert!(result.is_err());
    assert!(
        peak <= BUDGET + SLACK,
        "a huge sky: {peak} bytes at the peak"
    );
    assert!(start.elapsed() < Duration::from_secs(5));
}

/// PNG's CRC-32 (ISO 3309) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}
