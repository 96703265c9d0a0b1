//! The one way the editor reads and writes the files it names itself (settings, locks, crash
//! reports, recovery copies, kernel records, default render names): a read checks the type before
//! and after opening, never blocks on a pipe or device and stops at a bound; a write never
//! follows a link, and one that must not replace anything never does, even against a file made
//! meanwhile. Files the user names go through [`crate::files::atomic_file`] instead.

use std::fs::{File, Metadata, OpenOptions};
use std::io::{Error, ErrorKind, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Temporary files made by this process so far, for their unique names.
static TEMPORARIES: AtomicU64 = AtomicU64::new(0);

pub use treelight_import::file_kind;

fn not_regular(meta: &Metadata) -> Error {
    Error::new(
        ErrorKind::InvalidInput,
        format!(
            "it is {}, not a regular file; only regular files are read",
            file_kind(meta)
        ),
    )
}

/// Opens `path` for reading when it is a regular file (a link to one is followed), with its
/// length. A folder, device, pipe or socket is refused before it is opened, and the opened
/// handle is checked again, so one swapped in meanwhile is refused too; the open never blocks.
pub fn open_regular(path: &Path) -> std::io::Result<(File, u64)> {
    open_checked(path, true)
}

/// [`open_regular`] refusing a link too: for files only the editor writes (recovery copies,
/// crash reports), where a link is none of its own.
pub fn open_own(path: &Path) -> std::io::Result<(File, u64)> {
    open_checked(path, false)
}

fn open_checked(path: &Path, follow: bool) -> std::io::Result<(File, u64)> {
    let meta = if follow {
        std::fs::metadata(path)?
    } else {
        std::fs::symlink_metadata(path)?
    };
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        let no_follow = if follow { 0 } else { libc::O_NOFOLLOW };
        options.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY | no_follow);
    }
    let file = options.open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    Ok((file, meta.len()))
}

/// Reads `path` whole if it is a regular file of at most `limit` bytes ([`open_regular`]); a
/// larger one is refused without reading more than `limit + 1` bytes, whatever it claims.
pub fn read_bounded(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    read_from(open_regular(path)?, limit)
}

/// [`read_bounded`] of a file only the editor writes: a link is refused ([`open_own`]).
pub fn read_own_text(path: &Path, limit: u64) -> std::io::Result<String> {
    String::from_utf8(read_from(open_own(path)?, limit)?)
        .map_err(|_| Error::new(ErrorKind::InvalidData, "it is not UTF-8 text"))
}

fn read_from((file, len): (File, u64), limit: u64) -> std::io::Result<Vec<u8>> {
    let too_large = || {
        Error::new(
            ErrorKind::FileTooLarge,
            format!("it is larger than {limit} bytes, more than such a file can be"),
        )
    };
    if len > limit {
        return Err(too_large());
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large());
    }
    Ok(bytes)
}

/// [`read_bounded`] as UTF-8 text.
pub fn read_text_bounded(path: &Path, limit: u64) -> std::io::Result<String> {
    String::from_utf8(read_bounded(path, limit)?)
        .map_err(|_| Error::new(ErrorKind::InvalidData, "it is not UTF-8 text"))
}

/// Refuses `path` as a place to write the editor's own file unless it is absent or a regular
/// file: a link (even a dangling one) or anything else is left alone.
pub fn check_writable_place(path: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => Err(Error::new(
            ErrorKind::InvalidInput,
            "it is a link; the editor does not write its own files through links",
        )),
        Ok(m) if !m.is_file() => Err(Error::new(
            ErrorKind::InvalidInput,
            format!("it is {}, not a regular file", file_kind(&m)),
        )),
        Ok(_) => Ok(()),
        Err(e) if e.kind() == ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// A new temporary file beside `path`, made without following links (it cannot exist yet).
fn temporary_beside(path: &Path) -> std::io::Result<(PathBuf, File)> {
    let dir = folder_of(path);
    let name = path
        .file_name()
        .map_or("file".into(), |n| n.to_string_lossy().into_owned());
    let tmp = dir.join(format!(
        ".{name}.{}-{}.saving",
        std::process::id(),
        TEMPORARIES.fetch_add(1, Ordering::Relaxed)
    ));
    let file = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
    Ok((tmp, file))
}

/// The folder `path` is in (`.` for a bare name).
pub fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    }
}

