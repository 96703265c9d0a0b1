//! Recovery copies: where they are and whose they are. A project's copy lies beside it as
//! `.NAME.recovery.treelight` (`.NAME.recovery-PID.treelight` when another running editor holds
//! that name); an unsaved scene's lies in the cache directory as `unsaved-PID.recovery.treelight`.
//! Each copy's first line names the editor process that wrote it, so copies of editors still
//! running are never offered. What belongs to which scene follows from the name alone: a copy
//! beside a project is that project's, an unsaved copy is no project's.

use crate::files::own_file::open_own;
use crate::project::editor_lock::{editor_running, left_by_gone_editors, pid_in};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// Copies at least this old are marked as old when offered (never removed unasked).
pub const OLD_AGE: Duration = Duration::from_secs(7 * 24 * 3600);

/// The first line of every recovery copy: which editor process wrote it.
pub const HEADER: &str = "// treelight recovery copy, written by editor process ";

/// A recovery copy found on disk.
#[derive(Clone, Debug, PartialEq)]
pub struct RecoveryCopy {
    /// Its file.
    pub path: PathBuf,
    /// The project it holds unsaved work on (`None` for a scene never saved).
    pub owner: Option<PathBuf>,
    /// When it was written.
    pub modified: SystemTime,
}

impl RecoveryCopy {
    /// Whether it is older than [`OLD_AGE`].
    pub fn is_old(&self) -> bool {
        self.modified.elapsed().is_ok_and(|age| age > OLD_AGE)
    }
}

fn stem_of(project: &Path) -> String {
    let name = project
        .file_name()
        .map_or("project".into(), |n| n.to_string_lossy().into_owned());
    name.strip_suffix(".treelight").unwrap_or(&name).to_owned()
}

/// The recovery copy for the project at `project`.
pub fn recovery_beside(project: &Path) -> PathBuf {
    project.with_file_name(format!(".{}.recovery.treelight", stem_of(project)))
}

/// The recovery copy this editor writes for `project` when another running editor holds the
/// usual name.
pub fn recovery_beside_for(project: &Path, pid: u32) -> PathBuf {
    project.with_file_name(format!(".{}.recovery-{pid}.treelight", stem_of(project)))
}

/// The recovery copy of an unsaved scene of editor process `pid` in the cache directory.
pub fn unsaved_recovery_in(cache: &Path, pid: u32) -> PathBuf {
    cache.join(format!("unsaved-{pid}.recovery.treelight"))
}

/// The project a recovery copy belongs to, from its name: `.NAME.recovery[-PID].treelight`
/// beside it is `NAME.treelight`'s; anything else (an unsaved scene's copy) is no project's.
pub fn owner_of_copy(copy: &Path) -> Option<PathBuf> {
    let name = copy.file_name()?.to_str()?;
    let stem = name.strip_prefix('.')?.strip_suffix(".treelight")?;
    let stem = match stem.strip_suffix(".recovery") {
        Some(s) => s,
        None => {
            let (s, pid) = stem.rsplit_once(".recovery-")?;
            pid.parse::<u32>().ok()?;
            s
        }
    };
    (!stem.is_empty()).then(|| copy.with_file_name(format!("{stem}.treelight")))
}

/// The editor process that wrote the recovery copy at `path`, from its first line (read without
/// blocking, a few bytes at most).
pub fn writer_of(path: &Path) -> Option<u32> {
    let (file, _) = open_own(path).ok()?;
    let mut head = Vec::with_capacity(96);
    file.take(96).read_to_end(&mut head).ok()?;
    let text = std::str::from_utf8(&head).ok()?;
    text.strip_prefix(HEADER)?
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

/// When a regular file (not a link) at `p` was modified.
fn modified(p: &Path) -> Option<SystemTime> {
    std::fs::symlink_metadata(p)
        .ok()
        .filter(|m| m.is_file())
        .and_then(|m| m.modified().ok())
}

/// Whether the copy at `path` belongs to another editor still running.
pub fn owned_by_running_editor(path: &Path, cache: Option<&Path>) -> bool {
    match (cache, writer_of(path)) {
        (Some(dir), Some(pid)) => pid != std::process::id() && editor_running(dir, pid),
        _ => false,
    }
}

/// The copies of `project` to offer: those beside it (regular files, not links) that are newer
/// than it (or it is gone) and whose editor is not running, newest first.
pub fn copies_for_project(project: &Path, cache: Option<&Path>) -> Vec<RecoveryCopy> {
    let saved = modified(project);
    let folder = crate::files::own_file::folder_of(project);
    let Ok(entries) = std::fs::read_dir(&folder) else {
        return Vec::new();
    };
    let wanted = absolute(project);
    let mut found: Vec<RecoveryCopy> = entries
        .flatten()
        .map(|e| folder.join(e.file_name()))
        .filter(|p| owner_of_copy(p).is_some_and(|o| absolute(&o) == wanted))
        .filter_map(|path| {
            let modified = modified(&path)?;
            let newer = saved.is_none_or(|s| modified > s);
            (newer && !owned_by_running_editor(&path, cache)).then(|| RecoveryCopy {
                owner: Some(project.to_owned()),
                path,
                modified,
            })
        })
        .collect();
    found.sort_by_key(|c| std::cmp::Reverse(c.modified));
    found
}

fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_owned())
}

