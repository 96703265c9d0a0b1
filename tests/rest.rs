//! An editor at rest draws no frames, and wakes without input for each source of work that comes
//! due or arrives while it rests: a file appearing in an Assets folder (the watcher), a recovery
//! copy (autosave's alarm), a notice fading (its alarm); an import started draws until it is in
//! the tree. The real binary under Xvfb.

mod support;
#[path = "support/xdrive.rs"]
mod xdrive;

use std::path::Path;
use std::time::{Duration, Instant};
use support::{run_without_display, temp_dir};
use treelight::report::EditorState;
use xdrive::{Session, keysym, object, widget};

/// Settings whose Assets panel, the window's left half, lists `folder`.
fn settings_with_assets(config: &Path, folder: &Path) {
    use treelight::editor::core::layout::EditorTab;
    use treelight::editor::workspace::settings::{EditorSettings, write_settings};
    std::fs::create_dir_all(config).unwrap();
    let mut layout = egui_dock::DockState::new(vec![EditorTab::Viewport]);
    let tree = layout.main_surface_mut();
    let [_, assets] = tree.split_left(egui_dock::NodeIndex::root(), 0.5, vec![EditorTab::Assets]);
    tree.split_below(
        assets,
        0.9,
        vec![
            EditorTab::Outliner,
            EditorTab::Inspector,
            EditorTab::History,
        ],
    );
    write_settings(
        &config.join("settings.ron"),
        &EditorSettings {
            version: 1,
            layout,
            grid_step: 0.5,
            angle_step_deg: 15.0,
            scale_step: 0.1,
            recent: Vec::new(),
            asset_folders: vec![folder.to_owned()],
        },
    )
    .unwrap();
}

/// Waits, sending nothing, until `done` accepts a report or `limit` passes; returns the report
/// and whether the editor was seen at rest for a second (its frame count still) on the way.
fn wait_untouched(
    s: &Session,
    limit: Duration,
    done: impl Fn(&EditorState) -> bool,
) -> (Option<EditorState>, bool) {
    let start = Instant::now();
    let mut still: Option<(u64, Instant)> = None;
    let mut rested = false;
    while start.elapsed() < limit {
        if let Some(st) = s.try_state() {
            if done(&st) {
                return (Some(st), rested);
            }
            match still {
                Some((f, since)) if f == st.frame && st.at_rest => {
                    rested |= since.elapsed() > Duration::from_secs(1)
                }
                _ => still = Some((st.frame, Instant::now())),
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    (None, rested)
}

#[test]
fn a_resting_editor_draws_nothing_and_wakes_for_watchers_and_alarms() {
    let dir = temp_dir("rest");
    let (cache, config, assets) = (dir.join("cache"), dir.join("config"), dir.join("assets"));
    std::fs::create_dir_all(&assets).unwrap();
    settings_with_assets(&config, &assets);
    let project = dir.join("house.treelight");
    let (ok, log) = run_without_display(&["--save", project.to_str().unwrap()]);
    assert!(ok, "{log}");
    let env = [
        ("TREELIGHT_CACHE_DIR", cache.to_str().unwrap()),
        ("TREELIGHT_CONFIG_DIR", config.to_str().unwrap()),
        ("TREELIGHT_AUTOSAVE_SECS", "25"),
    ];
    let mut s = Session::start_with("rest", &[project.to_str().unwrap(), "--samples", "2"], &env);

    // Converged and untouched (the open's notice gone), it draws nothing.
    s.wait_until("rest", Duration::from_secs(120), |st| {
        st.at_rest && st.notices.is_empty()
    });
    // (The window loop may run one more frame after the last one that asked for none.)
    std::thread::sleep(Duration::from_secs(1));
    let st = s.try_state().unwrap();
    // At rest only with the view's samples all denoised (the denoiser makes a pass a frame, its
    // last run after the last samples).
    assert_eq!(st.samples, 2);
    assert!(!st.denoising, "at rest with the denoiser part way");
    std::thread::sleep(Duration::from_secs(3));
    let later = s.try_state().unwrap();
    assert_eq!(
        later.frame, st.frame,
        "frames drawn at rest (last busy: {:?})",
        later.last_busy
    );

    // A scene file appears in the Assets folder: the watcher wakes the editor, which lists it and
    // makes its thumbnail with no input.
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/samples/arch.obj");
    std::fs::copy(&sample, assets.join("watched.obj")).unwrap();
    let (st, _) = wait_untouched(&s, Duration::from_secs(20), |st| {
        st.at_rest && st.widgets.iter().any(|(name, _)| name == "watched.obj")
    });
    let st = st.unwrap_or_else(|| panic!("the new file's tile never came\n{}", s.log()));
    assert!(st.frame > later.frame);

    // A click on its tile imports it at the view's centre; then nothing: the frames go on while
    // the file is read and traced into the tree, and stop once it is there.
    let (x, y) = widget(&st, "watched.obj");
    let before = st.objects.len();
    s.click(x, y);
    let (st, _) = wait_untouched(&s, Duration::from_secs(60), |st| {
        st.at_rest && st.settled && st.objects.len() > before
    });
    let st = st.unwrap_or_else(|| panic!("the import never finished at rest\n{}", s.log()));
    assert!(
        st.objects.iter().any(|o| o.name.contains("watched")),
        "{:?}",
        st.objects.iter().map(|o| &o.name).collect::<Vec<_>>()
    );

    // The import saved: the save's notice fades at its time, with no input.
    s.key(&[keysym::CONTROL], keysym::letter('s'));
    let st = s.wait_until("the save's notice", Duration::from_secs(30), |st| {
        !st.dirty && st.notices.iter().any(|n| n.starts_with("saved"))
    });
    let shown = Instant::now();
    let (faded, rested) = wait_untouched(&s, Duration::from_secs(15), |st| {
        !st.notices.iter().any(|n| n.starts_with("saved"))
    });
    assert!(faded.is_some(), "the notice never faded ({:?})", st.notices);
    assert!(rested, "the editor never rested while the notice showed");
    assert!(shown.elapsed() > Duration::from_secs(3), "it faded early");

    // An edit, then nothing: the editor rests, and autosave's alarm wakes it to write the
    // recovery copy (the loop's longest sleep, 60 s, is far later).
    let st = s.frames(1);
    let sphere = object(&st, "Sphere").screen.unwrap();
    s.click(sphere[0], sphere[1]);
    s.key(&[], keysym::DELETE);
    let st = s.frames(1);
    assert!(st.dirty);
    let copy = dir.join(".house.recovery.treelight");
    let (written, rested) = wait_untouched(&s, Duration::from_secs(40), |_| copy.exists());
    assert!(
        written.is_some(),
        "no recovery copy within 40 s\n{}",
        s.log()
    );
    assert!(rested, "the editor never rested before the copy was due");

    drop(s);
    std::fs::remove_dir_all(&dir).ok();
}
