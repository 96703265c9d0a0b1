//! Writing a file so that a crash, a full disk or a second writer never leaves it half-written:
//! the bytes go to a temporary file of a name unique to this process and call, beside the target,
//! which is flushed, given the target's permissions and renamed over it; then the folder itself is
//! flushed, so the rename survives a power cut. A target that is a symbolic link has its link's
//! destination written, and the link stays.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Temporary files made by this process so far, for their unique names.
static WRITES: AtomicU64 = AtomicU64::new(0);

/// The file that writing to `path` changes: the destination of a symbolic link (followed through
/// every link, even to a file that does not exist yet), else `path`.
pub fn write_target(path: &Path) -> PathBuf {
    let mut at = path.to_owned();
    // A bounded walk: a loop of links ends as the path it reached.
    for _ in 0..40 {
        match std::fs::symlink_metadata(&at) {
            Ok(m) if m.file_type().is_symlink() => match std::fs::read_link(&at) {
                Ok(to) => {
                    at = match at.parent() {
                        Some(dir) if to.is_relative() => dir.join(to),
                        _ => to,
                    }
                }
                Err(_) => break,
            },
            _ => break,
        }
    }
    at
}

/// Writes `bytes` to `path` atomically (see the module's description).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomically_flushing(path, bytes, sync_folder)
}

/// [`write_atomically`], flushing the folder with `flush`.
fn write_atomically_flushing(
    path: &Path,
    bytes: &[u8],
    flush: impl FnOnce(&Path) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let target = write_target(path);
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    };
    let name = target
        .file_name()
        .map_or("file".into(), |n| n.to_string_lossy().into_owned());
    let tmp = dir.join(format!(
        ".{name}.{}-{}.saving",
        std::process::id(),
        WRITES.fetch_add(1, Ordering::Relaxed)
    ));
    let written = (|| {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        f.write_all(bytes)?;
        // The file keeps the mode it had (a shared project stays group-writable).
        if let Ok(old) = std::fs::metadata(&target) {
            f.set_permissions(old.permissions())?;
        }
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, &target)
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    // The file is replaced; a folder that refuses to be flushed (some network and FUSE file
    // systems do) does not make the save a failure.
    if let Err(e) = flush(&dir) {
        bevy::log::warn!("{}: the folder could not be flushed: {e}", dir.display());
    }
    Ok(())
}

/// Flushes a folder's entries (a rename into it) to the disk.
pub fn sync_folder(dir: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        std::fs::File::open(dir)?.sync_all()
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(tag: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("treelight-atomic-{tag}-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_write_replaces_the_file_and_leaves_no_temporary_behind() {
        let dir = folder("replace");
        let path = dir.join("a.treelight");
        write_atomically(&path, b"one").unwrap();
        write_atomically(&path, b"two").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().collect();
        assert_eq!(names.len(), 1, "{names:?}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[cfg(unix)]
    #[test]
    fn a_link_has_its_destination_written_and_the_mode_is_kept() {
        use std::os::unix::fs::PermissionsExt;
        let dir = folder("link");
        let real = dir.join("real.treelight");
        std::fs::write(&real, b"old").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o664)).unwrap();
        let link = dir.join("link.treelight");
        std::os::unix::fs::symlink("real.treelight", &link).unwrap();
        write_atomically(&link, b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink(),
            "the link stays a link"
        );
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        let mode = std::fs::metadata(&real).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o664);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_whole() {
        let dir = folder("fail");
        let path = dir.join("a.treelight");
        write_atomically(&path, b"kept").unwrap();
        // A target that is a folder cannot be replaced by a file.
        let blocked = dir.join("blocked");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("inside"), b"x").unwrap();
        assert!(write_atomically(&blocked, b"new").is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"kept");
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().ends_with(".saving"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_folder_that_refuses_to_be_flushed_does_not_fail_a_write_that_replaced_the_file() {
        let dir = folder("nofsync");
        let path = dir.join("a.treelight");
        let refuse = |_: &Path| Err(std::io::Error::from_raw_os_error(22));
        write_atomically_flushing(&path, b"saved", refuse).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"saved");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn temporary_names_are_unique_per_call() {
        let dir = folder("unique");
        let path = dir.join("a.treelight");
        std::thread::scope(|s| {
            for k in 0..8 {
                let path = &path;
                s.spawn(move || write_atomically(path, format!("{k}").as_bytes()).unwrap());
            }
        });
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.parse::<u32>().unwrap() < 8);
        std::fs::remove_dir_all(&dir).ok();
    }
}
