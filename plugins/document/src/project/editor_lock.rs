//! Which editors are running: each holds a lock in the cache directory (`editor-PID.lock`, an
//! `flock` the system releases when the process dies), which also names the project it has open,
//! so a second editor on one project is told, and files an editor leaves behind (recovery copies,
//! crash reports) are left alone while it runs.

use crate::files::own_file::{open_own_for_writing, read_text_bounded};
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// How old a released lock must be before it is removed: a younger one may belong to an editor
/// that made the file and has not locked it yet.
const LOCK_GRACE: Duration = Duration::from_secs(60);

/// The most a lock's text (a project's path) may take.
const MAX_LOCK_BYTES: u64 = 16 << 10;

/// Where editor process `pid` keeps its lock in `dir`.
pub fn lock_path(dir: &Path, pid: u32) -> PathBuf {
    dir.join(format!("editor-{pid}.lock"))
}

/// This editor's lock in the cache directory, held while it runs (dropping it, or the process
/// dying, releases it).
pub struct EditorLock {
    file: std::fs::File,
}

impl EditorLock {
    /// Takes this process's lock in `dir` (made if need be), and removes the locks that editors
    /// no longer running left behind (a missing lock says the same as a released one). A lock
    /// file that is a link, a pipe or anything but a regular file is refused, never followed.
    pub fn take(dir: &Path) -> std::io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let path = lock_path(dir, std::process::id());
        let file = open_own_for_writing(&path)
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
        file.lock()?;
        for (_, stale) in left_by_gone_editors(dir, "editor-", ".lock") {
            let young = std::fs::symlink_metadata(&stale)
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| t.elapsed().ok())
                .is_none_or(|age| age < LOCK_GRACE);
            if !young {
                let _ = std::fs::remove_file(stale);
            }
        }
        Ok(Self { file })
    }

    /// Records which project this editor has open (none for a scene never saved), for the
    /// other editors to see.
    pub fn announce(&mut self, project: Option<&Path>) {
        let text = project.map_or_else(String::new, |p| absolute(p).display().to_string());
        let _ = self.file.set_len(0);
        let _ = self.file.rewind();
        let _ = self.file.write_all(text.as_bytes());
    }
}

fn absolute(p: &Path) -> PathBuf {
    std::fs::canonicalize(p)
        .or_else(|_| std::path::absolute(p))
        .unwrap_or_else(|_| p.to_owned())
}

/// Whether editor process `pid` is running: whether its lock in `dir` is held. A lock that is not
/// a regular file is no editor's.
pub fn editor_running(dir: &Path, pid: u32) -> bool {
    let path = lock_path(dir, pid);
    if !std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file()) {
        return false;
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    let Ok(file) = options.open(path) else {
        return false;
    };
    file.metadata().is_ok_and(|m| m.is_file())
        && matches!(file.try_lock(), Err(std::fs::TryLockError::WouldBlock))
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
            let pid = pid_in(&p, prefix, suffix)?;
            (pid != std::process::id() && !editor_running(dir, pid)).then_some((pid, p))
        })
        .collect()
}

/// The PID in a file name of the form `PREFIX-PID.SUFFIX` (`PREFIX` ends with its dash).
pub fn pid_in(path: &Path, prefix: &str, suffix: &str) -> Option<u32> {
    path.file_name()?
        .to_str()?
        .strip_prefix(prefix)?
        .strip_suffix(suffix)?
        .parse()
        .ok()
}

/// The other running editors in `dir` that have `project` open.
pub fn editors_with(dir: &Path, project: &Path) -> Vec<u32> {
    let wanted = absolute(project);
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut pids: Vec<u32> = entries
        .flatten()
        .filter_map(|e| pid_in(&e.path(), "editor-", ".lock"))
        .filter(|pid| *pid != std::process::id() && editor_running(dir, *pid))
        .filter(|pid| {
            read_text_bounded(&lock_path(dir, *pid), MAX_LOCK_BYTES)
                .is_ok_and(|text| !text.is_empty() && Path::new(&text) == wanted)
        })
        .collect();
    pids.sort_unstable();
    pids
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::SystemTime;

    fn folder(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("treelight-lock-{tag}-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Holds process `pid`'s lock as that editor would while running.
    pub(crate) fn hold_lock(cache: &Path, pid: u32, project: Option<&Path>) -> std::fs::File {
        let mut f = std::fs::File::create(lock_path(cache, pid)).unwrap();
        f.lock().unwrap();
        if let Some(p) = project {
            f.write_all(absolute(p).display().to_string().as_bytes())
                .unwrap();
        }
        f
    }

    #[test]
    fn taking_the_lock_removes_locks_editors_left_behind_a_minute_ago_or_more() {
        let cache = folder("stale");
        let released = |pid: u32, age: Duration| {
            let path = lock_path(&cache, pid);
            let f = std::fs::File::create(&path).unwrap();
            f.set_modified(SystemTime::now() - age).unwrap();
            path
        };
        let gone = released(4_000_011, Duration::from_secs(3600));
        let starting = released(4_000_012, Duration::from_secs(1));
        let held = hold_lock(&cache, 4_000_013, None);
        held.set_modified(SystemTime::now() - Duration::from_secs(3600))
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
    fn a_second_editor_sees_the_first_on_its_project() {
        let cache = folder("with");
        let project = cache.join("house.treelight");
        std::fs::write(&project, "()").unwrap();
        assert!(editors_with(&cache, &project).is_empty());
        let other = hold_lock(&cache, 4_000_021, Some(&project));
        let elsewhere = hold_lock(&cache, 4_000_022, Some(&cache.join("shed.treelight")));
        assert_eq!(editors_with(&cache, &project), vec![4_000_021]);
        drop(other);
        assert!(editors_with(&cache, &project).is_empty(), "it quit");
        // This editor's own announcement is not another editor's.
        let mut own = EditorLock::take(&cache).unwrap();
        own.announce(Some(&project));
        assert!(editors_with(&cache, &project).is_empty());
        drop((own, elsewhere));
        std::fs::remove_dir_all(&cache).ok();
    }

    #[cfg(unix)]
    #[test]
    fn a_lock_that_is_a_pipe_or_a_link_is_refused_without_blocking() {
        let cache = folder("fifo");
        let own = lock_path(&cache, std::process::id());
        let c = std::ffi::CString::new(own.as_os_str().as_encoded_bytes()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let other = lock_path(&cache, 4_000_031);
        let c = std::ffi::CString::new(other.as_os_str().as_encoded_bytes()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let started = std::time::Instant::now();
        assert!(EditorLock::take(&cache).is_err());
        assert!(!editor_running(&cache, 4_000_031));
        std::fs::remove_file(&own).unwrap();
        let victim = cache.join("victim");
        std::os::unix::fs::symlink(&victim, &own).unwrap();
        assert!(EditorLock::take(&cache).is_err());
        assert!(!victim.exists(), "the link was followed");
        assert!(started.elapsed() < Duration::from_secs(2));
        std::fs::remove_dir_all(&cache).ok();
    }
}
