//! `treelight render`: the default scene path traced to a PNG where there is no display at all,
//! the same image for the same samples, a project's exposure and sky in the picture, and the refusals
//! (an existing file without `--overwrite`, another format, a scene file that does not open); and a
//! render equal to what the editor's viewport accumulates from the same samples.

mod support;
#[path = "support/xdrive.rs"]
mod xdrive;

use support::{
    load_rgb, mean_rgb, run_without_display, shared_scene, temp_dir, write_two_sided_sky,
};

fn render(args: &[&str]) -> (bool, String) {
    run_without_display(&[&["render"], args].concat())
}

fn brightness(img: &image::RgbImage) -> f32 {
    let m = mean_rgb(img, 0, 0, img.width(), img.height());
    (m[0] + m[1] + m[2]) / 3.0
}

#[test]
fn the_default_scene_renders_to_a_png_without_a_display_and_again_the_same() {
    let dir = temp_dir("render");
    let a = dir.join("a.png");
    let b = dir.join("b.png");
    let size = ["--width", "96", "--height", "64", "--spp", "6"];
    let (ok, log) = render(&[&["--out", a.to_str().unwrap()], &size[..]].concat());
    assert!(ok, "{log}");
    let img = load_rgb(&a);
    assert_eq!((img.width(), img.height()), (96, 64));
    // The room, lit: many colours, neither black nor blown out.
    let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(colours.len() > 200, "{} colours", colours.len());
    let mean = brightness(&img);
    assert!((30.0..220.0).contains(&mean), "mean {mean}");
    // The same samples give the same image.
    let (ok, log) = render(&[&["--out", b.to_str().unwrap()], &size[..]].concat());
    assert!(ok, "{log}");
    assert_eq!(
        load_rgb(&a).into_raw(),
        load_rgb(&b).into_raw(),
        "two renders of the same scene differ"
    );
    // Another seed draws other samples of the same picture: other noise, the same light.
    let c = dir.join("c.png");
    let (ok, log) = render(&[&["--out", c.to_str().unwrap(), "--seed", "7"], &size[..]].concat());
    assert!(ok, "{log}");
    let other = load_rgb(&c);
    assert_ne!(
        other.as_raw(),
        img.as_raw(),
        "seed 7 drew the same samples as seed 0"
    );
    let (m0, m7) = (brightness(&img), brightness(&other));
    assert!(
        (m0 - m7).abs() < 0.03 * m0,
        "mean {m0} at seed 0, {m7} at seed 7"
    );
    std::fs::remove_file(&c).ok();

    // An existing file is kept unless --overwrite says otherwise.
    let before = std::fs::read(&a).unwrap();
    let (ok, log) = render(&[&["--out", a.to_str().unwrap()], &size[..]].concat());
    assert!(!ok);
    assert!(
        log.contains("the file exists") && log.contains("a.png"),
        "{log}"
    );
    assert_eq!(std::fs::read(&a).unwrap(), before);
    let (ok, log) = render(&["--out", a.to_str().unwrap(), "--overwrite", "--spp", "1"]);
    assert!(ok, "{log}");
    assert_eq!(load_rgb(&a).width(), 640, "the default size");

    // Only PNG; a scene that does not open names itself and writes nothing.
    let (ok, log) = render(&["--out", dir.join("c.jpg").to_str().unwrap()]);
    assert!(!ok && log.contains("must be a .png"), "{log}");
    let missing = dir.join("missing.glb");
    let d = dir.join("d.png");
    let (ok, log) = render(&[missing.to_str().unwrap(), "--out", d.to_str().unwrap()]);
    assert!(!ok, "{log}");
    assert!(log.contains("missing.glb"), "{log}");
    assert!(!d.exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// The default scene with `edits` applied, saved as `name`.treelight in `dir`.
fn project_with(dir: &std::path::Path, name: &str, edits: &str) -> std::path::PathBuf {
    let script = dir.join(format!("{name}.ron"));
    std::fs::write(&script, edits).unwrap();
    let project = dir.join(format!("{name}.treelight"));
    let (ok, log) = run_without_display(&[
        "--commands",
        script.to_str().unwrap(),
        "--save",
        project.to_str().unwrap(),
    ]);
    assert!(ok, "{log}");
    project
}

#[test]
fn a_project_s_exposure_is_in_its_render() {
    let dir = temp_dir("render-look");
    let size = ["--width", "64", "--height", "48", "--spp", "4"];
    // The default scene, then a project of it (or none) rendered to `out`.
    let render_to = |project: Option<&std::path::Path>, out: &std::path::Path| {
        let scene: Vec<&str> = project.map(|p| p.to_str().unwrap()).into_iter().collect();
        let (ok, log) =
            render(&[&scene[..], &["--out", out.to_str().unwrap()], &size[..]].concat());
        assert!(ok, "{log}");
        load_rgb(out)
    };
    let plain = render_to(None, &dir.join("plain.png"));
    let bright_project = project_with(
        &dir,
        "bright",
        "[SetLook(look: (exposure: 2.0, tone: Filmic))]",
    );
    let bright = render_to(Some(&bright_project), &dir.join("bright.png"));
    let (p, b) = (brightness(&plain), brightness(&bright));
    assert!(b > p * 1.3, "two stops more: mean {p} -> {b}");
    // A red sky: seen through the room's open front and lighting it, the picture turns red.
    let red_project = project_with(
        &dir,
        "red",
        "[SetLook(look: (exposure: 0.0, tone: Filmic, sky: (400.0, 20.0, 10.0)))]",
    );
    let red = render_to(Some(&red_project), &dir.join("red.png"));
    let rgb = |img: &image::RgbImage| mean_rgb(img, 0, 0, img.width(), img.height());
    let (before, after) = (rgb(&plain), rgb(&red));
    assert!(
        after[0] - after[2] > before[0] - before[2] + 10.0,
        "the sky's red: {before:?} -> {after:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_project_s_sky_panorama_is_seen_turned_and_hidden_in_its_render() {
    let dir = temp_dir("render-sky");
    let sky = dir.join("two-sided.hdr");
    write_two_sided_sky(&sky);
    let size = ["--width", "64", "--height", "48", "--spp", "4"];
    let render_project = |name: &str, environment: &str| {
        let project = project_with(
            &dir,
            name,
            &format!("[SetEnvironment(environment: {environment})]"),
        );
        let out = dir.join(format!("{name}.png"));
        let (ok, log) = render(
            &[
                &[project.to_str().unwrap(), "--out", out.to_str().unwrap()][..],
                &size[..],
            ]
            .concat(),
        );
        (ok, log, out)
    };
    let sky_path = sky.to_str().unwrap();
    let shot = |name: &str, rotation: f32, shown: bool| {
        let (ok, log, out) = render_project(
            name,
            &format!(
                "(image: Some({sky_path:?}), rotation_degrees: {rotation:.1}, intensity: 150.0, \
                 shown: {shown})"
            ),
        );
        assert!(ok, "{log}");
        load_rgb(&out)
    };
    // The default view looks into the room along −Z: the sky above its roof is the panorama's
    // green half, and the red half once the panorama turns half round.
    let corner = |img: &image::RgbImage| mean_rgb(img, 0, 0, 8, 6);
    let front = corner(&shot("front", 0.0, true));
    assert!(front[1] > 2.0 * front[0] && front[1] > 60.0, "{front:?}");
    let turned = corner(&shot("turned", 180.0, true));
    assert!(
        turned[0] > 2.0 * turned[1] && turned[0] > 60.0,
        "{turned:?}"
    );
    // Hidden, the corner shows the look's sky colour, as a render without a panorama does.
    let plain = dir.join("plain.png");
    let (ok, log) = render(&[&["--out", plain.to_str().unwrap()][..], &size[..]].concat());
    assert!(ok, "{log}");
    let hidden = corner(&shot("hidden", 0.0, false));
    let flat = corner(&load_rgb(&plain));
    assert!(
        hidden.iter().zip(flat).all(|(a, b)| (a - b).abs() < 6.0),
        "{hidden:?} vs {flat:?}"
    );
    // `--sky` lights a scene without a project the same way, `--sky-rotation` turns it, and both
    // override a project's own.
    let with_sky = |name: &str, scene: Option<&str>, extra: &[&str]| {
        let out = dir.join(format!("{name}.png"));
        let mut args: Vec<&str> = scene.into_iter().collect();
        args.extend(["--out", out.to_str().unwrap()]);
        args.extend(extra);
        args.extend(size);
        let (ok, log) = render(&args);
        (ok, log, out)
    };
    let (ok, log, out) = with_sky("cli", None, &["--sky", sky_path, "--sky-intensity", "150"]);
    assert!(ok, "{log}");
    let cli = corner(&load_rgb(&out));
    assert!(
        cli.iter().zip(front).all(|(a, b)| (a - b).abs() < 6.0),
        "--sky {cli:?} vs the project's {front:?}"
    );
    let (ok, log, out) = with_sky(
        "cli-turned",
        None,
        &[
            "--sky",
            sky_path,
            "--sky-intensity=150",
            "--sky-rotation=-180",
        ],
    );
    assert!(ok, "{log}");
    let cli_turned = corner(&load_rgb(&out));
    assert!(cli_turned[0] > 2.0 * cli_turned[1], "{cli_turned:?}");
    let turned_project = dir.join("turned.treelight");
    let (ok, log, out) = with_sky(
        "unturned",
        Some(turned_project.to_str().unwrap()),
        &["--sky-rotation", "0"],
    );
    assert!(ok, "{log}");
    let unturned = corner(&load_rgb(&out));
    assert!(unturned[1] > 2.0 * unturned[0], "{unturned:?}");
    std::fs::create_dir_all(dir.join("folder.hdr")).unwrap();
    for (bad, why) in [
        (dir.join("missing.hdr"), "no such file"),
        // A folder named like a panorama: refused before anything is read.
        (dir.join("folder.hdr"), "not a regular file"),
        (dir.join("plain.png"), "must be a .hdr or .exr"),
    ] {
        let (ok, log, out) = with_sky("refused", None, &["--sky", bad.to_str().unwrap()]);
        let name = bad.file_name().unwrap().to_str().unwrap();
        assert!(!ok && log.contains(name) && log.contains(why), "{log}");
        assert!(!out.exists());
    }

    // A panorama that is not one ends the render with its name, and writes nothing.
    let broken = dir.join("broken.hdr");
    std::fs::write(&broken, b"#?RADIANCE\n\n-Y 4 +X 8\n").unwrap();
    let project = dir.join("broken.treelight");
    let text = std::fs::read_to_string(dir.join("front.treelight")).unwrap();
    assert!(
        text.contains("\"two-sided.hdr\""),
        "stored beside the project: {text}"
    );
    std::fs::write(&project, text.replace("two-sided.hdr", "broken.hdr")).unwrap();
    let out = dir.join("broken.png");
    let (ok, log) = render(
        &[
            &[project.to_str().unwrap(), "--out", out.to_str().unwrap()][..],
            &size[..],
        ]
        .concat(),
    );
    assert!(!ok && log.contains("broken.hdr"), "{log}");
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_render_through_a_file_s_camera_sees_what_that_camera_sees() {
    let dir = temp_dir("render-camera");
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("plugins/import/tests/data/cameras.gltf");
    let scene = scene.to_str().unwrap();
    let size = ["--width", "64", "--height", "40", "--spp", "4"];
    let shot = |camera: &str| {
        let out = dir.join(format!("{camera}.png"));
        let (ok, log) = render(
            &[
                &[scene, "--out", out.to_str().unwrap(), "--camera", camera][..],
                &size[..],
            ]
            .concat(),
        );
        assert!(ok, "{log}");
        load_rgb(&out)
    };
    // From the front, the red card fills the middle of the picture; from the side it is edge-on,
    // and from the top (orthographic, looking down) it is a line too.
    let red = |img: &image::RgbImage| {
        let m = mean_rgb(img, 28, 16, 36, 24);
        m[0] > 2.0 * m[1] && m[0] > 2.0 * m[2] && m[0] > 20.0
    };
    let front = shot("Front");
    assert!(red(&front), "the front camera does not see the card");
    assert!(!red(&shot("Side")), "the side camera sees the card face on");
    assert!(!red(&shot("Top")), "the top camera sees the card face on");
    // A name the file does not have is refused, with the names it has.
    let (ok, log) = render(&[
        scene,
        "--out",
        dir.join("nope.png").to_str().unwrap(),
        "--camera",
        "Nope",
    ]);
    assert!(!ok, "{log}");
    assert!(
        log.contains("no camera named 'Nope'") && log.contains("Front") && log.contains("Top"),
        "{log}"
    );
    assert!(!dir.join("nope.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_exr_render_holds_the_exposed_radiance_that_the_png_shows_clipped() {
    let dir = temp_dir("render-exr");
    let size = ["--width", "48", "--height", "32", "--spp", "4"];
    // With no tone curve, the PNG is the same samples clipped at 1 and sRGB-encoded.
    let project = project_with(&dir, "clip", "[SetLook(look: (exposure: 0.0, tone: None))]");
    let shot = |name: &str| {
        let out = dir.join(name);
        let (ok, log) = render(
            &[
                &[project.to_str().unwrap(), "--out", out.to_str().unwrap()][..],
                &size[..],
            ]
            .concat(),
        );
        assert!(ok, "{log}");
        out
    };
    let exr = image::open(shot("linear.exr")).unwrap().to_rgb32f();
    let png = load_rgb(&shot("clipped.png"));
    assert_eq!(exr.dimensions(), png.dimensions());
    assert!(
        exr.pixels()
            .flat_map(|p| p.0)
            .all(|v| v.is_finite() && v >= 0.0)
    );
    // The lamp is brighter than white: the EXR keeps what the PNG clips.
    assert!(exr.pixels().any(|p| p.0.iter().any(|&v| v > 1.5)));
    let srgb = |v: f32| {
        let v = v.clamp(0.0, 1.0);
        let s = if v <= 0.003_130_8 {
            v * 12.92
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        s * 255.0
    };
    let mut worst = 0.0f32;
    for (e, p) in exr.pixels().zip(png.pixels()) {
        for c in 0..3 {
            worst = worst.max((srgb(e.0[c]) - f32::from(p.0[c])).abs());
        }
    }
    // Half floats and the PNG's dither: a few levels at most.
    assert!(worst <= 4.0, "a pixel {worst} levels off");
    // Other formats are refused before anything is rendered.
    let jpg = dir.join("x.jpg");
    let (ok, log) = render(&["--out", jpg.to_str().unwrap()]);
    assert!(!ok && log.contains("must be a .png or .exr file"), "{log}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The viewport's path-traced view, once it has its samples, against `treelight render` of the same
/// scene, view and size at the same samples: each pixel's n-th sample draws from (pixel, n) alone,
/// so the two are the same image (up to Bevy's dither, which follows the pixel's place on the
/// screen, and what the editor draws over the view).
#[test]
fn a_render_equals_the_viewport_s_accumulation_at_the_same_samples() {
    // The viewport carries its picture through camera moves until a pixel has
    // `TEMPORAL_FADE_SAMPLES` of its own; from there on it shows its samples alone, as a render does.
    const SPP: u32 = treelight_render::TEMPORAL_FADE_SAMPLES as u32;
    let mut s = xdrive::Session::start(
        "render-equals-viewport",
        &[
            // A small window (a viewport of 277 × 358 pixels beside the panels): each of its
            // pixels takes 16 full samples on CI's two cores.
            "--width",
            "640",
            "--height",
            "440",
            "--samples",
            &SPP.to_string(),
            "--trace-scale",
            "1",
            "--frame-budget",
            "0",
        ],
    );
    // The denoiser makes a pass a frame: its last run over the samples ends frames after them.
    let state = s.wait_until(
        "the viewport's samples, denoised",
        std::time::Duration::from_secs(300),
        |st| st.samples >= SPP && !st.denoising,
    );
    assert_eq!(state.samples, SPP, "the viewport stops at --samples");
    // Let the picture reach the screen.
    let state = s.frames(3);
    assert_eq!(state.samples, SPP);
    let shot = s.screenshot();
    let [x, y, w, h] = state.viewport.map(|v| v as u32);
    assert!(w > 200 && h > 150, "viewport {:?}", state.viewport);
    let viewport = image::imageops::crop_imm(&shot, x, y, w, h).to_image();
    viewport.save(s.dir().join("viewport.png")).unwrap();

    let out = s.dir().join("render.png");
    let (ok, log) = render(&[
        "--out",
        out.to_str().unwrap(),
        "--spp",
        &SPP.to_string(),
        "--width",
        &w.to_string(),
        "--height",
        &h.to_string(),
    ]);
    assert!(ok, "{log}");
    let rendered = load_rgb(&out);
    // What the editor draws over the view: the toolbar along its top and the lights' icons.
    let bar = xdrive::widget_rect(&state, "Viewport toolbar");
    let toolbar = bar[1] + bar[3] + 2.0 - y as f32;
    let icons: Vec<[f32; 2]> = state
        .objects
        .iter()
        .filter(|o| o.light.is_some())
        .filter_map(|o| o.screen)
        .map(|p| [p[0] - x as f32, p[1] - y as f32])
        .collect();
    let drawn_over = |px: u32, py: u32| {
        let (px, py) = (px as f32 + 0.5, py as f32 + 0.5);
        py < toolbar
            || icons
                .iter()
                .any(|c| (px - c[0]).powi(2) + (py - c[1]).powi(2) < 16.0 * 16.0)
    };
    let (mut compared, mut far, mut sum) = (0u64, 0u64, 0u64);
    for (px, py, a) in viewport.enumerate_pixels() {
        if drawn_over(px, py) {
            continue;
        }
        let b = rendered.get_pixel(px, py);
        let d = (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap();
        compared += 1;
        sum += u64::from(d);
        if d > 2 {
            far += 1;
        }
    }
    let mean = sum as f64 / compared as f64;
    // Bevy's dither moves a level or two; other samples would move most pixels by several.
    assert!(
        compared * 10 > u64::from(w * h) * 8,
        "{compared} pixels compared"
    );
    assert!(
        far == 0 && mean < 1.0,
        "{far} of {compared} pixels differ by more than 2 levels, mean difference {mean:.2}; see {}",
        s.dir().display()
    );
}

/// Renders `scene` at 96×64 and 4 samples a pixel into `out`: its red and its green pixels
/// (`support::red_and_green_pixels`, 40 levels clear of the other channels).
fn red_and_green_render(scene: &std::path::Path, out: &std::path::Path) -> (u32, u32) {
    let (ok, log) = render(&[
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--width",
        "96",
        "--height",
        "64",
        "--spp",
        "4",
    ]);
    assert!(ok, "{log}");
    let img = load_rgb(out);
    support::red_and_green_pixels(&img, [0, 0, img.width(), img.height()], 40)
}

/// A material that reads its maps through the second UV set is path traced through it, as the
/// raster view draws it: the quad is its texture's green half, no pixel the red half of set 0;
/// so too when another of its maps reads set 0 (the shading records then hold both sets).
#[test]
fn a_map_on_the_second_uv_set_is_path_traced_through_it() {
    let dir = temp_dir("render-uv-set-1");
    for emission_on_first in [false, true] {
        let quad = support::write_second_uv_set_quad(&dir, emission_on_first);
        let out = dir.join(format!("quad-{emission_on_first}.png"));
        let (red, green) = red_and_green_render(&quad, &out);
        assert!(
            green > 96 * 64 / 8 && red == 0,
            "the quad is not the second set's green (emission on set 0: {emission_on_first}): \
             {green} green pixels, {red} red; see {}",
            out.display()
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Maps with their own `KHR_texture_transform`s are path traced each through its own: the quad's
/// emission map, moved by its transform onto the texture's green half, makes it green; read through
/// the base colour's transform (the first map's, all the raster view has), it would be red.
#[test]
fn maps_with_their_own_texture_transforms_are_path_traced_through_each() {
    let dir = temp_dir("render-map-transforms");
    let quad = support::write_map_transforms_quad(&dir);
    let out = dir.join("quad.png");
    let (red, green) = red_and_green_render(&quad, &out);
    assert!(
        green > 96 * 64 / 8 && red == 0,
        "the quad's emission is not its own transform's green: {green} green pixels, {red} red; \
         see {}",
        out.display()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A textured assembly renders the same twice, denoised: the scene worker rebuilds its meshes
/// while the samples accumulate (without restarting them), and the denoiser, guided by the object
/// each pixel's first sample hit, sees each mesh as the same object before and after.
#[test]
fn a_gltf_assembly_renders_the_same_twice_denoised() {
    let dir = temp_dir("render-helmet");
    let helmet = shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let helmet = helmet.to_str().unwrap();
    let images: Vec<Vec<u8>> = ["a.png", "b.png"]
        .iter()
        .map(|name| {
            let out = dir.join(name);
            let (ok, log) = render(&[
                helmet,
                "--out",
                out.to_str().unwrap(),
                "--width",
                "160",
                "--height",
                "100",
                "--spp",
                "16",
                "--denoise",
                "on",
            ]);
            assert!(ok, "{log}");
            // A render holds each mesh once, in the tree: every mesh the file opened with had
            // its vertex data freed once traced (and the image is still the viewport's, below).
            assert_eq!(
                log_figure(&log, "meshes' vertex data freed"),
                log_figure(&log, "meshes, "),
                "{log}"
            );
            load_rgb(&out).into_raw()
        })
        .collect();
    assert!(images[0] == images[1], "two denoised renders differ");
    std::fs::remove_dir_all(&dir).ok();
}

/// The number just before `words` in the first line of `log` that holds them.
fn log_figure(log: &str, words: &str) -> u64 {
    let line = log
        .lines()
        .find(|l| l.contains(words))
        .unwrap_or_else(|| panic!("no {words:?} in the log:\n{log}"));
    let before = line.split(words).next().unwrap_or("").trim_end();
    let number = before.rsplit([' ', '(']).next().unwrap_or("");
    number
        .parse()
        .unwrap_or_else(|_| panic!("no number before {words:?} in {line:?}"))
}

/// The rounds `treelight render`'s log says were handed to the GPU before their frame's end.
fn upload_rounds(log: &str) -> u64 {
    log_figure(log, " rounds handed over")
}

/// A scene whose records are handed to the GPU in rounds of 16 KiB while they are made (the
/// buffers grown before the first, the writes left over after the frame's end) renders as the same
/// scene handed over whole at the end of each frame.
#[test]
fn a_scene_uploaded_in_small_rounds_renders_as_one_uploaded_whole() {
    let dir = temp_dir("render-rounds");
    let helmet = shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let helmet = helmet.to_str().unwrap();
    let mut runs = Vec::new();
    for (name, round) in [("whole.png", None), ("rounds.png", Some("16"))] {
        let out = dir.join(name);
        let mut args = vec![
            helmet,
            "--out",
            out.to_str().unwrap(),
            "--width",
            "96",
            "--height",
            "64",
            "--spp",
            "4",
            "--denoise",
            "off",
        ];
        if let Some(kib) = round {
            args.extend(["--upload-round", kib]);
        }
        let (ok, log) = render(&args);
        assert!(ok, "{log}");
        runs.push((load_rgb(&out).into_raw(), upload_rounds(&log)));
    }
    // The helmet's records are megabytes: many rounds of 16 KiB, few or none of the default's.
    assert!(
        runs[1].1 > 50 && runs[1].1 > 10 * runs[0].1,
        "{} rounds of 16 KiB, {} of the default size",
        runs[1].1,
        runs[0].1
    );
    assert!(
        runs[0].0 == runs[1].0,
        "the render uploaded in rounds differs from the one uploaded whole"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Writes `NAME.gltf` (and the shared `floor.bin`) into `dir`: a 20 m floor at y = 0 of base colour
/// 0.5 with no specular reflection (`KHR_materials_specular` factor 0: a Lambert surface, radiance
/// = 0.5 × irradiance / π), glowing at `glow` nits (`KHR_materials_emissive_strength`, base colour
/// then black), a camera named Top 5 m above its centre looking down, and `light` (a
/// `KHR_lights_punctual` light's JSON) on a node at `height` above the centre, pointing down.
fn write_lit_floor(
    dir: &std::path::Path,
    name: &str,
    light: Option<(&str, f32)>,
    glow: f32,
) -> String {
    let mut bin: Vec<u8> = Vec::new();
    for v in [
        -10.0f32, 0.0, -10.0, -10.0, 0.0, 10.0, 10.0, 0.0, 10.0, 10.0, 0.0, -10.0,
    ] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u32, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join("floor.bin"), &bin).unwrap();
    let down = "[-0.70710678,0,0,0.70710678]";
    let (lights, light_node, node_ref) = match light {
        Some((json, height)) => (
            format!(r#","extensions":{{"KHR_lights_punctual":{{"lights":[{json}]}}}}"#),
            format!(
                r#",{{"name":"light","translation":[0,{height},0],"rotation":{down},"extensions":{{"KHR_lights_punctual":{{"light":0}}}}}}"#
            ),
            ",2",
        ),
        None => (String::new(), String::new(), ""),
    };
    let (base, emissive) = if glow > 0.0 {
        (
            "[0,0,0,1]",
            format!(
                r#","emissiveFactor":[1,1,1],"extensions":{{"KHR_materials_specular":{{"specularFactor":0}},"KHR_materials_emissive_strength":{{"emissiveStrength":{glow}}}}}"#
            ),
        )
    } else {
        (
            "[0.5,0.5,0.5,1]",
            r#","extensions":{"KHR_materials_specular":{"specularFactor":0}}"#.to_string(),
        )
    };
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_lights_punctual","KHR_materials_specular","KHR_materials_emissive_strength"]{lights},
        "scene":0,"scenes":[{{"nodes":[0,1{node_ref}]}}],
        "nodes":[{{"name":"floor","mesh":0}},{{"name":"Top","camera":0,"translation":[0,5,0],"rotation":{down}}}{light_node}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.5,"aspectRatio":1.0,"znear":0.1}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
        "materials":[{{"doubleSided":true,"pbrMetallicRoughness":{{"baseColorFactor":{base},"metallicFactor":0.0,"roughnessFactor":1.0}}{emissive}}}],
        "accessors":[
          {{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-10,0,-10],"max":[10,0,10]}},
          {{"bufferView":1,"componentType":5125,"count":6,"type":"SCALAR"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":24}}],
        "buffers":[{{"uri":"floor.bin","byteLength":72}}]}}"#
    );
    let file = dir.join(format!("{name}.gltf"));
    std::fs::write(&file, gltf).unwrap();
    file.to_str().unwrap().to_owned()
}

/// KHR_lights_punctual's and KHR_materials_emissive_strength's units, end to end through import,
/// the document, Bevy's components and the kernel, against the specifications' definitions:
/// a point or spot light of I candela (lumens per steradian) at distance d gives I cos θ / d² lux;
/// a directional light of E lux gives E lux on a surface facing it; a Lambert surface of albedo ρ
/// under E lux shows ρ E / π nits; an emissive surface of factor 1 and strength S shows S nits. A
/// light without `range` is unlimited (a point light 30 m up loses nothing to a window), and a file
/// without lights gets the 8,000 lux default sun unless `--default-sun off`. The EXR holds the
/// radiance times the camera's exposure, 2^-EV100 / 1.2 at the default EV100 (Bevy's camera).
#[test]
fn light_units_are_the_gltf_specification_s() {
    let dir = temp_dir("render-light-units");
    let render_exr = |scene: &str, sun: &str| {
        let out = dir.join(format!("{}-{sun}.exr", scene.rsplit('/').next().unwrap()));
        let (ok, log) = render(&[
            scene,
            "--out",
            out.to_str().unwrap(),
            "--camera",
            "Top",
            "--width",
            "32",
            "--height",
            "32",
            "--spp",
            "4",
            "--denoise",
            "off",
            "--default-sun",
            sun,
            "--overwrite",
        ]);
        assert!(ok, "{log}");
        image::open(&out).unwrap().to_rgb32f()
    };
    // Nits per EXR unit, and where on the floor each of the centre pixels looks.
    let exposure = 2f32.powf(-treelight_document::values::look::DEFAULT_EV100) / 1.2;
    let glow = render_exr(&write_lit_floor(&dir, "glow", None, 2000.0), "off");
    let centre = |img: &image::Rgb32FImage| {
        let mut sum = [0.0f32; 3];
        for y in 14..18 {
            for x in 14..18 {
                for (s, v) in sum.iter_mut().zip(img.get_pixel(x, y).0) {
                    *s += v / 16.0;
                }
            }
        }
        sum
    };
    let close = |what: &str, got: [f32; 3], want: f32| {
        for g in got {
            assert!(
                (g / want - 1.0).abs() < 0.01,
                "{what}: {got:?} nits, the specification says {want}"
            );
        }
    };
    close(
        "an emissive floor of strength 2000",
        centre(&glow).map(|v| v / exposure),
        2000.0,
    );
    let plain = centre(&render_exr(
        &write_lit_floor(&dir, "plain", None, 0.0),
        "off",
    ));
    // The light each adds at the centre, in nits: the render less the unlit floor's (the sky).
    let added = |name: &str, light: &str, height: f32| {
        let scene = write_lit_floor(&dir, name, Some((light, height)), 0.0);
        let lit = centre(&render_exr(&scene, "off"));
        [0, 1, 2].map(|c| (lit[c] - plain[c]) / exposure)
    };
    let lambert = |lux: f32| 0.5 * lux / std::f32::consts::PI;
    // A light of I cd at height h over the floor: I h / (h² + r²)^1.5 lux at r from its foot,
    // averaged over what the centre pixels see (each 2 × 5 m × tan(0.25) / 32 across).
    let under = |candela: f32, h: f32| {
        let pixel = 10.0 * 0.25f32.tan() / 32.0;
        let mut sum = 0.0;
        let n = 64;
        for i in 0..n {
            for j in 0..n {
                let at = |k: u32| (k as f32 + 0.5) / n as f32 * 4.0 * pixel - 2.0 * pixel;
                let r2 = at(i).powi(2) + at(j).powi(2);
                sum += candela * h / (h * h + r2).powf(1.5);
            }
        }
        sum / (n * n) as f32
    };
    close(
        "a point light of 4000 cd 2 m up",
        added("point", r#"{"type":"point","intensity":4000}"#, 2.0),
        lambert(under(4000.0, 2.0)),
    );
    close(
        "a spot light of 4000 cd 2 m up, inside its cone",
        added(
            "spot",
            r#"{"type":"spot","intensity":4000,"spot":{"innerConeAngle":0.3,"outerConeAngle":0.5}}"#,
            2.0,
        ),
        lambert(under(4000.0, 2.0)),
    );
    close(
        "a directional light of 1000 lux",
        added("sun", r#"{"type":"directional","intensity":1000}"#, 3.0),
        lambert(1000.0),
    );
    close(
        "a point light of 900,000 cd 30 m up, without range",
        added("far", r#"{"type":"point","intensity":900000}"#, 30.0),
        lambert(under(900_000.0, 30.0)),
    );
    // The default sun: 8,000 lux from (1, 3, 2) towards the centre, so cos θ = 3 / √14.
    let sunny = centre(&render_exr(
        &write_lit_floor(&dir, "plain", None, 0.0),
        "on",
    ));
    close(
        "the default sun",
        [0, 1, 2].map(|c| (sunny[c] - plain[c]) / exposure),
        lambert(8000.0 * 3.0 / 14f32.sqrt()),
    );
    std::fs::remove_dir_all(&dir).ok();
}
