//! Running the editor binary headless under xvfb-run with software Vulkan.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh temporary folder for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = temp_dir_path(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Where [`temp_dir`] puts the folder `name`, without making it.
pub fn temp_dir_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("treelight-test-{name}-{}", std::process::id()))
}

#[allow(unused_imports)] // Not every binary that includes this module reads a scene.
pub use treelight_test_support::shared_scene;

/// The window the tests' editors open where a test needs no other size (the window sessions'
/// too): on a software adapter the editor's start and frames cost about what its pixels do.
pub const TEST_WINDOW: [&str; 4] = ["--width", "960", "--height", "600"];

/// The window of an editor run that reads no picture, only its report or its files.
pub const NO_PICTURE_WINDOW: [&str; 4] = ["--width", "640", "--height", "400"];

/// A settings folder for editors the tests start, apart from the user's: one a test process,
/// removed as the process exits (its editors' settings, recent files and recovery copies).
pub fn test_config_dir() -> PathBuf {
    static REMOVED_AT_EXIT: std::sync::Once = std::sync::Once::new();
    extern "C" fn remove() {
        std::fs::remove_dir_all(config_dir_path()).ok();
    }
    REMOVED_AT_EXIT.call_once(|| {
        // SAFETY: `remove` is a plain function of this program, alive until it exits. A process
        // that cannot register it only leaves the folder behind.
        unsafe { libc::atexit(remove) };
    });
    config_dir_path()
}

/// Where [`test_config_dir`] is.
fn config_dir_path() -> PathBuf {
    std::env::temp_dir().join(format!("treelight-test-config-{}", std::process::id()))
}

/// Runs the editor with `args` where there is no display (and the test settings folder): whether it
/// succeeded, and its combined output.
pub fn run_without_display(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_treelight"))
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env("TREELIGHT_CONFIG_DIR", test_config_dir())
        .output()
        .unwrap();
    (
        out.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

/// Runs the editor with `args` under xvfb-run and returns its combined output.
pub fn run_editor(args: &[&str]) -> String {
    run_headless(Path::new(env!("CARGO_BIN_EXE_treelight")), args)
}

/// Runs a program with `args` under xvfb-run and returns its combined output. Panics with an
/// explanation when the display server or the GPU adapter is missing, or when it fails.
pub fn run_headless(exe: &Path, args: &[&str]) -> String {
    run_headless_with_config(exe, args, &test_config_dir())
}

/// Runs the editor with `args` and its settings in `config`.
pub fn run_editor_with_config(args: &[&str], config: &Path) -> String {
    run_headless_with_config(Path::new(env!("CARGO_BIN_EXE_treelight")), args, config)
}

/// [`run_headless`] with the editor's settings in `config`.
pub fn run_headless_with_config(exe: &Path, args: &[&str], config: &Path) -> String {
    run_headless_with_env(exe, args, config, &[])
}

/// [`run_headless_with_config`] with `env` set too.
pub fn run_headless_with_env(
    exe: &Path,
    args: &[&str],
    config: &Path,
    env: &[(&str, &Path)],
) -> String {
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1600x1000x24"])
        .arg(exe)
        .args(args)
        .envs(env.iter().copied())
        .env("WGPU_BACKEND", "vulkan")
        // The user's own settings stay untouched by tests.
        .env("TREELIGHT_CONFIG_DIR", config)
        .env("TREELIGHT_CACHE_DIR", config.join("cache"))
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run xvfb-run ({e}). Install the headless GPU test packages: apt-get install -y mesa-vulkan-drivers libvulkan1 xvfb xauth")
        });
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if !out.status.success() {
        if text.contains("Unable to find a GPU")
            || text.contains("No suitable adapter")
            || text.contains("adapter") && text.contains("panicked")
        {
            panic!(
                "no GPU adapter was found. Install Mesa's software Vulkan (apt-get install -y mesa-vulkan-drivers libvulkan1). \
                 Output:\n{text}"
            );
        }
        panic!("{} exited with {}:\n{text}", exe.display(), out.status);
    }
    text
}

