//! A day's work is never lost, and nothing is written that the user did not choose: the real
//! editor binary, killed and started again on a project; links, pipes and broken files planted
//! where the editor keeps its own; keys typed into a text field on a slow frame; `render --out`
//! through a dangling link; `--save` and `info` on what the user made.

#[path = "../plugins/document/tests/support/assembly.rs"]
mod assembly;
mod support;
#[path = "support/xdrive.rs"]
mod xdrive;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use support::{run_without_display, shared_scene, temp_dir};
use xdrive::{Session, keysym, object};

fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.as_os_str().as_encoded_bytes()).unwrap();
    // SAFETY: a valid C string naming a path; mkfifo only reads it.
    assert_eq!(
        unsafe { libc::mkfifo(c.as_ptr(), 0o600) },
        0,
        "mkfifo {path:?}"
    );
}

fn fresh(name: &str) -> PathBuf {
    let d = temp_dir(name);
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The default scene saved as `dir/house.treelight` by the real binary, without a display.
fn house(dir: &Path) -> PathBuf {
    let path = dir.join("house.treelight");
    let (ok, log) = run_without_display(&["--save", path.to_str().unwrap()]);
    assert!(ok, "{log}");
    path
}

/// Starts the editor once it draws frames (not waiting for the scene to settle).
fn start_drawing(name: &str, args: &[&str], env: &[(&str, &str)]) -> Session {
    Session::start_until(name, args, env, "the editor's first frames", |s| {
        s.frame > 3
    })
}

#[test]
fn a_project_killed_mid_edit_is_offered_its_own_copy_and_never_another_scenes() {
    let dir = fresh("trust-killed");
    let cache = dir.join("cache");
    let project = house(&dir);
    let env = [
        ("TREELIGHT_CACHE_DIR", cache.to_str().unwrap()),
        ("TREELIGHT_AUTOSAVE_SECS", "1"),
    ];
    let copy = dir.join(".house.recovery.treelight");
    {
        let mut s = Session::start_with("trust-killed-1", &[project.to_str().unwrap()], &env);
        let st = s.frames(1);
        let sphere = object(&st, "Sphere").clone();
        s.click(sphere.screen.unwrap()[0], sphere.screen.unwrap()[1]);
        s.key(&[], keysym::DELETE);
        let start = Instant::now();
        while !copy.exists() {
            assert!(
                start.elapsed().as_secs() < 30,
                "no recovery copy was written"
            );
            s.frames(1);
        }
        // Dropping the session kills the editor (SIGKILL): no chance to save.
    }
    // An unsaved scene's copy left by another editor that died, newer than the house's.
    let other = cache.join("unsaved-4000700.recovery.treelight");
    let text = std::fs::read_to_string(&copy).unwrap();
    let body = text.split_once('\n').unwrap().1;
    let header = treelight_document::project::recovery::HEADER;
    std::fs::write(&other, format!("{header}4000700\n{body}")).unwrap();
    let mut s = Session::start_until(
        "trust-killed-2",
        &[project.to_str().unwrap()],
        &env,
        "the offer",
        |st| !st.recovery_offer.is_empty(),
    );
    let st = s.frames(1);
    assert_eq!(
        st.recovery_offer,
        vec![copy.clone()],
        "the house's own copy only"
    );
    // Return opens it: the house with its unsaved work, titled so.
    s.key(&[], keysym::RETURN);
    let st = s.wait_until("the recovered scene", Duration::from_secs(60), |st| {
        st.objects.iter().all(|o| o.name != "Sphere") && st.dirty
    });
    assert_eq!(st.project.as_deref(), Some(project.as_path()));
    // Saved: the house holds the work, its copy is gone, the other scene's copy stays.
    s.key(&[keysym::CONTROL], keysym::letter('s'));
    s.wait_until("the save", Duration::from_secs(30), |st| !st.dirty);
    assert!(!copy.exists(), "the recovered copy was left");
    assert!(other.exists(), "another scene's copy was removed unasked");
    let saved = std::fs::read_to_string(&project).unwrap();
    assert!(!saved.contains("\"Sphere\""), "the save lacks the work");
    drop(s);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_link_planted_as_the_recovery_copy_is_never_written_through() {
    let dir = fresh("trust-link");
    let project = house(&dir);
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "the user's own file").unwrap();
    std::os::unix::fs::symlink(&victim, dir.join(".house.recovery.treelight")).unwrap();
    let mut s = Session::start_with(
        "trust-link",
        &[project.to_str().unwrap()],
        &[("TREELIGHT_AUTOSAVE_SECS", "1")],
    );
    let st = s.frames(1);
    let sphere = object(&st, "Sphere").clone();
    s.click(sphere.screen.unwrap()[0], sphere.screen.unwrap()[1]);
    s.key(&[], keysym::DELETE);
    let st = s.wait_until("the notice", Duration::from_secs(30), |st| {
        st.notices.iter().any(|n| n.contains("is a link"))
    });
    // The work is copied under the editor's own name beside the project, the link untouched.
    let start = Instant::now();
    let own = loop {
        let found = std::fs::read_dir(&dir).unwrap().flatten().find(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.starts_with(".house.recovery-") && n.ends_with(".treelight")
        });
        if let Some(e) = found {
            break e.path();
        }
        assert!(start.elapsed().as_secs() < 30, "no copy: {:?}", st.notices);
        s.frames(1);
    };
    assert!(
        std::fs::read_to_string(own)
            .unwrap()
            .contains("treelight recovery copy")
    );
    assert_eq!(
        std::fs::read_to_string(&victim).unwrap(),
        "the user's own file"
    );
    drop(s);
    std::fs::remove_dir_all(&dir).ok();
}

