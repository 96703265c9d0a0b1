//! The editor driven as a user drives it: real pointer and key events through the X server
//! (XTEST) on the editor's real window under Xvfb, with assertions on the world the editor reports
//! (`--state`) and on the picture the X server holds.

mod support;
#[path = "support/xdrive.rs"]
mod xdrive;

use treelight::report::{EditorState, ObjectReport};
use xdrive::{Session, below_the_toolbar, handle, keysym, object, widget, widget_at, widget_rect};

fn pos(p: [f32; 2]) -> (f32, f32) {
    (p[0], p[1])
}

fn ids_named(state: &EditorState, name: &str) -> Vec<treelight_document::values::object::SceneId> {
    state
        .objects
        .iter()
        .filter(|o| o.name == name)
        .map(|o| o.id)
        .collect()
}

/// Pixels of the selection outline's colours inside the viewport.
fn outline_pixels(img: &image::RgbImage, viewport: [f32; 4]) -> usize {
    let [x, y, w, h] = viewport.map(|v| v as u32);
    let mut n = 0;
    for py in y..(y + h).min(img.height()) {
        for px in x..(x + w).min(img.width()) {
            let p = img.get_pixel(px, py).0;
            // The outline's orange: strong red, middling green, little blue.
            if p[0] > 215 && (100..=190).contains(&p[1]) && p[2] < 70 {
                n += 1;
            }
        }
    }
    n
}

/// How long a test waits for the path-traced view to gather the samples it looks at: paths of up to
/// 16 bounces with the lamp's glow sampled directly, on llvmpipe, beside the other tests.
const CONVERGING: std::time::Duration = std::time::Duration::from_secs(180);

/// The view traced at a quarter of its resolution (in the sessions' 960 × 600 window), for tests
/// that judge the picture by its mean brightness, a region's colour or an outline, which depend on
/// neither. On llvmpipe a frame costs about what its pixels do: these tests take a half to two
/// thirds of their time at the editor's default 1280 × 800 and half the resolution. The viewport's
/// toolbar wraps onto a second row at this width, where the exposure and sky tests reach the tone
/// curve and the sky.
const QUARTER_TRACE: [&str; 2] = ["--trace-scale", "0.25"];

/// A display whose server died without cleaning up (killed outright, the machine's `/tmp` kept
/// between runs) is taken over; one whose server lives, or whose lock does not read as a pid, is
/// not. CI once ran out of display numbers to such leftovers.
#[test]
fn a_stale_x_lock_frees_its_display_number_and_a_live_one_does_not() {
    let n = 5000 + std::process::id() % 1000;
    let (lock, socket) = (xdrive::lock_path(n), xdrive::socket_path(n));
    let _ = std::fs::create_dir_all(socket.parent().unwrap());
    let mut gone = std::process::Command::new("true").spawn().unwrap();
    gone.wait().unwrap();
    let write = |pid: &str| {
        std::fs::write(&lock, format!("{pid:>10}\n")).unwrap();
        std::fs::write(&socket, b"").unwrap();
    };
    write(&gone.id().to_string());
    assert!(xdrive::display_free(n), "a dead server's display");
    assert!(!lock.exists() && !socket.exists(), "its leftovers removed");
    write(&std::process::id().to_string());
    assert!(!xdrive::display_free(n), "a live process's display");
    write("not a pid");
    assert!(!xdrive::display_free(n), "an unreadable lock");
    assert!(
        lock.exists() && socket.exists(),
        "nothing removed that was not stale"
    );
    let _ = std::fs::remove_file(&lock);
    let _ = std::fs::remove_file(&socket);
    assert!(xdrive::display_free(n), "no lock and no socket");
}

#[test]
fn clicks_keys_and_the_gizmo_edit_the_default_scene() {
    let mut s = Session::start("input", &QUARTER_TRACE);
    let start = s.frames(1);
    let tall = object(&start, "Tall box").clone();
    let short = object(&start, "Short box").clone();
    let sphere = object(&start, "Sphere").clone();
    selects_by_clicks_and_boxes(&mut s, &start, [&tall, &short, &sphere]);
    deletes_copies_and_pastes(&mut s, &tall);
    moves_with_the_gizmo_and_renames(&mut s, &tall);
}

/// A click selects what is under the pointer (outlined in the traced view), Ctrl+click adds,
/// Escape clears, a box selects what it encloses, and a light's icon selects the light.
fn selects_by_clicks_and_boxes(
    s: &mut Session,
    start: &EditorState,
    [tall, short, sphere]: [&ObjectReport; 3],
) {
    let before_outline = outline_pixels(&s.screenshot(), start.viewport);
    // A click selects what is under the pointer, and the path-traced view shows it outlined.
    s.click(tall.screen.unwrap()[0], tall.screen.unwrap()[1]);
    let st = s.frames(2);
    assert_eq!(st.selection, vec![tall.id], "click on the tall box");
    let outlined = outline_pixels(&s.screenshot(), st.viewport);
    assert!(
        outlined > before_outline + 100,
        "the selection is not outlined: {before_outline} -> {outlined} outline pixels"
    );

    // Ctrl+click adds; Escape clears.
    s.key_event(keysym::CONTROL, true);
    s.click(short.screen.unwrap()[0], short.screen.unwrap()[1]);
    s.key_event(keysym::CONTROL, false);
    let st = s.frames(2);
    assert_eq!(st.selection, vec![tall.id, short.id], "ctrl+click");
    s.key(&[], keysym::ESCAPE);
    assert!(s.frames(1).selection.is_empty(), "escape clears");

    // A box dragged around the short box and the sphere selects both, not the tall box.
    let (a, b) = (short.screen.unwrap(), sphere.screen.unwrap());
    let from = (a[0].min(b[0]) - 30.0, a[1].min(b[1]) - 30.0);
    let to = (a[0].max(b[0]) + 30.0, a[1].max(b[1]) + 30.0);
    s.drag(from, to, 4);
    let st = s.frames(2);
    assert!(
        st.selection.contains(&short.id) && st.selection.contains(&sphere.id),
        "box select: {:?}",
        st.selection
    );
    assert!(
        !st.selection.contains(&tall.id),
        "box select took the tall box"
    );

    // A light has no geometry: its icon in the viewport is what a click selects.
    let lamp = object(start, "Lamp light").clone();
    let at = lamp.screen.expect("the lamp's light is in view");
    s.click(at[0], at[1]);
    assert_eq!(
        s.frames(2).selection,
        vec![lamp.id],
        "click on the light's icon"
    );
}

