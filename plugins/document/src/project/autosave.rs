//! Autosave: while there are unsaved changes, a recovery copy of the project is written every
//! interval of real time (30 s; `TREELIGHT_AUTOSAVE_SECS` changes it) on a thread of its own,
//! beside the project or, for a scene never saved, in the cache directory ([`super::recovery`]
//! names them). A write that fails is shown in the window and tried again. Copies are written
//! without following links, and never over a copy offered to the user or left for later. Which
//! copies to offer is decided once the scene is known: at start from the command line, later
//! whenever a project opens; a save, and discarding the changes, remove this scene's copies (its
//! own and the one it was recovered from).

use crate::edit::history::EditHistory;
use crate::project::capture::capture_project;
use crate::project::editor_lock::{EditorLock, editors_with};
use crate::project::format::{ProjectState, checked_project_text};
use crate::project::recovery::{
    HEADER, RecoveryCopy, copies_for_project, owned_by_running_editor, recovery_beside,
    recovery_beside_for, unsaved_copies, unsaved_recovery_in,
};
use crate::scene::notice::Notices;
use crate::scene::outbox::DocumentEvent;
use bevy::prelude::*;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How soon a failed write is tried again (or the interval, if shorter).
const RETRY: Duration = Duration::from_secs(5);

/// Where unsaved scenes' recovery copies and the editors' locks go ([`crate::files::folders::cache_dir`]).
pub fn cache_dir() -> Option<PathBuf> {
    crate::files::folders::cache_dir()
}

/// A recovery copy being written: where, and the thread's answer.
struct Writer {
    target: PathBuf,
    thread: std::thread::JoinHandle<Result<(), String>>,
}

/// Which recovery copies to look for.
#[derive(Clone, Debug, PartialEq)]
enum LookFor {
    /// A project's own.
    Project(PathBuf),
    /// Those of unsaved scenes.
    UnsavedScenes,
}

/// Autosave's clock, the copies this scene owns, and the copies offered to the user.
#[derive(Resource)]
pub struct Autosave {
    /// Time between recovery copies.
    pub interval: Duration,
    /// When the unsaved changes were last copied (or became unsaved), in real time.
    last: Option<Instant>,
    /// Recovery copies offered to the user, newest first, until answered.
    pub offer: Vec<RecoveryCopy>,
    /// What to look for next, once the scene is known.
    look_for: Option<LookFor>,
    /// Copies offered this run already: not offered again.
    offered: HashSet<PathBuf>,
    /// Copies the user left for a later start: never written over.
    kept: Vec<PathBuf>,
    /// The copy last written whole, removed when the scene is saved.
    written: Option<PathBuf>,
    /// Copies this scene was recovered from, removed with its own once saved or discarded.
    adopted: Vec<PathBuf>,
    writer: Option<Writer>,
    /// Why the last write failed, while writes fail.
    pub failing: Option<String>,
    /// The cache directory (locks, unsaved scenes' copies).
    cache: Option<PathBuf>,
    /// This editor's lock, held while it runs.
    lock: Option<EditorLock>,
    /// The project last announced in the lock.
    announced: Option<Option<PathBuf>>,
    /// Copies written under this editor's own name because the usual one was refused, each
    /// said once.
    warned: HashSet<PathBuf>,
}

impl Autosave {
    /// When the next recovery copy is due, while there are unsaved changes: an editor that rests
    /// between frames wakes then.
    pub fn next_due(&self) -> Option<Instant> {
        self.last.map(|last| last + self.interval)
    }

    /// Whether a recovery copy is being written (on its thread) or removed.
    pub fn is_writing(&self) -> bool {
        self.writer.is_some()
    }

    /// Takes `path` as a copy of this scene's unsaved work, so a save or a discard removes it.
    pub fn adopt(&mut self, path: PathBuf) {
        self.offered.insert(path.clone());
        if !self.adopted.contains(&path) {
            self.adopted.push(path);
        }
    }