/// Puts something the editor cannot use at a path.
type Plant = dyn Fn(&Path);

/// Settings files the editor cannot use: each is set aside as `settings.ron.bad`, a notice
/// says so, and the editor starts with the defaults.
#[test]
fn settings_the_editor_cannot_use_are_set_aside_and_it_starts() {
    let cases: [(&str, &Plant); 5] = [
        ("an empty layout", &|p| {
            std::fs::write(
                p,
                "(version: 1, layout: (surfaces: [], focused_surface: None), grid_step: 1.0, \
                 angle_step_deg: 15.0, scale_step: 0.1)",
            )
            .unwrap()
        }),
        ("wrong types", &|p| {
            std::fs::write(p, "(version: \"one\", layout: 7)").unwrap()
        }),
        ("a pipe", &|p| mkfifo(p)),
        ("a link to a device", &|p| {
            std::os::unix::fs::symlink("/dev/zero", p).unwrap()
        }),
        ("a huge file", &|p| {
            let f = std::fs::File::create(p).unwrap();
            f.set_len(3 << 30).unwrap();
        }),
    ];
    for (k, (what, plant)) in cases.iter().enumerate() {
        let config = fresh(&format!("trust-settings-{k}"));
        let settings = config.join("settings.ron");
        plant(&settings);
        let started = Instant::now();
        let mut s = start_drawing(
            &format!("trust-settings-run-{k}"),
            &[],
            &[("TREELIGHT_CONFIG_DIR", config.to_str().unwrap())],
        );
        let st = s.frames(2);
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "{what}: slow start"
        );
        assert!(
            st.notices.iter().any(|n| n.contains("settings.ron")),
            "{what}: {:?}",
            st.notices
        );
        assert!(
            config.join("settings.ron.bad").symlink_metadata().is_ok(),
            "{what}"
        );
        drop(s);
        std::fs::remove_dir_all(&config).ok();
    }
}