/// Del deletes the selection, Ctrl+Z brings the same object back, Ctrl+D copies it, and Ctrl+C,
/// Ctrl+V paste a copy, selected.
fn deletes_copies_and_pastes(s: &mut Session, tall: &ObjectReport) {
    // Del deletes the selection; Ctrl+Z brings the same object back; Ctrl+D copies it.
    s.click(tall.screen.unwrap()[0], tall.screen.unwrap()[1]);
    let (head, _) = s.frames(1).history;
    s.key(&[], keysym::DELETE);
    let st = s.frames(2);
    assert!(ids_named(&st, "Tall box").is_empty(), "delete");
    s.key(&[keysym::CONTROL], keysym::letter('z'));
    let st = s.frames(2);
    assert_eq!(
        ids_named(&st, "Tall box"),
        vec![tall.id],
        "undo of the delete"
    );
    assert_eq!(st.history.0, head);
    s.click(tall.screen.unwrap()[0], tall.screen.unwrap()[1]);
    s.key(&[keysym::CONTROL], keysym::letter('d'));
    let st = s.frames(2);
    let copies = ids_named(&st, "Tall box");
    assert_eq!(copies.len(), 2, "duplicate");
    let copy = *copies.iter().find(|id| **id != tall.id).unwrap();
    assert_eq!(st.selection, vec![copy], "the copy is selected");
    s.key(&[keysym::CONTROL], keysym::letter('z'));
    assert_eq!(ids_named(&s.frames(2), "Tall box"), vec![tall.id]);
    // Ctrl+C copies; after the selection is cleared, Ctrl+V pastes a copy, selected.
    s.click(tall.screen.unwrap()[0], tall.screen.unwrap()[1]);
    s.key(&[keysym::CONTROL], keysym::letter('c'));
    s.key(&[], keysym::ESCAPE);
    assert!(s.frames(1).selection.is_empty());
    s.key(&[keysym::CONTROL], keysym::letter('v'));
    let st = s.frames(2);
    let copies = ids_named(&st, "Tall box");
    assert_eq!(copies.len(), 2, "paste");
    let pasted = *copies.iter().find(|id| **id != tall.id).unwrap();
    assert_eq!(st.selection, vec![pasted], "the pasted copy is selected");
    s.key(&[keysym::CONTROL], keysym::letter('z'));
    assert_eq!(ids_named(&s.frames(2), "Tall box"), vec![tall.id]);
}

/// The gizmo moves the box along one axis as one step; Escape or a right click cancel a drag;
/// F2 renames in the outliner, and keys in its text field edit only the text.
fn moves_with_the_gizmo_and_renames(s: &mut Session, tall: &ObjectReport) {
    // The gizmo: a drag along the x arrow moves the tall box along x only, as one step.
    s.click(tall.screen.unwrap()[0], tall.screen.unwrap()[1]);
    let st = s.frames(2);
    assert_eq!(st.selection, vec![tall.id]);
    let (head, _) = st.history;
    let arrow = handle(&st, "axis 0");
    let grab = (
        arrow[0][0] + (arrow[1][0] - arrow[0][0]) * 0.7,
        arrow[0][1] + (arrow[1][1] - arrow[0][1]) * 0.7,
    );
    let dir = (arrow[1][0] - arrow[0][0], arrow[1][1] - arrow[0][1]);
    let len = (dir.0 * dir.0 + dir.1 * dir.1).sqrt();
    let to = (grab.0 + dir.0 / len * 80.0, grab.1 + dir.1 / len * 80.0);
    let was = object(&st, "Tall box").world_translation;
    s.drag(grab, to, 4);
    let st = s.frames(2);
    let now = object(&st, "Tall box").world_translation;
    assert!(
        now[0] - was[0] > 0.2,
        "the drag moved x by {}",
        now[0] - was[0]
    );
    assert!(
        (now[1] - was[1]).abs() < 1e-4 && (now[2] - was[2]).abs() < 1e-4,
        "the drag left the axis: {was:?} -> {now:?}"
    );
    assert_eq!(st.history.0, head + 1, "one drag, one step");

    // Escape, or a right click, during a drag puts the box back and leaves no step.
    for cancel in ["escape", "right click"] {
        let arrow = handle(&st, "axis 0").to_vec();
        let grab = (
            arrow[0][0] + (arrow[1][0] - arrow[0][0]) * 0.7,
            arrow[0][1] + (arrow[1][1] - arrow[0][1]) * 0.7,
        );
        s.drag_without_release(grab, (grab.0 + 60.0, grab.1), 3);
        let moving = object(&s.frames(1), "Tall box").world_translation;
        assert!(
            moving[0] != now[0],
            "{cancel}: the preview follows the drag"
        );
        if cancel == "escape" {
            s.key(&[], keysym::ESCAPE);
        } else {
            s.press(3);
            s.release(3);
        }
        s.release(1);
        let after = s.frames(2);
        assert_eq!(
            object(&after, "Tall box").world_translation,
            now,
            "{cancel} put the box back"
        );
        assert_eq!(after.history.0, head + 1, "{cancel} left no step");
        assert_eq!(
            after.selection,
            vec![tall.id],
            "{cancel} kept the selection"
        );
    }

    // F2 renames in the outliner: while its text field has the keyboard, Delete and W edit the
    // text and do nothing else; Return commits the new name as a step.
    s.key(&[], keysym::F2);
    s.key(&[], keysym::DELETE);
    s.key(&[], keysym::letter('e'));
    let st = s.frames(2);
    assert_eq!(
        ids_named(&st, "Tall box"),
        vec![tall.id],
        "Delete in a text field"
    );
    assert_eq!(st.gizmo_mode, "Move", "E in a text field changed the gizmo");
    s.key(&[], keysym::letter('w'));
    s.key(&[], keysym::RETURN);
    let st = s.frames(2);
    assert!(
        st.objects
            .iter()
            .any(|o| o.id == tall.id && o.name != "Tall box"),
        "rename: {:?}",
        object_names(&st)
    );
    assert_eq!(st.history.0, head + 2, "the rename is one step");
    // Outside a text field, E switches the gizmo to rotation.
    s.key(&[], keysym::letter('e'));
    assert_eq!(s.frames(1).gizmo_mode, "Rotate");
}

fn object_names(state: &EditorState) -> Vec<&str> {
    state.objects.iter().map(|o| o.name.as_str()).collect()
}