/// Writes `bytes` to a new temporary file beside `path`, flushed, and hands it to `place`; the
/// temporary is removed if anything fails.
fn through_temporary(
    path: &Path,
    bytes: &[u8],
    place: impl FnOnce(&Path) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let (tmp, mut file) = temporary_beside(path)?;
    let written = (|| {
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        place(&tmp)
    })();
    let _ = std::fs::remove_file(&tmp);
    written?;
    // The rename is done: a folder that cannot be flushed (some network and FUSE file systems
    // refuse) leaves the file written all the same.
    let _ = crate::files::atomic_file::sync_folder(&folder_of(path));
    Ok(())
}

/// Writes the editor's own file at `path` atomically (a temporary renamed over it), replacing a
/// regular file there but never following or replacing a link, nor anything that is not a
/// regular file ([`check_writable_place`]). A link planted between the check and the rename is
/// replaced by the file, never written through.
pub fn write_own(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    check_writable_place(path)?;
    through_temporary(path, bytes, |tmp| {
        // The check again, as late as it can be: only the rename itself is later.
        check_writable_place(path)?;
        std::fs::rename(tmp, path)
    })
}

/// Writes a new file at `path` (atomically: whole or not at all), refusing when anything is
/// there already, a link or a file made by someone else meanwhile included: the last step
/// links the finished file in under its name, which fails if the name is taken.
pub fn write_new(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if let Ok(m) = std::fs::symlink_metadata(path) {
        return Err(exists(&m));
    }
    through_temporary(path, bytes, |tmp| match std::fs::hard_link(tmp, path) {
        Err(e) if e.kind() == ErrorKind::AlreadyExists => {
            Err(std::fs::symlink_metadata(path).map_or(e, |m| exists(&m)))
        }
        other => other,
    })
}

fn exists(meta: &Metadata) -> Error {
    let what = if meta.file_type().is_symlink() {
        "a link is there"
    } else {
        "the file exists"
    };
    Error::new(ErrorKind::AlreadyExists, what)
}

/// Opens (making it if need be) the editor's own lock or record file at `path` for writing,
/// without following a link, blocking on a pipe, or taking anything but a regular file.
pub fn open_own_for_writing(path: &Path) -> std::io::Result<File> {
    let mut options = OpenOptions::new();
    options.write(true).create(true).truncate(false);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    let file = options.open(path).map_err(|e| {
        if e.raw_os_error() == Some(libc::ELOOP) {
            Error::new(ErrorKind::InvalidInput, "it is a link")
        } else {
            e
        }
    })?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("it is {}, not a regular file", file_kind(&meta)),
        ));
    }
    Ok(file)
}

