//! Autosave and recovery: while there are unsaved changes, a recovery copy of the project is
//! written every interval of real time (30 s; `TREELIGHT_AUTOSAVE_SECS` changes it) on a thread of
//! its own, beside the project (`.NAME.recovery.treelight`) or, for a scene never saved, in the
//! cache directory. A write that fails is shown in the window and tried again. Each running editor
//! holds a lock in the cache directory (`editor-PID.lock`, an `flock` the system releases when the
//! process dies) and each copy names its editor, so the offer at start names only copies whose
//! editor is gone: a project's own copy when newer than it, or else the newest unsaved scene's.
//! Copies older than a week are removed; a save, and quitting with the changes discarded, remove
//! the copy that became stale; an editor starting removes the locks of editors that are gone.

use crate::edit::history::EditHistory;
use crate::notice::Notices;
use crate::project::capture::capture_project;
use crate::project::format::{ProjectState, project_text};
use bevy::prelude::*;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// Recovery copies older than this are removed instead of offered.
pub const MAX_AGE: Duration = Duration::from_secs(7 * 24 * 3600);

/// How soon a failed write is tried again (or the interval, if shorter).
const RETRY: Duration = Duration::from_secs(5);

/// The first line of every recovery copy: which editor process wrote it.
const HEADER: &str = "// treelight recovery copy, written by editor process ";

/// The recovery copy for the project at `project`.
pub fn recovery_beside(project: &Path) -> PathBuf {
    let name = project
        .file_name()
        .map_or("project".into(), |n| n.to_string_lossy().into_owned());
    let stem = name.strip_suffix(".treelight").unwrap_or(&name);
    project.with_file_name(format!(".{stem}.recovery.treelight"))
}

/// Where unsaved scenes' recovery copies and the editors' locks go ([`crate::folders::cache_dir`]).
pub fn cache_dir() -> Option<PathBuf> {
    crate::folders::cache_dir()
}

/// The recovery copy of an unsaved scene of this editor process.
fn unsaved_recovery() -> Option<PathBuf> {
    cache_dir().map(|d| d.join(format!("unsaved-{}.recovery.treelight", std::process::id())))
}

fn lock_path(dir: &Path, pid: u32) -> PathBuf {
    dir.join(format!("editor-{pid}.lock"))
}

/// This editor's lock in the cache directory, held while it runs (dropping the file, or the
/// process dying, releases it).
pub struct EditorLock {
    _file: std::fs::File,
}

/// How old a released lock must be before it is removed: a younger one may belong to an editor
/// that made the file and has not locked it yet.
const LOCK_GRACE: Duration = Duration::from_secs(60);

impl EditorLock {
    /// Takes this process's lock in `dir` (made if need be), and removes the locks that editors no
    /// longer running left behind (a missing lock says the same as a released one).
    pub fn take(dir: &Path) -> std::io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(lock_path(dir, std::process::id()))?;
        file.lock()?;
        for (_, stale) in left_by_gone_editors(dir, "editor-", ".lock") {
            let young = modified(&stale)
                .and_then(|t| t.elapsed().ok())
                .is_none_or(|age| age < LOCK_GRACE);
            if !young {
                let _ = std::fs::remove_file(stale);
            }
        }
        Ok(Self { _file: file })
    }
}

/// Whether editor process `pid` is running: whether its lock in `dir` is held.
pub fn editor_running(dir: &Path, pid: u32) -> bool {
    let Ok(file) = std::fs::OpenOptions::new()
        .write(true)
        .open(lock_path(dir, pid))
    else {
        return false;
    };
    matches!(file.try_lock(), Err(std::fs::TryLockError::WouldBlock))
}

/// The files in `dir` named `PREFIX-PID.SUFFIX` whose editor process PID is neither this one nor
/// still running (its lock in `dir` is free), with that PID.
pub fn left_by_gone_editors(dir: &Path, prefix: &str, suffix: &str) -> Vec<(u32, PathBuf)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .flatten()
        .map(|e| e.path())
        .filter_map(|p| {
            let pid = p
                .file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_prefix(prefix))
                .and_then(|n| n.strip_suffix(suffix))
                .and_then(|n| n.parse::<u32>().ok())?;
            (pid != std::process::id() && !editor_running(dir, pid)).then_some((pid, p))
        })
        .collect()
}