    /// Waits for a write under way, then removes the copies of this scene: its changes were
    /// saved or discarded, so no copy may be left to be offered.
    pub fn remove_copy(&mut self) {
        if let Some(w) = self.writer.take()
            && w.thread.join().ok().and_then(Result::ok).is_some()
        {
            self.written = Some(w.target);
        }
        for old in self
            .written
            .take()
            .into_iter()
            .chain(self.adopted.drain(..))
        {
            let _ = std::fs::remove_file(old);
        }
        self.last = None;
    }

    /// Looks for the recovery copies of the scene about to open at start: a project's own, or
    /// for any other scene (the default one, a scene file) those of unsaved scenes.
    pub fn look_for_start(&mut self, scene: Option<&Path>) {
        self.look_for = Some(match scene {
            Some(p) if crate::files::file_kind::is_project_file(p) => {
                LookFor::Project(p.to_owned())
            }
            _ => LookFor::UnsavedScenes,
        });
    }

    /// The user opened `copy` or deleted it: it is no longer offered.
    pub fn answered(&mut self, copy: &Path) {
        self.offer.retain(|c| c.path != copy);
    }

    /// The user left the copies offered for a later start: they stay on disk, untouched.
    pub fn keep_for_later(&mut self) {
        self.kept.extend(self.offer.drain(..).map(|c| c.path));
    }

    /// Where this editor writes the recovery copy of the scene saved at `project`: the usual
    /// name unless a copy there is another running editor's, offered or left for later, or
    /// the name holds something other than a regular file (a link planted there is never
    /// written through: the copy goes under this editor's own name, and `Some` reason is given).
    fn target(&self, project: Option<&Path>) -> Option<(PathBuf, Option<String>)> {
        let pid = std::process::id();
        let Some(p) = project else {
            return self
                .cache
                .as_deref()
                .map(|c| (unsaved_recovery_in(c, pid), None));
        };
        let usual = recovery_beside(p);
        let taken = self.kept.contains(&usual)
            || self.offer.iter().any(|c| c.path == usual)
            || (self.written.as_ref() != Some(&usual)
                && owned_by_running_editor(&usual, self.cache.as_deref()));
        let refused = crate::files::own_file::check_writable_place(&usual)
            .err()
            .map(|e| format!("{}: {e}", usual.display()));
        Some(if taken || refused.is_some() {
            (recovery_beside_for(p, pid), refused)
        } else {
            (usual, None)
        })
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
            offer: Vec::new(),
            look_for: None,
            offered: HashSet::new(),
            kept: Vec::new(),
            written: None,
            adopted: Vec::new(),
            writer: None,
            failing: None,
            cache: cache_dir(),
            lock: None,
            announced: None,
            warned: HashSet::new(),
        }
    }
}

impl Autosave {
    /// The editor's autosave: [`Autosave::default`], holding this editor's lock in the cache
    /// directory while it runs, so other editors leave its copies alone, and looking for unsaved
    /// scenes' copies unless told of a project to open ([`Autosave::look_for_start`]).
    pub fn for_editor() -> Self {
        let cache = cache_dir();
        Self {
            lock: cache.as_deref().and_then(take_lock),
            look_for: Some(LookFor::UnsavedScenes),
            ..Self::default()
        }
    }

    /// [`Autosave::default`] with its cache directory (for tests).
    pub fn with_cache(cache: PathBuf) -> Self {
        Self {
            cache: Some(cache),
            ..Self::default()
        }
    }
}

/// This editor's lock in `dir`; a lock file it cannot use (a pipe, a link: nothing an editor
/// made) is set aside once and the lock taken again.
fn take_lock(dir: &Path) -> Option<EditorLock> {
    match EditorLock::take(dir) {
        Ok(lock) => Some(lock),
        Err(e) => {
            let path = crate::project::editor_lock::lock_path(dir, std::process::id());
            warn!("{e}");
            crate::files::own_file::set_aside(&path).ok()?;
            EditorLock::take(dir).ok()
        }
    }
}

/// Takes the answer of a finished write: counted as written only when it was.
fn collect_write(world: &mut World, now: Instant) {
    let mut auto = world.resource_mut::<Autosave>();
    if !auto.writer.as_ref().is_some_and(|w| w.thread.is_finished()) {
        return;
    }
    let Some(w) = auto.writer.take() else {
        return;
    };
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
}