/// Moves the editor's own file at `path`, which it cannot use, out of the way as `NAME.bad`
/// (replacing an earlier one), so the next start does not meet it again; the entry itself is
/// moved, whatever it is, and nothing it points to is touched. Returns the new name.
pub fn set_aside(path: &Path) -> std::io::Result<PathBuf> {
    let mut name = path.file_name().unwrap_or_default().to_owned();
    name.push(".bad");
    let to = path.with_file_name(name);
    if let Ok(m) = std::fs::symlink_metadata(&to)
        && m.is_dir()
    {
        return Err(Error::new(
            ErrorKind::AlreadyExists,
            format!("{} is a folder", to.display()),
        ));
    }
    std::fs::rename(path, &to)?;
    Ok(to)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("treelight-own-{tag}-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[cfg(unix)]
    fn fifo(path: &Path) {
        let c = std::ffi::CString::new(path.as_os_str().as_encoded_bytes()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    }

    #[cfg(unix)]
    #[test]
    fn reads_refuse_pipes_devices_and_folders_at_once_and_stop_at_the_bound() {
        let dir = folder("read");
        let pipe = dir.join("settings.ron");
        fifo(&pipe);
        let started = std::time::Instant::now();
        let e = read_bounded(&pipe, 1 << 20).unwrap_err();
        assert!(e.to_string().contains("a pipe"), "{e}");
        let zero = dir.join("zero.ron");
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        let e = read_bounded(&zero, 1 << 20).unwrap_err();
        assert!(e.to_string().contains("a device"), "{e}");
        let e = read_bounded(&dir, 1 << 20).unwrap_err();
        assert!(e.to_string().contains("a folder"), "{e}");
        assert!(started.elapsed() < std::time::Duration::from_secs(2));
        let big = dir.join("big.ron");
        std::fs::write(&big, vec![b'x'; 5000]).unwrap();
        assert_eq!(
            read_bounded(&big, 4999).unwrap_err().kind(),
            ErrorKind::FileTooLarge
        );
        assert_eq!(read_bounded(&big, 5000).unwrap().len(), 5000);
        assert_eq!(
            read_bounded(&dir.join("none"), 10).unwrap_err().kind(),
            ErrorKind::NotFound
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[cfg(unix)]
    #[test]
    fn own_writes_never_follow_links_and_new_writes_never_replace() {
        let dir = folder("write");
        let victim = dir.join("victim.txt");
        std::fs::write(&victim, b"the user's").unwrap();
        let planted = dir.join(".house.recovery.treelight");
        std::os::unix::fs::symlink(&victim, &planted).unwrap();
        let e = write_own(&planted, b"copy").unwrap_err();
        assert!(e.to_string().contains("link"), "{e}");
        assert_eq!(std::fs::read(&victim).unwrap(), b"the user's");
        // A dangling link is not followed either, by either write.
        let dangling = dir.join("x.png");
        let target = dir.join("made-elsewhere.png");
        std::os::unix::fs::symlink(&target, &dangling).unwrap();
        assert!(write_own(&dangling, b"png").is_err());
        assert!(write_new(&dangling, b"png").is_err());
        assert!(!target.exists());
        // A new file is written once, then refused.
        let new = dir.join("render.png");
        write_new(&new, b"one").unwrap();
        assert_eq!(
            write_new(&new, b"two").unwrap_err().kind(),
            ErrorKind::AlreadyExists
        );
        assert_eq!(std::fs::read(&new).unwrap(), b"one");
        // An own file is replaced in place.
        write_own(&new, b"three").unwrap();
        assert_eq!(std::fs::read(&new).unwrap(), b"three");
        let pipe = dir.join("pipe");
        fifo(&pipe);
        assert!(write_own(&pipe, b"x").is_err());
        assert!(open_own_for_writing(&pipe).is_err());
        assert!(open_own_for_writing(&planted).is_err());
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().ends_with(".saving"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[cfg(unix)]
    #[test]
    fn setting_aside_moves_the_entry_not_what_it_points_to() {
        let dir = folder("aside");
        let victim = dir.join("victim");
        std::fs::write(&victim, b"kept").unwrap();
        let settings = dir.join("settings.ron");
        std::os::unix::fs::symlink(&victim, &settings).unwrap();
        let moved = set_aside(&settings).unwrap();
        assert_eq!(moved, dir.join("settings.ron.bad"));
        assert!(!settings.exists());
        assert_eq!(std::fs::read(&victim).unwrap(), b"kept");
        let pipe = dir.join("settings.ron");
        fifo(&pipe);
        set_aside(&pipe).unwrap();
        assert!(std::fs::symlink_metadata(&pipe).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