/// The editor process that wrote the recovery copy at `path`, from its first line.
fn writer_of(path: &Path) -> Option<u32> {
    use std::io::Read;
    let mut head = [0u8; 96];
    let n = std::fs::File::open(path).ok()?.read(&mut head).ok()?;
    let text = std::str::from_utf8(&head[..n]).ok()?;
    text.strip_prefix(HEADER)?
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

fn modified(p: &Path) -> Option<SystemTime> {
    std::fs::metadata(p).and_then(|m| m.modified()).ok()
}

fn too_old(p: &Path) -> bool {
    modified(p)
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age > MAX_AGE)
}

/// Whether the copy at `path` belongs to another editor still running (so it is not offered).
fn owned_by_running_editor(path: &Path, cache: Option<&Path>) -> bool {
    match (cache, writer_of(path)) {
        (Some(dir), Some(pid)) => pid != std::process::id() && editor_running(dir, pid),
        _ => false,
    }
}

/// The recovery copy to offer at start: for `project`, its own copy when newer than it; with no
/// project, the newest unsaved scene's copy in the cache directory. Copies of running editors are
/// left alone; copies older than [`MAX_AGE`] are removed.
pub fn recovery_to_offer(project: Option<&Path>) -> Option<PathBuf> {
    recovery_to_offer_in(project, cache_dir().as_deref())
}

/// [`recovery_to_offer`] with the cache directory given.
pub fn recovery_to_offer_in(project: Option<&Path>, cache: Option<&Path>) -> Option<PathBuf> {
    match project {
        Some(p) => {
            let r = recovery_beside(p);
            if too_old(&r) && !owned_by_running_editor(&r, cache) {
                let _ = std::fs::remove_file(&r);
                return None;
            }
            let newer = match (modified(&r), modified(p)) {
                (Some(a), Some(b)) => a > b,
                (Some(_), None) => true,
                _ => false,
            };
            (newer && !owned_by_running_editor(&r, cache)).then_some(r)
        }
        None => {
            let dir = cache?;
            let mut copies = Vec::new();
            for (pid, p) in left_by_gone_editors(dir, "unsaved-", ".recovery.treelight") {
                if too_old(&p) {
                    let _ = std::fs::remove_file(&p);
                    let _ = std::fs::remove_file(lock_path(dir, pid));
                    continue;
                }
                if let Some(t) = modified(&p) {
                    copies.push((t, p));
                }
            }
            copies.into_iter().max_by_key(|(t, _)| *t).map(|(_, p)| p)
        }
    }
}

/// A recovery copy being written: where, and the thread's answer.
struct Writer {
    target: PathBuf,
    thread: std::thread::JoinHandle<Result<(), String>>,
}

/// Autosave's clock and the recovery offer.
#[derive(Resource)]
pub struct Autosave {
    /// Time between recovery copies.
    pub interval: Duration,
    /// When the unsaved changes were last copied (or became unsaved), in real time.
    last: Option<Instant>,
    /// A recovery copy offered at start, until the user answers.
    pub offer: Option<PathBuf>,
    /// The copy last written whole, removed when the scene is saved.
    written: Option<PathBuf>,
    writer: Option<Writer>,
    /// Why the last write failed, while writes fail.
    pub failing: Option<String>,
    /// This editor's lock, held while it runs.
    _lock: Option<EditorLock>,
}

impl Autosave {
    /// Takes `path` as this scene's recovery copy, so a save removes it.
    pub fn adopt(&mut self, path: PathBuf) {
        self.written = Some(path);
    }

    /// Waits for a write under way, then removes the copy this scene wrote: its changes were
    /// saved or discarded, so no copy may be left to be offered.
    pub fn remove_copy(&mut self) {
        if let Some(w) = self.writer.take()
            && w.thread.join().ok().and_then(Result::ok).is_some()
        {
            self.written = Some(w.target);
        }
        if let Some(old) = self.written.take() {
            let _ = std::fs::remove_file(old);
        }
        self.last = None;
    }
}

impl Default for Autosave {
    fn default() -> Self {
        let secs = std::env::var("TREELIGHT_AUTOSAVE_SECS")
            .ok()
            .and_then(|v| v.parse::<f32>().ok())
            .filter(|v| v.is_finite() && *v > 0.0)
            .unwrap_or(30.0);
        Self {
            interval: Duration::from_secs_f32(secs),
            last: None,
            offer: None,
            written: None,
            writer: None,
            failing: None,
            _lock: None,
        }
    }
}