/// Writes a recovery copy every interval while there are unsaved changes; removes it once saved.
pub fn autosave(world: &mut World) {
    let now = Instant::now();
    let dirty = world.resource::<EditHistory>().is_dirty();
    let project = world.resource::<ProjectState>().path.clone();
    let mut auto = world.resource_mut::<Autosave>();
    if auto.announced.as_ref() != Some(&project) {
        if let Some(lock) = auto.lock.as_mut() {
            lock.announce(project.as_deref());
        }
        auto.announced = Some(project.clone());
    }
    if !dirty {
        // The save that made the scene clean may have raced a write: wait for it, then remove.
        if auto.writer.is_some() || auto.written.is_some() || !auto.adopted.is_empty() {
            auto.remove_copy();
        }
        auto.last = None;
        return;
    }
    collect_write(world, now);
    let mut auto = world.resource_mut::<Autosave>();
    let last = *auto.last.get_or_insert(now);
    if now.duration_since(last) < auto.interval || auto.writer.is_some() {
        return;
    }
    auto.last = Some(now);
    let Some((target, refused)) = auto.target(project.as_deref()) else {
        return;
    };
    if let Some(why) = refused
        && auto.warned.insert(target.clone())
    {
        world.resource_mut::<Notices>().warn(format!(
            "autosave: {why}; the recovery copy is written as {} instead",
            target.display()
        ));
    }
    let mut auto = world.resource_mut::<Autosave>();
    // A copy of this scene written under another name (the usual one taken since) is stale.
    if let Some(old) = auto.written.take_if(|old| *old != target) {
        let _ = std::fs::remove_file(old);
    }
    // Capturing reads the world (no geometry: quick); the disk write happens off this thread.
    let at = project.clone().unwrap_or_else(|| target.clone());
    let (file, _) = capture_project(world, &at);
    let path = target.clone();
    let thread = std::thread::Builder::new()
        .name("treelight-autosave".into())
        .spawn(move || {
            let body = checked_project_text(&path, &file).map_err(|e| e.to_string())?;
            let text = format!("{HEADER}{}\n{body}", std::process::id());
            if let Some(dir) = path.parent() {
                std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            }
            crate::files::own_file::write_own(&path, text.as_bytes())
                .map_err(|e| format!("{}: {e}", path.display()))
        });
    let mut auto = world.resource_mut::<Autosave>();
    match thread {
        Ok(thread) => auto.writer = Some(Writer { target, thread }),
        Err(e) => auto.failing = Some(e.to_string()),
    }
}

/// Finds the recovery copies to offer once the scene they would belong to is known (at start,
/// and whenever a project opens), and tells the user when another editor has the project open.
pub fn find_recovery(
    mut auto: ResMut<Autosave>,
    mut events: MessageReader<DocumentEvent>,
    mut notices: ResMut<Notices>,
) {
    for event in events.read() {
        if let DocumentEvent::Opened(p) = event {
            auto.look_for = Some(LookFor::Project(p.clone()));
        }
    }
    let Some(look_for) = auto.look_for.take() else {
        return;
    };
    let cache = auto.cache.clone();
    let found = match &look_for {
        LookFor::Project(p) => {
            let others = cache
                .as_deref()
                .map_or_else(Vec::new, |c| editors_with(c, p));
            if !others.is_empty() {
                notices.warn(format!(
                    "{} is open in another editor too (process {}): a save there and one here \
                     overwrite each other; saving here asks first once the file has changed",
                    p.display(),
                    others
                        .iter()
                        .map(u32::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            copies_for_project(p, cache.as_deref())
        }
        LookFor::UnsavedScenes => cache.as_deref().map_or_else(Vec::new, unsaved_copies),
    };
    for copy in found {
        if auto.offered.insert(copy.path.clone()) {
            auto.offer.push(copy);
        }
    }
}

/// Recovery copies while editing, and finding the ones to offer (the offer is the shell's:
/// [`Autosave::offer`]).
pub struct AutosavePlugin;

impl Plugin for AutosavePlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(Autosave::for_editor())
            .add_systems(Update, (autosave, find_recovery));
    }
}
