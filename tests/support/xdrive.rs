//! Driving the real editor as a user does: its own virtual X server (Xvfb), the editor's window on
//! it, and input sent through the X server's XTEST extension (pointer motion, buttons, keys), so
//! the events reach the editor exactly as a user's would (winit, Bevy's input, egui). The editor
//! reports its world through `--state PATH`; screenshots come from the X server.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use treelight::report::EditorState;
use treelight::report::ObjectReport;
use x11rb::connection::Connection;
use x11rb::protocol::xproto::{self, ConnectionExt as _};
use x11rb::protocol::xtest::ConnectionExt as _;
use x11rb::rust_connection::RustConnection;

/// X keysyms used by the tests.
pub mod keysym {
    /// Escape.
    pub const ESCAPE: u32 = 0xff1b;
    /// Delete.
    pub const DELETE: u32 = 0xffff;
    /// Left Control.
    pub const CONTROL: u32 = 0xffe3;
    /// Left Shift.
    pub const SHIFT: u32 = 0xffe1;
    /// Left Alt.
    pub const ALT: u32 = 0xffe9;
    /// F2.
    pub const F2: u32 = 0xffbf;
    /// F12.
    pub const F12: u32 = 0xffc9;
    /// Return.
    pub const RETURN: u32 = 0xff0d;
    /// The full stop.
    pub const PERIOD: u32 = 0x2e;
    /// A lower-case letter.
    pub const fn letter(c: char) -> u32 {
        c as u32
    }
}

/// A running editor on its own X server.
pub struct Session {
    xvfb: Child,
    editor: Child,
    conn: RustConnection,
    root: xproto::Window,
    window: xproto::Window,
    /// Window origin on the screen.
    origin: (i16, i16),
    state_path: PathBuf,
    log_path: PathBuf,
    dir: PathBuf,
    /// Whether the session made `dir` (a test's own folder, made before, is the test's to remove).
    owns_dir: bool,
    keycodes: Vec<(u32, u8)>,
    display: u32,
    /// Button and key events sent: [`Session::frames`] first waits for the editor to have read
    /// them all (on a loaded machine one may arrive frames later).
    sent: std::cell::Cell<u64>,
    /// The turn this editor holds: released (after `Drop` ends the processes) for the next.
    _turn: std::sync::MutexGuard<'static, ()>,
}