impl Autosave {
    /// The editor's autosave: [`Autosave::default`], holding this editor's lock in the cache
    /// directory while it runs, so other editors leave its copies alone.
    pub fn for_editor() -> Self {
        Self {
            _lock: cache_dir().and_then(|d| EditorLock::take(&d).ok()),
            ..Self::default()
        }
    }
}

/// Writes a recovery copy every interval while there are unsaved changes; removes it once saved.
pub fn autosave(world: &mut World) {
    let now = Instant::now();
    let dirty = world.resource::<EditHistory>().is_dirty();
    let project = world.resource::<ProjectState>().path.clone();
    let mut auto = world.resource_mut::<Autosave>();
    if !dirty {
        // The save that made the scene clean may have raced a write: wait for it, then remove.
        if auto.writer.is_some() || auto.written.is_some() {
            auto.remove_copy();
        }
        auto.last = None;
        return;
    }
    // A write that finished: counted as written only when it was.
    if auto.writer.as_ref().is_some_and(|w| w.thread.is_finished())
        && let Some(w) = auto.writer.take()
    {
        let result = w
            .thread
            .join()
            .unwrap_or_else(|_| Err("the autosave thread panicked".into()));
        match result {
            Ok(()) => {
                auto.written = Some(w.target);
                if auto.failing.take().is_some() {
                    world
                        .resource_mut::<Notices>()
                        .info("autosave: recovery copies are written again");
                }
            }
            Err(e) => {
                let first = auto.failing.is_none();
                auto.failing = Some(e.clone());
                // Try again soon rather than a whole interval later.
                let retry = auto.interval.min(RETRY);
                auto.last = Some(now - auto.interval + retry);
                if first {
                    world.resource_mut::<Notices>().error(format!(
                        "autosave failed, retrying every {} s: {e}",
                        retry.as_secs_f32()
                    ));
                }
            }
        }
        auto = world.resource_mut::<Autosave>();
    }
    let last = *auto.last.get_or_insert(now);
    if now.duration_since(last) < auto.interval || auto.writer.is_some() {
        return;
    }
    auto.last = Some(now);
    let Some(target) = project
        .as_deref()
        .map(recovery_beside)
        .or_else(unsaved_recovery)
    else {
        return;
    };
    // Capturing reads the world (no geometry: quick); the disk write happens off this thread.
    let at = project.clone().unwrap_or_else(|| target.clone());
    let (file, _) = capture_project(world, &at);
    let path = target.clone();
    let thread = std::thread::Builder::new()
        .name("treelight-autosave".into())
        .spawn(move || {
            let body = project_text(&file).map_err(|e| e.to_string())?;
            let text = format!("{HEADER}{}\n{body}", std::process::id());
            if let Some(dir) = path.parent() {
                std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            }
            crate::atomic_file::write_atomically(&path, text.as_bytes())
                .map_err(|e| format!("{}: {e}", path.display()))
        });
    let mut auto = world.resource_mut::<Autosave>();
    match thread {
        Ok(thread) => auto.writer = Some(Writer { target, thread }),
        Err(e) => auto.failing = Some(e.to_string()),
    }
}

/// Looks for a recovery copy to offer, once the scene named on the command line is known.
pub fn find_recovery(mut auto: ResMut<Autosave>, state: Res<ProjectState>, mut done: Local<u32>) {
    // A project named on the command line is opened in the first frames.
    *done += 1;
    if *done != 3 {
        return;
    }
    auto.offer = recovery_to_offer(state.path.as_deref());
}

/// Recovery copies while editing, and finding the one to offer at start (the offer is the
/// shell's: [`Autosave::offer`]).
pub struct AutosavePlugin;