/// Loads a PNG as RGB.
pub fn load_rgb(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// Number of distinct colours in a region.
pub fn distinct_colours(img: &image::RgbImage, x0: u32, y0: u32, x1: u32, y1: u32) -> usize {
    let mut set = std::collections::HashSet::new();
    for y in y0..y1.min(img.height()) {
        for x in x0..x1.min(img.width()) {
            set.insert(img.get_pixel(x, y).0);
        }
    }
    set.len()
}

/// Runs an example under Xvfb and returns its combined output. `cargo test` builds the package's examples;
/// this builds one itself when run otherwise.
pub fn run_example(package: &str, name: &str, args: &[&str]) -> String {
    let exe = Path::new(env!("CARGO_BIN_EXE_treelight"))
        .parent()
        .unwrap()
        .join("examples")
        .join(name);
    if !exe.exists() {
        let status = Command::new(env!("CARGO"))
            .args(["build", "-p", package, "--example", name])
            .status()
            .expect("cargo runs");
        assert!(status.success());
    }
    run_headless(&exe, args)
}

/// Mean colour of a rectangle.
pub fn mean_rgb(img: &image::RgbImage, x0: u32, y0: u32, x1: u32, y1: u32) -> [f32; 3] {
    let mut sum = [0f32; 3];
    for y in y0..y1 {
        for x in x0..x1 {
            let p = img.get_pixel(x, y);
            for c in 0..3 {
                sum[c] += p[c] as f32;
            }
        }
    }
    sum.map(|s| s / ((x1 - x0) * (y1 - y0)) as f32)
}

/// A panorama: its upper half green towards −Z (u from 1/4 to 3/4), red towards +Z, over a dark
/// ground.
pub fn write_two_sided_sky(path: &std::path::Path) {
    let (w, h) = (128u32, 64u32);
    let img = image::Rgb32FImage::from_fn(w, h, |x, y| {
        let u = (x as f32 + 0.5) / w as f32;
        image::Rgb(if y >= h / 2 {
            [0.05, 0.05, 0.05]
        } else if (0.25..0.75).contains(&u) {
            [0.1, 2.0, 0.1]
        } else {
            [2.0, 0.1, 0.1]
        })
    });
    image::DynamicImage::ImageRgb32F(img).save(path).unwrap();
}

/// Writes `quad.gltf` (with its .bin and image) into `dir` and returns its path: a quad whose first
/// UV set points at the red half of a two-texel texture and whose second points at the green half,
/// its base colour map reading the second set. Drawn right, it is green. With `emission_on_first`,
/// the material also has a faint emission map reading the first set (the red half): it reads both
/// sets, and is still mostly green drawn right.
pub fn write_second_uv_set_quad(dir: &Path, emission_on_first: bool) -> PathBuf {
    let emission = if emission_on_first {
        r#","emissiveTexture":{"index":0},"emissiveFactor":[0.05,0.05,0.05]"#
    } else {
        ""
    };
    let material = format!(
        r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,"texCoord":1}},"metallicFactor":0.0}}{emission}}}"#
    );
    write_red_green_quad(dir, &[[0.25, 0.5], [0.75, 0.5]], &material)
}

/// Writes `quad.gltf` (with its .bin and image) into `dir` and returns its path: a quad whose one
/// UV set points at the red half of a two-texel texture, with a black base colour reading it as it
/// is, and a bright emission map reading it through a `KHR_texture_transform` that moves it onto the
/// green half. Each map read through its own transform, it is green; the emission read through the
/// base colour's, red.
pub fn write_map_transforms_quad(dir: &Path) -> PathBuf {
    let material = r#"{"pbrMetallicRoughness":{"baseColorFactor":[0,0,0,1],"baseColorTexture":{"index":0},"metallicFactor":0.0},"emissiveTexture":{"index":0,"extensions":{"KHR_texture_transform":{"offset":[0.5,0.0]}}},"emissiveFactor":[1,1,1],"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":3000}}}"#;
    write_red_green_quad(dir, &[[0.25, 0.5]], material)
}