#[test]
fn pipes_where_the_editor_keeps_its_files_do_not_stop_the_start() {
    let dir = fresh("trust-fifos");
    let project = house(&dir);
    let cache = dir.join("cache");
    std::fs::create_dir_all(&cache).unwrap();
    // Another editor's lock, a crash report, an unsaved copy, and the project's recovery copy:
    // all pipes, which a plain open would wait on for ever.
    for name in [
        "editor-4000800.lock",
        "crash-4000800.txt",
        "unsaved-4000800.recovery.treelight",
    ] {
        mkfifo(&cache.join(name));
    }
    mkfifo(&dir.join(".house.recovery.treelight"));
    let mut s = start_drawing(
        "trust-fifos",
        &[project.to_str().unwrap()],
        &[("TREELIGHT_CACHE_DIR", cache.to_str().unwrap())],
    );
    let st = s.wait_until("the project", Duration::from_secs(60), |st| {
        st.project.is_some()
    });
    assert!(st.recovery_offer.is_empty(), "{:?}", st.recovery_offer);
    drop(s);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn keys_typed_into_the_rename_field_on_slow_frames_stay_there() {
    let mut s = Session::start("trust-keys", &["--max-fps", "3"]);
    let st = s.frames(1);
    let sphere = object(&st, "Sphere").clone();
    s.click(sphere.screen.unwrap()[0], sphere.screen.unwrap()[1]);
    assert_eq!(s.frames(2).selection, vec![sphere.id]);
    s.key(&[], keysym::F2);
    s.frames(2);
    // Typed quicker than the frames come: a letter, Delete (in the field) and Return.
    for sym in [keysym::letter('x'), keysym::DELETE, keysym::RETURN] {
        s.key_event(sym, true);
        s.key_event(sym, false);
    }
    let st = s.frames(6);
    let again = st.objects.iter().find(|o| o.id == sphere.id);
    assert!(
        again.is_some(),
        "the Delete typed into the field deleted the object"
    );
}

#[test]
fn render_out_through_a_dangling_link_is_refused_unless_overwrite() {
    let dir = fresh("trust-render-link");
    let elsewhere = dir.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let target = elsewhere.join("made.png");
    let link = dir.join("x.png");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let args = ["--width", "32", "--height", "24", "--spp", "1"];
    let (ok, log) =
        run_without_display(&[&["render", "--out", link.to_str().unwrap()], &args[..]].concat());
    assert!(!ok && log.contains("link"), "{log}");
    assert!(!target.exists(), "the link's target was made");
    // With --overwrite the user chose the name: it is written where the link points.
    let (ok, log) = run_without_display(
        &[
            &["render", "--overwrite", "--out", link.to_str().unwrap()],
            &args[..],
        ]
        .concat(),
    );
    assert!(ok, "{log}");
    assert!(target.exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn save_from_a_scene_file_keeps_its_framing_and_info_counts_its_triangles() {
    let dir = fresh("trust-save");
    let helmet = shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let out = dir.join("helmet.treelight");
    let (ok, log) =
        run_without_display(&[helmet.to_str().unwrap(), "--save", out.to_str().unwrap()]);
    assert!(ok, "{log}");
    let project = treelight_document::project::format::read_project(&out).unwrap();
    let camera = project.camera.expect("the framed view");
    assert!(camera.radius < 2.0, "{camera:?}");
    let (ok, text) = run_without_display(&["info", out.to_str().unwrap()]);
    assert!(ok, "{text}");
    // The helmet's triangles and the sun the import adds (no triangles).
    assert!(text.contains("triangles: 94722"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

/// An OBJ of a ground and a block, `scale` units across, standing `scale` units from the
/// world's origin (a site in millimetres is 1e7 across).
fn far_site(dir: &Path, scale: f32) -> PathBuf {
    let path = dir.join(format!("site-{scale:e}.obj"));
    let (o, s) = (scale, scale);
    let v = |x: f32, y: f32, z: f32| format!("v {} {} {}\n", o + x * s, y * s, o + z * s);
    let mut text = String::new();
    for (x, z) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
        text.push_str(&v(x, 0.0, z));
    }
    for y in [0.0, 0.2] {
        for (x, z) in [(-0.1, -0.1), (0.1, -0.1), (0.1, 0.1), (-0.1, 0.1)] {
            text.push_str(&v(x, y, z));
        }
    }
    text.push_str(
        "f 1 3 2\nf 1 4 3\nf 9 10 11\nf 9 11 12\nf 5 6 10\nf 5 10 9\nf 6 7 11\nf 6 11 10\n",
    );
    text.push_str("f 7 8 12\nf 7 12 11\nf 8 5 9\nf 8 9 12\n");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn scenes_far_from_the_origin_render_and_a_site_1e9_across_is_framed_at_the_limit() {
    let dir = fresh("trust-far");
    let mut means = Vec::new();
    for scale in [10.0f32, 1.0e7, 1.0e9] {
        let site = far_site(&dir, scale);
        let out = dir.join(format!("site-{scale:e}.png"));
        let (ok, log) = run_without_display(&[
            "render",
            site.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--spp",
            "4",
        ]);
        assert!(ok, "{log}");
        let img = support::load_rgb(&out);
        let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
        let m = support::mean_rgb(&img, 0, 0, img.width(), img.height());
        means.push((m[0] + m[1] + m[2]) / 3.0);
        assert!(
            colours.len() > 20,
            "scale {scale:e}: {} colours",
            colours.len()
        );
    }
    // The same framing up to a site in millimetres: about the same picture. A site 1e9 across is
    // framed from as far as a project keeps a camera (1e9, what a reopen accepts), so it shows
    // closer: brighter with more ground, never black (the 1e7 site rendered black before rays
    // were made relative to the camera).
    assert!(
        (means[1] - means[0]).abs() < 25.0,
        "scale 1e7: mean {} against {}",
        means[1],
        means[0]
    );
    assert!(
        means[2] > means[0],
        "scale 1e9: mean {} against {}",
        means[2],
        means[0]
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn settled_is_never_reported_before_the_tree_holds_the_whole_file() {
    let dir = fresh("trust-settled");
    // 2M triangles in 100 meshes.
    let (file, triangles) = assembly::generated_assembly(&dir, 100, 100);
    // Read from the editor's first report on: on a loaded machine its first frames can take as
    // long as the whole import, and a check begun after them saw the scene settled already.
    let s = Session::start_until(
        "trust-settled-run",
        &[file.to_str().unwrap()],
        &[],
        "the editor's first report",
        |_| true,
    );
    let start = Instant::now();
    let mut seen = 0;
    loop {
        if let Some(st) = s.try_state() {
            seen += 1;
            if st.settled {
                assert_eq!(
                    st.memory.triangles, triangles as u64,
                    "settled with {} of the file's {triangles} triangles in the tree (frame {})",
                    st.memory.triangles, st.frame
                );
                if st.objects.len() > 100 {
                    break;
                }
            }
        }
        assert!(start.elapsed() < Duration::from_secs(600), "never settled");
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(
        seen > 10,
        "only {seen} reports read before the scene settled"
    );
    drop(s);
    std::fs::remove_dir_all(&dir).ok();
}

/// A project of a chain of `n` groups over a cube.
fn chain_project(dir: &Path, n: u64) -> PathBuf {
    let mut text = String::from("(version: 4, objects: [\n");
    for id in 1..=n {
        let parent = if id == 1 {
            "None".to_owned()
        } else {
            format!("Some(({}))", id - 1)
        };
        text.push_str(&format!(
            "(id: ({id}), name: \"g{id}\", parent: {parent}, transform: (translation: (0.0, 0.01, \
             0.0)), kind: Empty),\n"
        ));
    }
    text.push_str(&format!(
        "(id: ({}), name: \"cube\", parent: Some(({n})), transform: (translation: (0.0, 0.0, \
         0.0)), kind: Shape(Cube)),\n])\n",
        n + 1
    ));
    let path = dir.join(format!("chain-{n}.treelight"));
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_chain_as_deep_as_the_limit_opens_and_a_deeper_one_is_refused_naming_the_object() {
    let dir = fresh("trust-chain");
    let out = dir.join("out.treelight");
    let deep = chain_project(&dir, 1000);
    let (ok, log) = run_without_display(&[deep.to_str().unwrap(), "--save", out.to_str().unwrap()]);
    assert!(ok, "{log}");
    let too_deep = chain_project(&dir, 200_000);
    let start = Instant::now();
    let (ok, log) =
        run_without_display(&[too_deep.to_str().unwrap(), "--save", out.to_str().unwrap()]);
    assert!(
        !ok && log.contains("levels deep") && log.contains("chain-200000"),
        "{log}"
    );
    assert!(start.elapsed() < Duration::from_secs(60));
    std::fs::remove_dir_all(&dir).ok();
}