impl Plugin for AutosavePlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(Autosave::for_editor())
            .add_systems(Update, (autosave, find_recovery));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recovery_copy_is_offered_only_when_newer_than_its_project() {
        let dir = std::env::temp_dir().join(format!("treelight-recovery-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let project = dir.join("house.treelight");
        let recovery = recovery_beside(&project);
        assert_eq!(recovery, dir.join(".house.recovery.treelight"));
        std::fs::write(&recovery, "old").unwrap();
        std::thread::sleep(Duration::from_millis(20));
        std::fs::write(&project, "saved later").unwrap();
        assert_eq!(recovery_to_offer(Some(&project)), None);
        std::thread::sleep(Duration::from_millis(20));
        std::fs::write(&recovery, "newer").unwrap();
        assert_eq!(recovery_to_offer(Some(&project)), Some(recovery));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// An unsaved scene's copy as editor process `pid` leaves it, written `age` ago.
    fn unsaved_copy(cache: &Path, pid: u32, age: Duration) -> PathBuf {
        let path = cache.join(format!("unsaved-{pid}.recovery.treelight"));
        std::fs::write(&path, format!("{HEADER}{pid}\n(version: 1)")).unwrap();
        let f = std::fs::File::options().write(true).open(&path).unwrap();
        f.set_modified(SystemTime::now() - age).unwrap();
        path
    }

    /// Holds process `pid`'s lock as that editor would while running.
    fn hold_lock(cache: &Path, pid: u32) -> std::fs::File {
        let f = std::fs::File::create(lock_path(cache, pid)).unwrap();
        f.lock().unwrap();
        f
    }

    #[test]
    fn taking_the_lock_removes_locks_editors_left_behind_a_minute_ago_or_more() {
        let cache = std::env::temp_dir().join(format!("treelight-stale-{}", std::process::id()));
        std::fs::remove_dir_all(&cache).ok();
        std::fs::create_dir_all(&cache).unwrap();
        let released = |pid: u32, age: Duration| {
            let path = lock_path(&cache, pid);
            let f = std::fs::File::create(&path).unwrap();
            f.set_modified(SystemTime::now() - age).unwrap();
            path
        };
        let gone = released(4_000_011, Duration::from_secs(3600));
        let starting = released(4_000_012, Duration::from_secs(1));
        let held = hold_lock(&cache, 4_000_013);
        let f = std::fs::File::options()
            .write(true)
            .open(lock_path(&cache, 4_000_013))
            .unwrap();
        f.set_modified(SystemTime::now() - Duration::from_secs(3600))
            .unwrap();
        let own = EditorLock::take(&cache).unwrap();
        assert!(!gone.exists(), "a lock released long ago is removed");
        assert!(starting.exists(), "a young one may be an editor starting");
        assert!(editor_running(&cache, 4_000_013), "a held lock stays");
        assert!(
            editor_running(&cache, std::process::id()),
            "and this editor's own"
        );
        drop((own, held));
        std::fs::remove_dir_all(&cache).ok();
    }

    #[test]
    fn only_copies_of_editors_no_longer_running_are_offered_and_old_ones_removed() {
        let cache = std::env::temp_dir().join(format!("treelight-locks-{}", std::process::id()));
        std::fs::remove_dir_all(&cache).ok();
        std::fs::create_dir_all(&cache).unwrap();
        let minute = Duration::from_secs(60);
        // Editor 4000001 is running (its lock held) and has the newest copy; 4000002 died.
        let running = unsaved_copy(&cache, 4_000_001, minute);
        let dead = unsaved_copy(&cache, 4_000_002, 2 * minute);
        let lock = hold_lock(&cache, 4_000_001);
        assert!(editor_running(&cache, 4_000_001));
        assert!(!editor_running(&cache, 4_000_002));
        assert_eq!(recovery_to_offer_in(None, Some(&cache)), Some(dead.clone()));
        // Once the running editor is gone too, its newer copy is the one offered.
        drop(lock);
        assert_eq!(
            recovery_to_offer_in(None, Some(&cache)),
            Some(running.clone())
        );
        // A copy older than a week is removed, not offered.
        let ancient = unsaved_copy(&cache, 4_000_003, MAX_AGE + minute);
        std::fs::remove_file(&running).unwrap();
        std::fs::remove_file(&dead).unwrap();
        assert_eq!(recovery_to_offer_in(None, Some(&cache)), None);
        assert!(!ancient.exists());
        // A project's copy written by a running editor is left to it.
        let project = cache.join("house.treelight");
        std::fs::write(&project, "(version: 1)").unwrap();
        let f = std::fs::File::options().write(true).open(&project).unwrap();
        f.set_modified(SystemTime::now() - 2 * minute).unwrap();
        let beside = recovery_beside(&project);
        std::fs::write(&beside, format!("{HEADER}4000004\n(version: 1)")).unwrap();
        let lock = hold_lock(&cache, 4_000_004);
        assert_eq!(recovery_to_offer_in(Some(&project), Some(&cache)), None);
        drop(lock);
        assert_eq!(
            recovery_to_offer_in(Some(&project), Some(&cache)),
            Some(beside)
        );
        std::fs::remove_dir_all(&cache).ok();
    }
}