/// The copies of unsaved scenes in `cache` whose editors are gone, newest first.
pub fn unsaved_copies(cache: &Path) -> Vec<RecoveryCopy> {
    let mut found: Vec<RecoveryCopy> =
        left_by_gone_editors(cache, "unsaved-", ".recovery.treelight")
            .into_iter()
            .filter_map(|(_, path)| {
                Some(RecoveryCopy {
                    modified: modified(&path)?,
                    owner: None,
                    path,
                })
            })
            .collect();
    found.sort_by_key(|c| std::cmp::Reverse(c.modified));
    found
}

/// Whether `path` is an unsaved scene's copy (`unsaved-PID.recovery.treelight`).
pub fn is_unsaved_copy(path: &Path) -> bool {
    pid_in(path, "unsaved-", ".recovery.treelight").is_some()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::project::editor_lock::lock_path;

    fn folder(tag: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("treelight-recovery-{tag}-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A copy at `path` as editor process `pid` leaves it, written `age` ago.
    fn copy_at(path: &Path, pid: u32, age: Duration) {
        std::fs::write(path, format!("{HEADER}{pid}\n(version: 1)")).unwrap();
        let f = std::fs::File::options().write(true).open(path).unwrap();
        f.set_modified(SystemTime::now() - age).unwrap();
    }

    fn hold_lock(cache: &Path, pid: u32) -> std::fs::File {
        let f = std::fs::File::create(lock_path(cache, pid)).unwrap();
        f.lock().unwrap();
        f
    }

    #[test]
    fn a_copy_names_its_project() {
        let dir = Path::new("/work");
        let project = dir.join("house.treelight");
        assert_eq!(
            recovery_beside(&project),
            dir.join(".house.recovery.treelight")
        );
        assert_eq!(
            owner_of_copy(&recovery_beside(&project)),
            Some(project.clone())
        );
        assert_eq!(
            owner_of_copy(&recovery_beside_for(&project, 77)),
            Some(project.clone())
        );
        assert_eq!(owner_of_copy(&unsaved_recovery_in(dir, 77)), None);
        assert!(is_unsaved_copy(&unsaved_recovery_in(dir, 77)));
        assert_eq!(owner_of_copy(&dir.join(".recovery.treelight")), None);
        assert_eq!(owner_of_copy(&dir.join(".a.recovery-x.treelight")), None);
    }

    #[test]
    fn a_project_is_offered_its_own_newer_copies_only() {
        let dir = folder("project");
        let minute = Duration::from_secs(60);
        let project = dir.join("house.treelight");
        std::fs::write(&project, "(version: 1)").unwrap();
        let f = std::fs::File::options().write(true).open(&project).unwrap();
        f.set_modified(SystemTime::now() - 10 * minute).unwrap();
        // Older than the project: stale, not offered (and not removed).
        copy_at(&recovery_beside(&project), 4_000_101, 20 * minute);
        // Another project's copy, and an unsaved scene's in the same folder: never this one's.
        copy_at(&dir.join(".shed.recovery.treelight"), 4_000_102, minute);
        copy_at(&unsaved_recovery_in(&dir, 4_000_103), 4_000_103, minute);
        assert!(copies_for_project(&project, Some(&dir)).is_empty());
        assert!(recovery_beside(&project).exists());
        // Newer: offered; a second editor's copy too, newest first.
        copy_at(&recovery_beside(&project), 4_000_101, 2 * minute);
        copy_at(&recovery_beside_for(&project, 4_000_104), 4_000_104, minute);
        let found = copies_for_project(&project, Some(&dir));
        assert_eq!(
            found.iter().map(|c| c.path.clone()).collect::<Vec<_>>(),
            vec![
                recovery_beside_for(&project, 4_000_104),
                recovery_beside(&project)
            ]
        );
        assert!(found.iter().all(|c| c.owner.as_deref() == Some(&*project)));
        // A copy whose editor still runs is left to it.
        let lock = hold_lock(&dir, 4_000_104);
        assert_eq!(copies_for_project(&project, Some(&dir)).len(), 1);
        drop(lock);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn old_unsaved_copies_are_offered_marked_old_not_removed() {
        let cache = folder("unsaved");
        let minute = Duration::from_secs(60);
        let running = unsaved_recovery_in(&cache, 4_000_001);
        copy_at(&running, 4_000_001, minute);
        let dead = unsaved_recovery_in(&cache, 4_000_002);
        copy_at(&dead, 4_000_002, 2 * minute);
        let ancient = unsaved_recovery_in(&cache, 4_000_003);
        copy_at(&ancient, 4_000_003, OLD_AGE + minute);
        let lock = hold_lock(&cache, 4_000_001);
        let found = unsaved_copies(&cache);
        assert_eq!(
            found.iter().map(|c| c.path.clone()).collect::<Vec<_>>(),
            vec![dead.clone(), ancient.clone()]
        );
        assert!(!found[0].is_old() && found[1].is_old());
        assert!(ancient.exists());
        drop(lock);
        assert_eq!(unsaved_copies(&cache)[0].path, running);
        std::fs::remove_dir_all(&cache).ok();
    }

    #[cfg(unix)]
    #[test]
    fn links_and_pipes_named_as_copies_are_not_offered_and_never_block() {
        let dir = folder("links");
        let project = dir.join("house.treelight");
        let victim = dir.join("victim.txt");
        std::fs::write(&victim, format!("{HEADER}1\n")).unwrap();
        std::os::unix::fs::symlink(&victim, recovery_beside(&project)).unwrap();
        let pipe = recovery_beside_for(&project, 5);
        let c = std::ffi::CString::new(pipe.as_os_str().as_encoded_bytes()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        assert!(copies_for_project(&project, Some(&dir)).is_empty());
        assert_eq!(writer_of(&pipe), None);
        std::fs::remove_dir_all(&dir).ok();
    }
}