#[test]
fn the_gizmo_moves_a_child_of_a_rotated_stretched_parent_exactly_along_the_world_axis() {
    let dir = support::temp_dir("gizmo-child");
    let commands = dir.join("setup.ron");
    std::fs::write(
        &commands,
        r#"[
            AddPrimitive(shape: Cube, id: Some((100)), transform: (
                translation: (-1.2, 1.0, 0.5),
                rotation: (0.1, 0.35, 0.05, 0.93),
                scale: (1.6, 0.5, 0.8))),
            AddPrimitive(shape: Sphere, id: Some((101)), transform: (translation: (0.6, 3.2, 2.0))),
            Reparent(ids: [(101)], parent: Some((100))),
            Rename(id: (101), name: "Child"),
        ]"#,
    )
    .unwrap();
    let mut s = Session::start("gizmo-child", &["--commands", commands.to_str().unwrap()]);
    let st = s.wait_until(
        "the setup commands",
        std::time::Duration::from_secs(60),
        |s| s.history.0 == 4,
    );
    let child = object(&st, "Child").clone();
    assert_eq!(
        child.parent,
        Some(treelight_document::values::object::SceneId(100))
    );
    s.click(child.screen.unwrap()[0], child.screen.unwrap()[1]);
    let st = s.frames(2);
    assert_eq!(st.selection, vec![child.id], "click on the child");
    let was = object(&st, "Child").world_translation;
    let arrow = handle(&st, "axis 0");
    let grab = (
        arrow[0][0] + (arrow[1][0] - arrow[0][0]) * 0.7,
        arrow[0][1] + (arrow[1][1] - arrow[0][1]) * 0.7,
    );
    let d = (arrow[1][0] - arrow[0][0], arrow[1][1] - arrow[0][1]);
    let len = (d.0 * d.0 + d.1 * d.1).sqrt();
    s.drag(
        grab,
        (grab.0 + d.0 / len * 70.0, grab.1 + d.1 / len * 70.0),
        4,
    );
    let st = s.frames(2);
    let now = object(&st, "Child").world_translation;
    assert!(now[0] - was[0] > 0.2, "moved {:?} -> {:?}", was, now);
    assert!(
        (now[1] - was[1]).abs() < 1e-4 && (now[2] - was[2]).abs() < 1e-4,
        "the child left the world x axis: {was:?} -> {now:?}"
    );
    // Its parent did not move.
    assert_eq!(
        object(&st, "Cube").world_translation,
        [-1.2, 1.0, 0.5].map(|v: f32| v)
    );
    std::fs::remove_dir_all(&dir).ok();
    let _ = pos;
}

#[test]
fn a_shape_dragged_from_the_palette_lands_on_the_surface_under_the_pointer() {
    let mut s = Session::start("palette", &[]);
    let st = s.frames(1);
    let tile = widget(&st, "Cube");
    let floor = object(&st, "Floor").screen.unwrap();
    let (head, _) = st.history;
    let cubes = |st: &EditorState| ids_named(st, "Cube").len();

    // While the drag is over the viewport, the cube is already in the scene (and traced), with no
    // step yet.
    s.drag_without_release(tile, (floor[0], floor[1]), 6);
    // Within a few frames (more on a loaded machine, where a frame's input may land in the next).
    let during = s.wait_until(
        "the dragged cube is shown",
        std::time::Duration::from_secs(30),
        |st| cubes(st) == 1,
    );
    assert_eq!(during.history.0, head, "no step while dragging");
    s.release(1);
    let st = s.frames(2);
    assert_eq!(cubes(&st), 1);
    assert_eq!(st.history.0, head + 1, "the drop is one step");
    // Upright on the floor (its top at y = 0): the unit cube's centre half a unit above.
    let cube = object(&st, "Cube");
    // Within 1e-4 of the scene's size (the room is 5 units).
    assert!(
        (cube.world_translation[1] - 0.5).abs() < 5e-4,
        "the cube is not on the floor: {:?}",
        cube.world_translation
    );
    assert_eq!(st.selection, vec![cube.id], "the dropped cube is selected");

    // Escape during a second drag takes the ghost away and leaves no step.
    s.drag_without_release(tile, (floor[0] + 40.0, floor[1]), 6);
    assert_eq!(cubes(&s.frames(2)), 2, "the second ghost is shown");
    s.key(&[], keysym::ESCAPE);
    s.release(1);
    let st = s.frames(3);
    assert_eq!(cubes(&st), 1, "escape removed the ghost");
    assert_eq!(st.history.0, head + 1, "escape left no step");
}

/// Clicks the named widget the report lists.
fn click_widget(s: &mut Session, st: &EditorState, name: &str) {
    let (x, y) = widget(st, name);
    s.click(x, y);
}

fn row_centre(st: &EditorState, id: treelight_document::values::object::SceneId) -> (f32, f32) {
    widget(st, &format!("row {}", id.0))
}

#[test]
fn outliner_rows_reparent_by_dragging_and_rename_by_double_click() {
    let mut s = Session::start("outliner", &[]);
    let st = s.frames(1);
    let sphere = object(&st, "Sphere").clone();
    let short = object(&st, "Short box").clone();
    let (head, _) = st.history;

    // Dragging the sphere's row onto the short box's row puts it under the box, where it was.
    s.drag(row_centre(&st, sphere.id), row_centre(&st, short.id), 5);
    let st = s.frames(2);
    let moved = object(&st, "Sphere");
    assert_eq!(moved.parent, Some(short.id), "reparented");
    assert_eq!(st.history.0, head + 1);
    for k in 0..3 {
        assert!(
            (moved.world_translation[k] - sphere.world_translation[k]).abs() < 1e-4,
            "the sphere moved: {:?} -> {:?}",
            sphere.world_translation,
            moved.world_translation
        );
    }
    s.key(&[keysym::CONTROL], keysym::letter('z'));
    assert_eq!(object(&s.frames(2), "Sphere").parent, None, "undo");

    // A double click on a row opens its name for editing; Return commits it.
    let st = s.frames(1);
    let (x, y) = row_centre(&st, short.id);
    s.double_click(x, y);
    s.key(&[], keysym::letter('x'));
    s.key(&[], keysym::RETURN);
    let st = s.frames(2);
    let renamed = st.objects.iter().find(|o| o.id == short.id).unwrap();
    assert!(
        renamed.name != "Short box" && renamed.name.contains('x'),
        "rename by double click: {:?}",
        renamed.name
    );
}