impl Drop for Session {
    fn drop(&mut self) {
        let _ = self.editor.kill();
        let _ = self.editor.wait();
        end_server(&mut self.xvfb, self.display);
        // A passing test leaves nothing behind; a failing one keeps its log, report and shots.
        if self.owns_dir && !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// Has `command`'s process killed when the test's thread ends without ending it: a test binary
/// killed outright (a CI timeout, Ctrl+C) runs no `Drop`, and an editor left behind traces to its
/// sample limit on every core, slowing every later run on the machine. The kernel ties the child
/// to the thread that spawned it, so a session is started on the thread that holds it.
fn ends_with_the_test(command: &mut Command) -> &mut Command {
    use std::os::unix::process::CommandExt as _;
    let test = std::process::id();
    // SAFETY: between fork and exec the closure calls only `prctl`, `getppid` and `_exit`, all
    // async-signal-safe, and touches no memory the parent's other threads own.
    unsafe {
        command.pre_exec(move || {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            // The test may have gone before the call took effect.
            if u32::try_from(libc::getppid()).ok() != Some(test) {
                libc::_exit(1);
            }
            Ok(())
        })
    }
}

/// Ends an Xvfb politely (SIGTERM, so it removes its lock file and socket) and then firmly, and
/// removes what a server killed outright left behind: stale locks from thousands of earlier runs
/// on a machine whose `/tmp` persists would otherwise leave no display number free.
fn end_server(xvfb: &mut Child, display: u32) {
    if let Ok(pid) = i32::try_from(xvfb.id()) {
        // SAFETY: `kill` with a child's own pid and a signal number has no memory effects.
        unsafe { libc::kill(pid, libc::SIGTERM) };
    }
    let start = Instant::now();
    while !matches!(xvfb.try_wait(), Ok(Some(_))) && start.elapsed() < Duration::from_secs(3) {
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = xvfb.kill();
    let _ = xvfb.wait();
    let lock = lock_path(display);
    if lock_owner(&lock) == Some(xvfb.id()) {
        let _ = std::fs::remove_file(socket_path(display));
        let _ = std::fs::remove_file(&lock);
    }
}

/// Where an X server on `display` keeps its lock file.
pub fn lock_path(display: u32) -> PathBuf {
    PathBuf::from(format!("/tmp/.X{display}-lock"))
}

/// Where an X server on `display` listens.
pub fn socket_path(display: u32) -> PathBuf {
    PathBuf::from(format!("/tmp/.X11-unix/X{display}"))
}

/// The pid an X server wrote into its lock file (ten digits and a newline), if it reads as one.
fn lock_owner(lock: &Path) -> Option<u32> {
    use std::io::Read as _;
    let mut text = String::new();
    std::fs::File::open(lock)
        .ok()?
        .take(64)
        .read_to_string(&mut text)
        .ok()?;
    text.trim().parse().ok()
}

/// Whether display `n` can be had: no lock and no socket, or a lock whose server is gone (its
/// leftovers are removed, as an X server does itself with a stale lock).
pub fn display_free(n: u32) -> bool {
    let (lock, socket) = (lock_path(n), socket_path(n));
    if !lock.exists() {
        return !socket.exists();
    }
    match lock_owner(&lock) {
        Some(pid) if !Path::new(&format!("/proc/{pid}")).exists() => {
            let _ = std::fs::remove_file(&socket);
            let _ = std::fs::remove_file(&lock);
            !lock.exists() && !socket.exists()
        }
        _ => false,
    }
}

fn free_display() -> u32 {
    // Tests of one process run side by side: each call starts further along.
    static CALLS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let base = 200 + (std::process::id() % 500) + call * 7;
    (base..base + 2000)
        .find(|&n| display_free(n))
        .expect("a free X display number (every one from 200 on has a live server's lock)")
}

impl Session {
    /// Starts Xvfb and the editor with `args` (plus `--state`), and waits until the editor's scene
    /// has loaded and its BVH is idle.
    pub fn start(name: &str, args: &[&str]) -> Session {
        Self::start_with(name, args, &[])
    }

    /// [`Session::start`] with extra environment variables for the editor.
    pub fn start_with(name: &str, args: &[&str], env: &[(&str, &str)]) -> Session {
        // A software adapter with a cold shader cache compiles the path tracer's kernel for up to
        // a minute while the frames go on: the view is traced once it is ready.
        Self::start_until(
            name,
            args,
            env,
            "the editor's scene settles and its view is ready to trace",
            |s| s.settled && s.frame > 5 && s.preparing_kernel.is_none(),
        )
    }

    /// [`Session::start_with`], started once `ready` accepts the editor's report.
    pub fn start_until(
        name: &str,
        args: &[&str],
        env: &[(&str, &str)],
        what: &str,
        ready: impl Fn(&EditorState) -> bool,
    ) -> Session {
        // One editor at a time in a test process: two software-rendered editors on two cores
        // make each one's frames late enough that input lands frames after it was sent.
        static TURN: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let turn = TURN.lock().unwrap_or_else(|p| p.into_inner());
        let owns_dir = !crate::support::temp_dir_path(name).exists();
        let dir = crate::support::temp_dir(name);
        let mut last_error = String::new();
        for _ in 0..3 {
            let display = free_display();
            let mut xvfb = ends_with_the_test(&mut Command::new("Xvfb"))
                .arg(format!(":{display}"))
                .args(["-screen", "0", "1600x1000x24", "-nolisten", "tcp"])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap_or_else(|e| {
                    panic!("cannot start Xvfb ({e}). Install: apt-get install -y xvfb")
                });
            let socket = socket_path(display);
            let start = Instant::now();
            while !socket.exists() && start.elapsed() < Duration::from_secs(10) {
                if let Ok(Some(_)) = xvfb.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            // A server that exits at once lost the display number to another one.
            std::thread::sleep(Duration::from_millis(100));
            let lost = matches!(xvfb.try_wait(), Ok(Some(_)));
            let connected = if lost {
                None
            } else {
                x11rb::connect(Some(&format!(":{display}"))).ok()
            };
            let Some((conn, screen)) = connected else {
                last_error = format!("cannot connect to Xvfb on :{display}");
                end_server(&mut xvfb, display);
                continue;
            };
            let root = conn.setup().roots[screen].root;
            // No autorepeat: a key is held for a frame, and a frame late under load (over the
            // server's 660-ms delay) would otherwise type the letter a dozen times.
            conn.change_keyboard_control(
                &xproto::ChangeKeyboardControlAux::new()
                    .auto_repeat_mode(xproto::AutoRepeatMode::OFF),
            )
            .expect("the X server takes keyboard settings")
            .check()
            .expect("autorepeat turned off");
            let state_path = dir.join("state.ron");
            let log_path = dir.join("editor.log");
            let log = std::fs::File::create(&log_path).unwrap();
            // The tests' window unless the test asks for another size.
            let size: &[&str] = if args.contains(&"--width") {
                &[]
            } else {
                &crate::support::TEST_WINDOW
            };
            let editor = ends_with_the_test(&mut Command::new(env!("CARGO_BIN_EXE_treelight")))
                .args(size)
                .args(args)
                .arg("--state")
                .arg(&state_path)
                .env("DISPLAY", format!(":{display}"))
                .env("WGPU_BACKEND", "vulkan")
                .env("TREELIGHT_CONFIG_DIR", dir.join("config"))
                .env("TREELIGHT_CACHE_DIR", dir.join("cache"))
                // The in-window dialog, whatever the machine has (a test may ask otherwise).
                .env("TREELIGHT_FILE_DIALOG", "builtin")
                // Files the editor's dialogs offer are the test's own.
                .current_dir(&dir)
                .envs(env.iter().copied())
                .stdout(log.try_clone().unwrap())
                .stderr(log)
                .spawn()
                .expect("the editor starts");
            let keycodes = keycodes(&conn);
            let mut session = Session {
                xvfb,
                editor,
                conn,
                root,
                window: 0,
                origin: (0, 0),
                state_path,
                log_path,
                dir,
                owns_dir,
                keycodes,
                display,
                sent: std::cell::Cell::new(0),
                _turn: turn,
            };
            session.wait_until(what, Duration::from_secs(240), &ready);
            session.find_window();
            // Let the layout and the first path-traced frames settle.
            session.frames(4);
            return session;
        }
        panic!("{last_error}");
    }

    /// The folder the editor runs in (its working directory).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Whether the editor has exited.
    pub fn exited(&mut self) -> bool {
        matches!(self.editor.try_wait(), Ok(Some(_)))
    }

    /// The editor's log so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log_path).unwrap_or_default()
    }

    /// The editor's latest report, if it has written one.
    pub fn try_state(&self) -> Option<EditorState> {
        let text = std::fs::read_to_string(&self.state_path).ok()?;
        ron::from_str(&text).ok()
    }

    /// Waits for a report that `ok` accepts, panicking with `what` and the log after `timeout`.
    pub fn wait_until(
        &mut self,
        what: &str,
        timeout: Duration,
        ok: impl Fn(&EditorState) -> bool,
    ) -> EditorState {
        let start = Instant::now();
        loop {
            if let Ok(Some(status)) = self.editor.try_wait() {
                panic!(
                    "the editor exited ({status}) waiting for {what}:\n{}",
                    self.log()
                );
            }
            if let Some(s) = self.try_state()
                && ok(&s)
            {
                return s;
            }
            if start.elapsed() > timeout {
                panic!(
                    "timed out waiting for {what}; last state: {:#?}\nlog:\n{}",
                    self.try_state(),
                    self.log()
                );
            }
            std::thread::sleep(Duration::from_millis(30));
        }
    }

    /// Waits until the editor has drawn `n` more frames, or come to rest (it draws no frame
    /// without a change), and returns its report.
    pub fn frames(&mut self, n: u64) -> EditorState {
        let sent = self.sent.get();
        self.wait_until(
            "the editor to read the buttons and keys sent",
            Duration::from_secs(60),
            |s| s.inputs >= sent,
        );
        // Every input sent has been read: an editor at rest has drawn its effects.
        let now = self
            .wait_until("a report", Duration::from_secs(60), |_| true)
            .frame;
        self.wait_until("frames", Duration::from_secs(120), |s| {
            s.frame >= now + n || s.at_rest
        })
    }

    /// [`Session::frames`] without waiting for the input sent to be read: between the halves of
    /// a click or a chord, which must stay as close together as a person makes them.
    fn frames_between(&mut self, n: u64) -> EditorState {
        let now = self
            .wait_until("a report", Duration::from_secs(60), |_| true)
            .frame;
        // The input just sent wakes a resting editor: a frame after `now` has read it (input the
        // X server drops, as a move to where the pointer is, wakes nothing: a second does).
        let sent = Instant::now();
        self.wait_until("frames", Duration::from_secs(120), |s| {
            s.frame >= now + n
                || (s.at_rest && (s.frame > now || sent.elapsed() > Duration::from_secs(1)))
        })
    }

    fn find_window(&mut self) {
        let start = Instant::now();
        loop {
            let tree = self.conn.query_tree(self.root).unwrap().reply().unwrap();
            for w in tree.children {
                let name = self
                    .conn
                    .get_property(
                        false,
                        w,
                        xproto::AtomEnum::WM_NAME,
                        xproto::AtomEnum::ANY,
                        0,
                        256,
                    )
                    .ok()
                    .and_then(|c| c.reply().ok())
                    .map(|r| String::from_utf8_lossy(&r.value).into_owned())
                    .unwrap_or_default();
                if name.contains("Treelight") {
                    let t = self
                        .conn
                        .translate_coordinates(w, self.root, 0, 0)
                        .unwrap()
                        .reply()
                        .unwrap();
                    self.window = w;
                    self.origin = (t.dst_x, t.dst_y);
                    // What a window manager does when the user clicks the window: give it the
                    // keyboard.
                    self.conn
                        .set_input_focus(xproto::InputFocus::PARENT, w, x11rb::CURRENT_TIME)
                        .unwrap();
                    self.conn.flush().unwrap();
                    return;
                }
            }
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "no Treelight window on the X server"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    fn fake(&self, kind: u8, detail: u8, x: i16, y: i16) {
        // X's buttons 4 to 7 are the wheel: a press is one wheel message, a release none.
        let wheel = (4..=7).contains(&detail)
            && (kind == xproto::BUTTON_PRESS_EVENT || kind == xproto::BUTTON_RELEASE_EVENT);
        let counted = match kind {
            xproto::MOTION_NOTIFY_EVENT => false,
            xproto::BUTTON_RELEASE_EVENT if wheel => false,
            _ => true,
        };
        if counted {
            self.sent.set(self.sent.get() + 1);
        }
        self.conn
            .xtest_fake_input(kind, detail, x11rb::CURRENT_TIME, self.root, x, y, 0)
            .unwrap();
        self.conn.flush().unwrap();
    }

    /// The X display the editor runs on (`:N`).
    pub fn display_name(&self) -> String {
        format!(":{}", self.display)
    }

    /// The editor window's X id.
    pub fn window_id(&self) -> u32 {
        self.window
    }

    /// Moves the pointer to window coordinates `(x, y)` and lets a frame pass.
    pub fn move_to(&mut self, x: f32, y: f32) {
        let (ox, oy) = self.origin;
        self.fake(
            xproto::MOTION_NOTIFY_EVENT,
            0,
            ox + x.round() as i16,
            oy + y.round() as i16,
        );
        self.frames_between(1);
    }

    /// Presses mouse button `b` (1 left, 2 middle, 3 right).
    pub fn press(&mut self, b: u8) {
        self.fake(xproto::BUTTON_PRESS_EVENT, b, 0, 0);
        self.frames_between(1);
    }

    /// Releases mouse button `b`.
    pub fn release(&mut self, b: u8) {
        self.fake(xproto::BUTTON_RELEASE_EVENT, b, 0, 0);
        self.frames(2);
    }

    /// A click of the left button at `(x, y)`.
    pub fn click(&mut self, x: f32, y: f32) {
        self.move_to(x, y);
        self.press(1);
        self.release(1);
    }

    /// A double click of the left button at `(x, y)`: both clicks sent at once, since a
    /// double click must fit in a fraction of a second and a software-rendered frame may not.
    pub fn double_click(&mut self, x: f32, y: f32) {
        self.move_to(x, y);
        for _ in 0..2 {
            self.fake(xproto::BUTTON_PRESS_EVENT, 1, 0, 0);
            self.fake(xproto::BUTTON_RELEASE_EVENT, 1, 0, 0);
        }
        self.frames(2);
    }

    /// Drags with the left button from `from` to `to` in `steps` moves (a frame each), without
    /// releasing.
    pub fn drag_without_release(&mut self, from: (f32, f32), to: (f32, f32), steps: u32) {
        self.move_to(from.0, from.1);
        self.press(1);
        for k in 1..=steps {
            let t = k as f32 / steps as f32;
            self.move_to(from.0 + (to.0 - from.0) * t, from.1 + (to.1 - from.1) * t);
        }
    }

    /// A whole left-button drag.
    pub fn drag(&mut self, from: (f32, f32), to: (f32, f32), steps: u32) {
        self.drag_without_release(from, to, steps);
        self.release(1);
    }

    fn keycode(&self, sym: u32) -> u8 {
        self.keycodes
            .iter()
            .find(|(s, _)| *s == sym)
            .map(|(_, k)| *k)
            .unwrap_or_else(|| panic!("no keycode for keysym {sym:#x}"))
    }

    /// Presses or releases a key without waiting.
    pub fn key_event(&mut self, sym: u32, down: bool) {
        let kind = if down {
            xproto::KEY_PRESS_EVENT
        } else {
            xproto::KEY_RELEASE_EVENT
        };
        self.fake(kind, self.keycode(sym), 0, 0);
    }

    /// Types a key while holding `modifiers`, then lets frames pass.
    pub fn key(&mut self, modifiers: &[u32], sym: u32) {
        for m in modifiers {
            self.key_event(*m, true);
        }
        self.frames_between(1);
        self.key_event(sym, true);
        self.frames_between(1);
        self.key_event(sym, false);
        for m in modifiers {
            self.key_event(*m, false);
        }
        self.frames(2);
    }

    /// The window as an RGB image, taken from the X server.
    pub fn screenshot(&self) -> image::RgbImage {
        let geo = self
            .conn
            .get_geometry(self.window)
            .unwrap()
            .reply()
            .unwrap();
        let img = self
            .conn
            .get_image(
                xproto::ImageFormat::Z_PIXMAP,
                self.window,
                0,
                0,
                geo.width,
                geo.height,
                !0,
            )
            .unwrap()
            .reply()
            .unwrap();
        let (w, h) = (geo.width as u32, geo.height as u32);
        let mut out = image::RgbImage::new(w, h);
        for (i, p) in out.pixels_mut().enumerate() {
            let b = &img.data[i * 4..i * 4 + 3];
            *p = image::Rgb([b[2], b[1], b[0]]);
        }
        out
    }

    /// Saves a screenshot beside the test's other files and returns its path.
    pub fn save_screenshot(&self, name: &str) -> PathBuf {
        let path = self.dir.join(format!("{name}.png"));
        self.screenshot().save(&path).unwrap();
        path
    }
}

fn keycodes(conn: &RustConnection) -> Vec<(u32, u8)> {
    let setup = conn.setup();
    let (min, max) = (setup.min_keycode, setup.max_keycode);
    let map = conn
        .get_keyboard_mapping(min, max - min + 1)
        .unwrap()
        .reply()
        .unwrap();
    let per = map.keysyms_per_keycode as usize;
    let mut out = Vec::new();
    for (i, syms) in map.keysyms.chunks(per.max(1)).enumerate() {
        // The unshifted symbol is the key's own.
        if let Some(&s) = syms.first()
            && s != 0
        {
            out.push((s, min + i as u8));
        }
    }
    out
}

/// The named widget's rectangle the report lists (left, top, width, height), if it is laid out.
fn widget_rect_at(st: &EditorState, name: &str) -> Option<[f32; 4]> {
    st.widgets.iter().find(|(n, _)| n == name).map(|(_, r)| *r)
}

/// The centre of the named widget the report lists, if it is laid out.
pub fn widget_at(st: &EditorState, name: &str) -> Option<(f32, f32)> {
    widget_rect_at(st, name).map(|r| (r[0] + r[2] / 2.0, r[1] + r[3] / 2.0))
}

/// The named widget's rectangle the report lists: its left, top, width and height.
pub fn widget_rect(st: &EditorState, name: &str) -> [f32; 4] {
    widget_rect_at(st, name).unwrap_or_else(|| panic!("no widget {name}: {:?}", st.widgets))
}

/// The first screen row the view shows below its toolbar (one row or more, as wide as it is).
pub fn below_the_toolbar(st: &EditorState) -> u32 {
    let bar = widget_rect(st, "Viewport toolbar");
    (bar[1] + bar[3] + 2.0) as u32
}

/// The viewport's rectangle below its toolbar, `[x, y, width, height]` in whole screen pixels.
pub fn view_below_the_toolbar(st: &EditorState) -> [u32; 4] {
    let [x, y, w, h] = st.viewport.map(|v| v.max(0.0) as u32);
    let top = below_the_toolbar(st);
    [x, top, w, (y + h).saturating_sub(top)]
}

/// The centre of the named widget the report lists.
pub fn widget(st: &EditorState, name: &str) -> (f32, f32) {
    widget_at(st, name).unwrap_or_else(|| panic!("no widget {name}: {:?}", st.widgets))
}

/// The object named `name` in a report.
pub fn object<'a>(state: &'a EditorState, name: &str) -> &'a ObjectReport {
    state
        .objects
        .iter()
        .find(|o| o.name == name)
        .unwrap_or_else(|| panic!("no object named {name}: {:#?}", state.objects))
}

/// The screen points of a gizmo handle in a report.
pub fn handle<'a>(state: &'a EditorState, name: &str) -> &'a [[f32; 2]] {
    &state
        .gizmo
        .iter()
        .find(|h| h.handle == name)
        .unwrap_or_else(|| panic!("no gizmo handle {name}: {:#?}", state.gizmo))
        .points
}