/// Writes `quad.gltf`, `quad.bin` and `red-green.png` (a red texel, then a green one) into `dir`:
/// a 2×2 quad on the ground whose corners all have the UV `sets[k]` in `TEXCOORD_k`, drawn with
/// `material` (a glTF material's JSON; its textures' index 0 is the image, sampled nearest).
fn write_red_green_quad(dir: &Path, sets: &[[f32; 2]], material: &str) -> PathBuf {
    image::RgbImage::from_fn(2, 1, |x, _| {
        if x == 0 {
            image::Rgb([230, 20, 20])
        } else {
            image::Rgb([20, 230, 20])
        }
    })
    .save(dir.join("red-green.png"))
    .unwrap();
    let mut bin: Vec<u8> = Vec::new();
    let floats = |bin: &mut Vec<u8>, v: &[f32]| {
        for f in v {
            bin.extend_from_slice(&f.to_le_bytes());
        }
    };
    floats(
        &mut bin,
        &[
            -1.0, 0.0, -1.0, -1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, -1.0,
        ],
    );
    for uv in sets {
        floats(&mut bin, &uv.repeat(4));
    }
    let indices_at = bin.len();
    for i in [0u32, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join("quad.bin"), &bin).unwrap();
    let n = sets.len();
    let texcoords: String = (0..n)
        .map(|k| format!(r#","TEXCOORD_{k}":{}"#, k + 1))
        .collect();
    let uv_accessors: String = (0..n)
        .map(|k| {
            format!(
                r#"{{"bufferView":{},"componentType":5126,"count":4,"type":"VEC2"}},"#,
                k + 1
            )
        })
        .collect();
    let uv_views: String = (0..n)
        .map(|k| {
            format!(
                r#"{{"buffer":0,"byteOffset":{},"byteLength":32}},"#,
                48 + 32 * k
            )
        })
        .collect();
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_texture_transform","KHR_materials_emissive_strength"],"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"name":"quad","mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0{texcoords}}},"indices":{},"material":0}}]}}],
        "materials":[{material}],
        "textures":[{{"source":0,"sampler":0}}],"samplers":[{{"magFilter":9728,"minFilter":9728}}],
        "images":[{{"uri":"red-green.png"}}],
        "accessors":[
          {{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,0,-1],"max":[1,0,1]}},
          {uv_accessors}
          {{"bufferView":{},"componentType":5125,"count":6,"type":"SCALAR"}}],
        "bufferViews":[
          {{"buffer":0,"byteOffset":0,"byteLength":48}},
          {uv_views}
          {{"buffer":0,"byteOffset":{indices_at},"byteLength":24}}],
        "buffers":[{{"uri":"quad.bin","byteLength":{}}}]}}"#,
        n + 1,
        n + 1,
        bin.len()
    );
    let file = dir.join("quad.gltf");
    std::fs::write(&file, gltf).unwrap();
    file
}

/// Pixels of `img` in `x0..x1`, `y0..y1` whose red, and whose green, exceeds both other channels by
/// more than `margin` levels: (red, green).
pub fn red_and_green_pixels(
    img: &image::RgbImage,
    [x0, y0, x1, y1]: [u32; 4],
    margin: i32,
) -> (u32, u32) {
    let (mut red, mut green) = (0u32, 0u32);
    for y in y0..y1.min(img.height()) {
        for x in x0..x1.min(img.width()) {
            let p = img.get_pixel(x, y);
            let (r, g, b) = (i32::from(p[0]), i32::from(p[1]), i32::from(p[2]));
            red += u32::from(r > g.max(b) + margin);
            green += u32::from(g > r.max(b) + margin);
        }
    }
    (red, green)
}