#[test]
fn ctrl_s_saves_a_project_and_quitting_with_changes_asks_first() {
    let mut s = Session::start("save", &[]);
    let st = s.frames(1);
    assert_eq!(st.project, None);
    assert!(st.title.starts_with("Untitled"), "{}", st.title);
    // An edit makes the scene unsaved.
    let sphere = object(&st, "Sphere").clone();
    s.click(sphere.screen.unwrap()[0], sphere.screen.unwrap()[1]);
    s.key(&[], keysym::DELETE);
    let st = s.frames(2);
    assert!(st.dirty && st.title.contains('*'), "{}", st.title);
    // Ctrl+S on a scene never saved opens the save dialog with its name field ready: Return saves
    // there (the editor's working folder).
    s.key(&[keysym::CONTROL], keysym::letter('s'));
    s.frames(2);
    s.key(&[], keysym::RETURN);
    let path = s.dir().join("scene.treelight");
    let st = s.wait_until("the save", std::time::Duration::from_secs(30), |st| {
        st.project.is_some() && !st.dirty
    });
    assert_eq!(st.project.as_deref(), Some(path.as_path()));
    assert!(st.title.starts_with("scene.treelight") && !st.title.contains('*'));
    let project =
        treelight_document::project::format::read_project(&path).expect("a valid project");
    assert!(
        project.objects.iter().all(|o| o.id != sphere.id),
        "the deleted sphere is gone"
    );
    assert_eq!(project.objects.len(), st.objects.len());
    // Ctrl+Z makes it unsaved again; Ctrl+Q then asks instead of quitting.
    s.key(&[keysym::CONTROL], keysym::letter('z'));
    assert!(s.frames(2).dirty);
    s.key(&[keysym::CONTROL], keysym::letter('q'));
    s.frames(4);
    assert!(!s.exited(), "quit with unsaved changes did not ask");
    // Saved again (Ctrl+S, to the same file now), Ctrl+Q quits at once.
    s.key(&[], keysym::ESCAPE);
    s.key(&[keysym::CONTROL], keysym::letter('s'));
    s.wait_until(
        "the second save",
        std::time::Duration::from_secs(30),
        |st| !st.dirty,
    );
    s.key_event(keysym::CONTROL, true);
    s.key_event(keysym::letter('q'), true);
    let start = std::time::Instant::now();
    while !s.exited() {
        assert!(
            start.elapsed().as_secs() < 30,
            "Ctrl+Q did not quit a saved scene"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

#[test]
fn work_killed_mid_edit_is_offered_back_at_the_next_start() {
    let cache = support::temp_dir("recovery-cache");
    let cache_str = cache.to_str().unwrap().to_owned();
    let env = [
        ("TREELIGHT_CACHE_DIR", cache_str.as_str()),
        ("TREELIGHT_AUTOSAVE_SECS", "1"),
    ];
    let recovery_files = || {
        std::fs::read_dir(&cache)
            .map(|d| {
                d.flatten()
                    .filter(|e| {
                        e.file_name()
                            .to_string_lossy()
                            .ends_with(".recovery.treelight")
                    })
                    .count()
            })
            .unwrap_or(0)
    };
    {
        let mut s = Session::start_with("recovery-1", &[], &env);
        let st = s.frames(1);
        let sphere = object(&st, "Sphere").clone();
        s.click(sphere.screen.unwrap()[0], sphere.screen.unwrap()[1]);
        s.key(&[], keysym::DELETE);
        assert!(ids_named(&s.frames(2), "Sphere").is_empty());
        let start = std::time::Instant::now();
        while recovery_files() == 0 {
            assert!(
                start.elapsed().as_secs() < 30,
                "no recovery copy was written"
            );
            s.frames(1);
        }
        // Dropping the session kills the editor (SIGKILL): no chance to save.
    }
    let mut s = Session::start_with("recovery-2", &[], &env);
    // The offer's button has the keyboard: Return opens the copy.
    s.key(&[], keysym::RETURN);
    let st = s.wait_until(
        "the recovered scene",
        std::time::Duration::from_secs(30),
        |st| st.objects.iter().all(|o| o.name != "Sphere") && st.dirty,
    );
    assert!(st.objects.iter().any(|o| o.name == "Tall box"));
    std::fs::remove_dir_all(&cache).ok();
}

#[test]
fn the_desktop_file_dialog_opens_and_saves_projects_and_a_cancel_opens_nothing() {
    // A stand-in for zenity, rfd's dialog where no desktop portal runs: it logs its arguments and
    // answers from a file the test writes (a path, or nothing for a cancel).
    let bin = support::temp_dir("fake-zenity");
    let answer = bin.join("answer");
    let log = bin.join("calls");
    let script = bin.join("zenity");
    std::fs::write(
        &script,
        format!(
            "#!/bin/sh\necho \"$@\" >> '{}'\nif [ -s '{}' ]; then cat '{}'; exit 0; fi\nexit 1\n",
            log.display(),
            answer.display(),
            answer.display()
        ),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut s = Session::start_with(
        "native-dialog",
        &[],
        &[
            ("TREELIGHT_FILE_DIALOG", ""),
            ("PATH", &path),
            ("DBUS_SESSION_BUS_ADDRESS", ""),
        ],
    );
    s.frames(1);
    // Save As: the desktop dialog's answer (typed without the extension) becomes the project.
    std::fs::write(&answer, format!("{}\n", s.dir().join("mine").display())).unwrap();
    s.key(&[keysym::CONTROL, keysym::SHIFT], keysym::letter('s'));
    let saved = s.dir().join("mine.treelight");
    let st = s.wait_until("the save", std::time::Duration::from_secs(30), |st| {
        st.project.as_deref() == Some(saved.as_path()) && !st.dirty
    });
    assert_eq!(st.dialog, None);
    assert!(treelight_document::project::format::read_project(&saved).is_ok());
    let calls = std::fs::read_to_string(&log).unwrap();
    assert!(calls.contains("--save"), "{calls}");

    // A cancel (zenity exits without a file): nothing opens, not even the in-window dialog.
    std::fs::write(&answer, "").unwrap();
    s.key(&[keysym::CONTROL], keysym::letter('o'));
    s.wait_until(
        "the dialog's answer",
        std::time::Duration::from_secs(30),
        |_| std::fs::read_to_string(&log).is_ok_and(|c| c.lines().count() >= 2),
    );
    let st = s.frames(5);
    assert_eq!(st.dialog, None, "a cancel opened another dialog");
    assert_eq!(st.project.as_deref(), Some(saved.as_path()));

    // Save As through the desktop dialog onto an existing file asks too; Escape keeps the file.
    let before = std::fs::read(&saved).unwrap();
    let existing = s.dir().join("other.treelight");
    std::fs::write(&existing, "someone's work").unwrap();
    std::fs::write(&answer, format!("{}\n", existing.display())).unwrap();
    s.key(&[keysym::CONTROL, keysym::SHIFT], keysym::letter('s'));
    wait_for_replace_question(&mut s, "the question");
    s.key(&[], keysym::ESCAPE);
    s.wait_until("the escape", std::time::Duration::from_secs(30), |st| {
        st.dialog.is_none()
    });
    assert_eq!(
        std::fs::read_to_string(&existing).unwrap(),
        "someone's work"
    );
    assert_eq!(std::fs::read(&saved).unwrap(), before);
    std::fs::remove_dir_all(&bin).ok();
}

#[test]
fn the_x_server_says_where_a_desktop_drop_lands() {
    // winit reports no pointer during an X11 drag-and-drop; the editor then asks the X server,
    // which must give the pointer's place in the editor's window.
    let mut s = Session::start("x11-pointer", &[]);
    let st = s.frames(1);
    let [vx, vy, vw, vh] = st.viewport;
    for (fx, fy) in [(0.3, 0.4), (0.7, 0.6)] {
        let (x, y) = (vx + vw * fx, vy + vh * fy);
        s.move_to(x, y);
        let at = treelight::editor::viewport::x11_pointer::pointer_in_window(
            Some(&s.display_name()),
            s.window_id(),
        )
        .expect("the X server answers");
        assert_eq!(at, (x.round() as i16, y.round() as i16));
    }
    // A window that does not exist: no answer, no panic.
    assert_eq!(
        treelight::editor::viewport::x11_pointer::pointer_in_window(
            Some(&s.display_name()),
            0x7fff_fff0
        ),
        None
    );
}

#[test]
fn a_sample_file_dragged_from_the_assets_panel_lands_on_the_floor() {
    let mut s = Session::start("palette-file", &[]);
    let st = s.frames(1);
    let tile_of = |st: &EditorState| widget_at(st, "stairs.obj");
    let cube = widget(&st, "Cube");
    // The samples sit below the shapes: scroll the panel until the tile is on screen.
    s.move_to(cube.0, cube.1);
    let [_, vy, _, vh] = st.viewport;
    let mut tile = tile_of(&st).expect("the Samples folder lists stairs.obj");
    for _ in 0..12 {
        if tile.1 < vy + vh - 40.0 {
            break;
        }
        s.press(5);
        s.release(5);
        tile = tile_of(&s.frames(2)).unwrap();
    }
    let floor = object(&st, "Floor").screen.unwrap();
    let (head, _) = st.history;
    // The samples' thumbnails (and with them the files, read) are made within a few frames.
    s.frames(20);
    // In front of both boxes, where only the floor is under the pointer. While the drag is over
    // the viewport the stairs are already in the scene (and traced), with no step yet.
    s.drag_without_release(tile, (floor[0] - 60.0, floor[1] + 50.0), 6);
    let during = s.wait_until(
        "the dragged file is shown",
        std::time::Duration::from_secs(30),
        |st| ids_named(st, "stairs.obj").len() == 1,
    );
    assert_eq!(during.history.0, head, "no step while dragging");
    s.release(1);
    let st = s.wait_until(
        "the dropped file",
        std::time::Duration::from_secs(60),
        |st| st.settled && st.objects.iter().any(|o| o.name == "stairs.obj"),
    );
    assert_eq!(st.history.0, head + 1, "the drop is one step");
    assert_eq!(
        ids_named(&st, "stairs.obj").len(),
        1,
        "the ghost became the object"
    );
    // The stairs' lowest point (y = 0 in the file) stands on the floor's top (y = 0).
    let stairs = object(&st, "stairs.obj");
    // Within 1e-4 of the scene's size (the room is 5 units).
    assert!(
        stairs.world_translation[1].abs() < 5e-4,
        "not on the floor: {:?}",
        stairs.world_translation
    );
    // Where the pointer was: near the floor's middle, not at the file's own origin far away.
    assert!(stairs.world_translation[0].abs() < 2.5 && stairs.world_translation[2].abs() < 2.5);
    // Placed again, beside the first: the new stairs show the first ones' mesh, so no mesh asset
    // is added. (Whether the tree holds their triangles once depends on whether the first stairs
    // were baked by then: the document's tests check the sharing in the tree.)
    let tile = tile_of(&st).unwrap();
    s.drag_without_release(tile, (floor[0] + 40.0, floor[1] + 50.0), 6);
    s.wait_until(
        "the second ghost",
        std::time::Duration::from_secs(30),
        |st| ids_named(st, "stairs.obj").len() == 2,
    );
    s.release(1);
    let again = s.wait_until(
        "the second drop",
        std::time::Duration::from_secs(60),
        |st| st.settled && st.history.0 == head + 2,
    );
    assert_eq!(ids_named(&again, "stairs.obj").len(), 2);
    assert_eq!(again.memory.mesh_count, st.memory.mesh_count);
}

/// Waits until Save As asks whether to replace a file.
fn wait_for_replace_question(s: &mut Session, what: &str) -> EditorState {
    s.wait_until(what, std::time::Duration::from_secs(30), |st| {
        st.dialog
            .as_deref()
            .is_some_and(|d| d.starts_with("replace"))
    })
}

/// Ctrl+Shift+S, then Return in the in-window dialog's name field, onto a file that exists: the
/// state once the question is asked.
fn save_as_with_return(s: &mut Session, what: &str) -> EditorState {
    s.key(&[keysym::CONTROL, keysym::SHIFT], keysym::letter('s'));
    s.frames(2);
    s.key(&[], keysym::RETURN);
    wait_for_replace_question(s, what)
}

#[test]
fn save_as_asks_before_replacing_a_file_and_a_cancel_keeps_it() {
    let mut s = Session::start("replace", &[]);
    let st = s.frames(1);
    let sphere = object(&st, "Sphere").clone();
    s.click(sphere.screen.unwrap()[0], sphere.screen.unwrap()[1]);
    s.key(&[], keysym::DELETE);
    assert!(s.frames(2).dirty);
    // A file of the name the dialog offers is already there.
    let path = s.dir().join("scene.treelight");
    std::fs::write(&path, "precious work").unwrap();
    // Return in the name field asks; Return again answers with the question's default, Cancel.
    let st = save_as_with_return(&mut s, "the question");
    assert!(widget_at(&st, "Replace").is_some() && widget_at(&st, "Cancel").is_some());
    s.key(&[], keysym::RETURN);
    let st = s.wait_until("the cancel", std::time::Duration::from_secs(30), |st| {
        st.dialog.is_none()
    });
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "precious work");
    assert_eq!(st.project, None);
    assert!(st.dirty);
    // Escape cancels too.
    save_as_with_return(&mut s, "the question again");
    s.key(&[], keysym::ESCAPE);
    s.wait_until("the escape", std::time::Duration::from_secs(30), |st| {
        st.dialog.is_none()
    });
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "precious work");
    // Replace, clicked, replaces it with the project.
    let st = save_as_with_return(&mut s, "the third question");
    let (x, y) = widget_at(&st, "Replace").unwrap();
    s.click(x, y);
    let st = s.wait_until("the save", std::time::Duration::from_secs(30), |st| {
        st.project.is_some() && !st.dirty
    });
    assert_eq!(st.project.as_deref(), Some(path.as_path()));
    assert!(treelight_document::project::format::read_project(&path).is_ok());
}

#[test]
fn quick_chords_count_once_each_at_three_frames_a_second() {
    let mut s = Session::start("slow-keys", &["--max-fps", "3"]);
    let st = s.frames(1);
    let sphere = object(&st, "Sphere").clone();
    s.click(sphere.screen.unwrap()[0], sphere.screen.unwrap()[1]);
    let st = s.frames(2);
    assert_eq!(st.selection, vec![sphere.id], "the sphere is selected");
    let head = st.history.0;
    // Each chord typed within a few milliseconds, well inside one frame (a third of a second).
    let chord = |s: &mut Session, modifiers: &[u32], sym: u32| {
        for m in modifiers {
            s.key_event(*m, true);
        }
        std::thread::sleep(std::time::Duration::from_millis(3));
        s.key_event(sym, true);
        std::thread::sleep(std::time::Duration::from_millis(3));
        s.key_event(sym, false);
        for m in modifiers.iter().rev() {
            s.key_event(*m, false);
        }
        std::thread::sleep(std::time::Duration::from_millis(3));
    };
    let wait = |s: &mut Session, what: &str, f: &dyn Fn(&EditorState) -> bool| {
        s.wait_until(what, std::time::Duration::from_secs(60), |st| f(st))
    };
    chord(&mut s, &[], keysym::DELETE);
    let st = wait(&mut s, "the delete", &|st| {
        ids_named(st, "Sphere").is_empty()
    });
    assert_eq!(st.history.0, head + 1);
    chord(&mut s, &[keysym::CONTROL], keysym::letter('z'));
    let st = wait(&mut s, "the undo", &|st| {
        !ids_named(st, "Sphere").is_empty()
    });
    assert_eq!(st.history.0, head);
    chord(
        &mut s,
        &[keysym::CONTROL, keysym::SHIFT],
        keysym::letter('z'),
    );
    let st = wait(&mut s, "the redo", &|st| ids_named(st, "Sphere").is_empty());
    assert_eq!(st.history.0, head + 1);
    chord(&mut s, &[keysym::CONTROL], keysym::letter('z'));
    wait(&mut s, "the second undo", &|st| {
        !ids_named(st, "Sphere").is_empty()
    });
    // Selected again, Ctrl+D copies it, once.
    s.click(sphere.screen.unwrap()[0], sphere.screen.unwrap()[1]);
    wait(&mut s, "the selection", &|st| {
        st.selection == vec![sphere.id]
    });
    chord(&mut s, &[keysym::CONTROL], keysym::letter('d'));
    wait(&mut s, "the copy", &|st| ids_named(st, "Sphere").len() > 1);
    let st = s.frames(3);
    assert_eq!(ids_named(&st, "Sphere").len(), 2, "Ctrl+D copied once");
    // All four chords in a row inside one frame: each acts once, in order.
    let copies = ids_named(&st, "Sphere").len();
    let head = st.history.0;
    chord(&mut s, &[keysym::CONTROL], keysym::letter('z'));
    chord(
        &mut s,
        &[keysym::CONTROL, keysym::SHIFT],
        keysym::letter('z'),
    );
    chord(&mut s, &[keysym::CONTROL], keysym::letter('z'));
    chord(
        &mut s,
        &[keysym::CONTROL, keysym::SHIFT],
        keysym::letter('z'),
    );
    let st = s.frames(8);
    assert_eq!(
        st.history.0, head,
        "undo, redo, undo, redo ends where it began"
    );
    assert_eq!(ids_named(&st, "Sphere").len(), copies);
    assert_eq!(st.history.1, head, "no step was added or lost");
}

#[test]
fn an_import_past_the_free_memory_asks_first_and_goes_ahead_only_when_told() {
    let helmet = support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let helmet = helmet.to_str().unwrap();
    // The machine says 1 MiB is free: the helmet's 94,722 triangles need tens of MiB traced.
    let free = [("TREELIGHT_AVAILABLE_MEMORY_MIB", "1")];
    let asked = |s: &mut Session| {
        s.wait_until("the question", std::time::Duration::from_secs(60), |st| {
            st.dialog
                .as_deref()
                .is_some_and(|d| d.starts_with("large import") && d.ends_with("FlightHelmet.gltf"))
        })
    };
    let has_helmet = |st: &EditorState| st.objects.iter().any(|o| o.name == "Hose_low");
    // Nothing of the file comes in while it asks (a cancel is the document's test); Import anyway,
    // clicked, brings it in.
    let mut s = Session::start_with("large-import", &[helmet], &free);
    let st = asked(&mut s);
    assert!(!has_helmet(&st));
    let st = s.frames(5);
    assert!(!has_helmet(&st), "imported before the answer");
    click_widget(&mut s, &st, "Import anyway");
    s.wait_until("the import", std::time::Duration::from_secs(60), has_helmet);
}

/// Mean of the three channels over the viewport below its toolbar.
fn viewport_brightness(img: &image::RgbImage, st: &EditorState) -> f32 {
    let [x, y, w, h] = xdrive::view_below_the_toolbar(st);
    let (x1, y1) = ((x + w).min(img.width()), (y + h).min(img.height()));
    let rgb = support::mean_rgb(img, x, y, x1, y1);
    (rgb[0] + rgb[1] + rgb[2]) / 3.0
}

#[test]
fn the_toolbar_s_exposure_and_tone_curve_change_the_picture_as_one_step_each() {
    let mut s = Session::start("exposure", &QUARTER_TRACE);
    let st = s.wait_until("the scene settles", CONVERGING, |st| {
        st.settled && st.samples >= 4 && !st.denoising
    });
    let (head, _) = st.history;
    // The toolbar wraps where the window is too narrow for one row: every control in the view.
    let [vx, vy, vw, vh] = st.viewport;
    for name in ["Render mode", "Quality", "Exposure", "Tone curve", "Sky"] {
        let [x, y, w, h] = widget_rect(&st, name);
        assert!(
            x >= vx && y >= vy && x + w <= vx + vw && y + h <= vy + vh,
            "{name} at {:?} is outside the viewport {:?}",
            [x, y, w, h],
            st.viewport
        );
    }
    assert_eq!(st.look.exposure, 0.0);
    let default_ev100 = st.camera_look.as_ref().expect("the camera's exposure").0;
    let dark = viewport_brightness(&s.screenshot(), &st);

    // Dragging the exposure field to the right brightens, in one step.
    let field = widget(&st, "Exposure");
    s.drag(field, (field.0 + 80.0, field.1), 8);
    let st = s.frames(2);
    assert!(
        st.look.exposure > 0.8,
        "the drag set {} EV",
        st.look.exposure
    );
    assert_eq!(st.history.0, head + 1, "one drag is one step");
    let (ev100, _) = st.camera_look.clone().unwrap();
    assert!(
        (ev100 - (default_ev100 - st.look.exposure)).abs() < 1e-4,
        "the camera's EV100 {ev100} does not follow the look's {} EV",
        st.look.exposure
    );
    assert!(st.dirty, "a new look is an unsaved change");
    let st = s.wait_until("the picture converges again", CONVERGING, |st| {
        st.samples >= 4 && !st.denoising
    });
    let bright = viewport_brightness(&s.screenshot(), &st);
    assert!(
        bright > dark * 1.2 + 2.0,
        "{} EV more: mean {dark} -> {bright}",
        st.look.exposure
    );

    // Another curve from the menu: a step of its own, on the camera.
    s.click(widget(&st, "Tone curve").0, widget(&st, "Tone curve").1);
    let st = s.frames(2);
    click_widget(&mut s, &st, "Tone curve None (clip)");
    let st = s.frames(2);
    assert_eq!(
        st.look.tone,
        treelight_document::values::look::ToneCurve::None
    );
    assert_eq!(st.camera_look.as_ref().unwrap().1, "None");
    assert_eq!(st.history.0, head + 2);

    // Undo twice: the default look, on the camera and in the picture.
    s.key(&[keysym::CONTROL], keysym::letter('z'));
    s.key(&[keysym::CONTROL], keysym::letter('z'));
    let st = s.frames(2);
    assert_eq!(st.history.0, head);
    assert_eq!(
        st.look,
        treelight_document::values::look::SceneLook::default()
    );
    assert_eq!(st.camera_look.as_ref().unwrap().0, default_ev100);
    let st = s.wait_until("the picture converges again", CONVERGING, |st| {
        st.samples >= 4 && !st.denoising
    });
    let back = viewport_brightness(&s.screenshot(), &st);
    assert!(
        (back - dark).abs() < 0.1 * dark + 2.0,
        "undone: mean {dark} -> {back}"
    );
}

#[test]
fn the_inspector_turns_the_lamp_into_a_spot_light_as_one_step_and_undo_takes_it_back() {
    let mut s = Session::start("light-kind", &QUARTER_TRACE);
    let st = s.wait_until("the scene settles", CONVERGING, |st| {
        st.settled && st.samples >= 8 && !st.denoising
    });
    let lamp = object(&st, "Lamp light").clone();
    let point = lamp.light.expect("the lamp is a light");
    assert_eq!(
        point.kind,
        treelight_document::values::light::LightKind::Point
    );
    let (head, _) = st.history;
    let before = viewport_brightness(&s.screenshot(), &st);

    let row = row_centre(&st, lamp.id);
    s.click(row.0, row.1);
    let st = s.frames(2);
    assert_eq!(st.selection, vec![lamp.id]);
    click_widget(&mut s, &st, "Light kind");
    let st = s.frames(2);
    click_widget(&mut s, &st, "Light kind Spot light");
    let st = s.frames(2);
    let now = object(&st, "Lamp light").light.unwrap();
    assert_eq!(now.kind, treelight_document::values::light::LightKind::Spot);
    assert_eq!((now.intensity, now.color), (point.intensity, point.color));
    assert_eq!(st.history.0, head + 1, "one step");
    let st = s.wait_until("the picture converges again", CONVERGING, |st| {
        st.samples >= 8 && !st.denoising
    });
    let lit = viewport_brightness(&s.screenshot(), &st);
    eprintln!("mean brightness: point {before}, spot {lit}");
    assert!(
        (lit - before).abs() > 0.03 * before,
        "the spot light's cone changed nothing: {before} -> {lit}"
    );

    s.key(&[keysym::CONTROL], keysym::letter('z'));
    let st = s.frames(2);
    assert_eq!(st.history.0, head);
    assert_eq!(object(&st, "Lamp light").light, Some(point));
}

#[test]
fn f12_renders_the_view_to_a_png_beside_the_project_and_asks_before_replacing_it() {
    // A project in a folder of its own: the render goes beside it, named after it.
    let dir = support::temp_dir("render-window");
    let project = dir.join("room.treelight");
    let (ok, log) = support::run_without_display(&["--save", project.to_str().unwrap()]);
    assert!(ok, "{log}");
    let mut args = vec![project.to_str().unwrap()];
    args.extend(QUARTER_TRACE);
    let mut s = Session::start("render-window", &args);
    let st = s.wait_until(
        "the project opens",
        std::time::Duration::from_secs(60),
        |st| st.settled && st.project.as_deref() == Some(project.as_path()),
    );
    let _ = st;
    s.key(&[], keysym::F12);
    let st = s.frames(2);
    // Smaller and fewer samples than the defaults, typed into the fields (a click edits one).
    for (field, value) in [("Render width", "160"), ("Render samples", "2")] {
        let at = widget(&st, field);
        s.click(at.0, at.1);
        s.frames(1);
        for c in value.chars() {
            s.key(&[], keysym::letter(c));
        }
        s.key(&[], keysym::RETURN);
        s.frames(1);
    }
    let st = s.frames(2);
    click_widget(&mut s, &st, "Render");
    let out = dir.join("room.png");
    let st = s.wait_until(
        "the render is saved",
        std::time::Duration::from_secs(120),
        |st| st.notices.iter().any(|n| n.starts_with("Rendered")),
    );
    assert!(
        st.notices.iter().any(|n| n.contains("room.png")),
        "{:?}",
        st.notices
    );
    assert!(
        st.notices
            .iter()
            .any(|n| n.ends_with("at 2 samples per pixel")),
        "{:?}",
        st.notices
    );
    let img = support::load_rgb(&out);
    assert_eq!((img.width(), img.height()), (160, 400), "the size typed");
    let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(colours.len() > 500, "{} colours", colours.len());

    // Again: the file exists, so the editor asks; Cancel keeps it.
    let before = std::fs::read(&out).unwrap();
    let st = s.frames(2);
    click_widget(&mut s, &st, "Render");
    let st = s.frames(2);
    click_widget(&mut s, &st, "Cancel");
    let st = s.frames(3);
    assert!(
        st.widgets.iter().all(|(n, _)| n != "Replace"),
        "the question is gone"
    );
    assert!(
        st.widgets.iter().any(|(n, _)| n == "Render"),
        "no render started"
    );
    assert_eq!(std::fs::read(&out).unwrap(), before);
    std::fs::remove_dir_all(&dir).ok();
}

/// The viewport's left edge, below the toolbar: sky beside the room in the default view.
fn sky_beside_the_room(img: &image::RgbImage, st: &EditorState) -> [f32; 3] {
    let [x, y] = [st.viewport[0] as u32, st.viewport[1] as u32];
    let top = below_the_toolbar(st).max(y + 60);
    support::mean_rgb(img, x + 4, top, x + 40, top + 80)
}

#[test]
fn the_sky_menu_chooses_a_panorama_that_lights_the_view_and_undo_takes_it_back() {
    let mut s = Session::start("panorama", &QUARTER_TRACE);
    support::write_two_sided_sky(&s.dir().join("sky.hdr"));
    let st = s.wait_until("the scene settles", CONVERGING, |st| {
        st.settled && st.samples >= 4 && !st.denoising
    });
    let (head, _) = st.history;
    let before = sky_beside_the_room(&s.screenshot(), &st);
    // Sky → Choose… → the dialog, in the folder the editor runs in; the file's name, Return.
    click_widget(&mut s, &st, "Sky");
    let st = s.frames(2);
    // Opening the menu changes nothing.
    assert_eq!(st.history.0, head, "{:?}", st.history);
    click_widget(&mut s, &st, "Choose panorama");
    s.wait_until("the dialog", std::time::Duration::from_secs(30), |st| {
        st.dialog.is_some()
    });
    for c in ['s', 'k', 'y'] {
        s.key(&[], keysym::letter(c));
    }
    s.key(&[], keysym::PERIOD);
    for c in ['h', 'd', 'r'] {
        s.key(&[], keysym::letter(c));
    }
    s.key(&[], keysym::RETURN);
    s.wait_until(
        "the panorama, ready in the path tracer",
        std::time::Duration::from_secs(60),
        |st| st.dialog.is_none() && st.environment.1 && st.settled,
    );
    // Its upload restarts the accumulation a frame or two later. (A software adapter with a cold
    // shader cache compiles the trace kernel anew for the panorama's textures, most of a minute,
    // after the start's compile.)
    let st = s.wait_until(
        "the picture converges again, under the panorama",
        std::time::Duration::from_secs(150),
        |st| st.traced_panorama && st.samples >= 4,
    );
    let image = st.environment.0.image.clone().expect("a panorama");
    assert_eq!(image.file_name().unwrap(), "sky.hdr");
    assert_eq!(st.history.0, head + 1, "one step");
    assert!(st.dirty);
    // The view looks along −Z, at the panorama's green half.
    let green = sky_beside_the_room(&s.screenshot(), &st);
    assert!(
        green[1] > green[0] + 30.0 && green[1] > green[2] + 30.0,
        "{before:?} -> {green:?}"
    );
    // Undo: the flat sky again.
    s.key(&[keysym::CONTROL], keysym::letter('z'));
    let st = s.wait_until("the flat sky", CONVERGING, |st| {
        st.environment.0.image.is_none() && !st.traced_panorama && st.samples >= 4
    });
    assert_eq!(st.history.0, head);
    let after = sky_beside_the_room(&s.screenshot(), &st);
    assert!(
        after.iter().zip(before).all(|(a, b)| (a - b).abs() < 8.0),
        "{before:?} -> {after:?}"
    );
}

/// The toolbar's Quality menu, by real input: Denoise off, half resolution, and the view restarts
/// its samples at the new resolution (a quarter of the pixels traced).
#[test]
fn the_quality_menu_switches_the_denoiser_and_the_traced_resolution() {
    let mut s = Session::start("quality", &["--trace-scale", "1"]);
    let st = s.wait_until("the view has samples", CONVERGING, |st| {
        st.settled && st.samples >= 1
    });
    assert_eq!(
        st.quality,
        (true, 1.0, 4096),
        "the defaults and --trace-scale"
    );
    click_widget(&mut s, &st, "Quality");
    let st = s.frames(2);
    click_widget(&mut s, &st, "Denoise");
    let st = s.frames(2);
    assert!(!st.quality.0, "Denoise is off: {:?}", st.quality);
    // The menu stays open for the next choice.
    click_widget(&mut s, &st, "Resolution Half");
    let st = s.frames(2);
    assert_eq!(st.quality, (false, 0.5, 4096));
    s.key(&[], keysym::ESCAPE);
    let st = s.frames(2);
    assert!(
        widget_at(&st, "Resolution Half").is_none(),
        "Escape closes the menu"
    );
    // Nothing of the scene changed: no step.
    assert_eq!(st.history.0, 0);
}

#[test]
fn a_selected_mesh_stays_outlined_after_the_worker_rebuilds_it() {
    let bunny = support::shared_scene("obj/stanford-bunny.obj");
    // A coarse trace, so that a sweep over the view takes a frame.
    let mut s = Session::start(
        "outline-rebuild",
        &[bunny.to_str().unwrap(), "--trace-scale", "0.125"],
    );
    let st = s.frames(1);
    let mesh = st
        .objects
        .iter()
        .find(|o| o.mesh)
        .expect("the bunny")
        .clone();
    let [x, y] = mesh.screen.expect("the bunny in view");
    // Deleting the bunny and undoing that puts it back as a new group, and the view starts over.
    // Once it has been still, the worker bakes it and then rebuilds its tree into another slot,
    // neither restarting the view: its pixels keep the slot their first samples met. The scenario
    // needs samples before the rebuild; the worker may be quicker, so it is tried up to 3 times.
    for attempt in 1..=3 {
        s.click(x, y);
        s.key(&[], keysym::DELETE);
        let before = s.frames(1).memory.meshes_rebuilt;
        s.key(&[keysym::CONTROL], keysym::letter('z'));
        s.frames(1);
        // The samples seen before the rebuild (none after a restart), and the last seen.
        let (mut sampled, mut last) = (None::<u32>, 0);
        let start = std::time::Instant::now();
        let rebuilt = loop {
            assert!(
                start.elapsed() < std::time::Duration::from_secs(120),
                "the bunny was not rebuilt:\n{}",
                s.log()
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
            let Some(st) = s.try_state() else { continue };
            if ids_named(&st, &mesh.name).is_empty() {
                continue;
            }
            if sampled.is_some() && st.samples < last {
                // The view restarted after its first samples: not the scenario.
                sampled = None;
            }
            last = st.samples;
            if st.memory.meshes_rebuilt == before {
                if st.samples > 0 {
                    sampled = Some(st.samples);
                }
            } else {
                break st;
            }
        };
        let Some(first) = sampled else {
            eprintln!("attempt {attempt}: rebuilt before the view had samples");
            continue;
        };
        assert!(rebuilt.samples >= first, "the rebuild restarted the view");
        // Selected now: outlined, the view still holding its samples from before the rebuild.
        s.click(x, y);
        let st = s.frames(2);
        assert_eq!(st.selection, vec![mesh.id], "click on the bunny");
        assert!(
            st.samples >= rebuilt.samples,
            "the view restarted: {} samples, {} at the rebuild",
            st.samples,
            rebuilt.samples
        );
        let outlined = outline_pixels(&s.screenshot(), st.viewport);
        assert!(
            outlined > 100,
            "the rebuilt bunny is not outlined: {outlined} outline pixels"
        );
        return;
    }
    panic!("the worker rebuilt the bunny before the view had samples, 3 times");
}

#[test]
fn a_second_start_skips_the_kernel_warmup_the_first_recorded() {
    // On a software adapter the first start compiles the trace kernel on a device of its own
    // and records that in the editor's cache; a later start with the same cache (and driver,
    // shader cache, binary) goes straight to tracing, the driver's cache holding the kernel.
    let cache = support::temp_dir("kernel-record");
    let env = [("TREELIGHT_CACHE_DIR", cache.to_str().unwrap())];
    let traced = |s: &mut Session| {
        s.wait_until(
            "the view traced",
            std::time::Duration::from_secs(150),
            |st| st.samples >= 1,
        );
        s.log()
    };
    let first = traced(&mut Session::start_with("kernel-record-1", &[], &env));
    assert!(first.contains("trace kernel was compiled in"), "{first}");
    let records = std::fs::read_dir(cache.join("kernels")).unwrap().count();
    assert_eq!(records, 1, "one kernel, one texture state");
    let second = traced(&mut Session::start_with("kernel-record-2", &[], &env));
    assert!(!second.contains("trace kernel was compiled in"), "{second}");
    assert!(
        second.contains("trace kernel was compiled at an earlier start"),
        "{second}"
    );
    std::fs::remove_dir_all(&cache).ok();
}
