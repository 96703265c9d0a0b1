//! The file sandbox the readers share: what a scene file may reference (embedded data, or regular
//! files beside it), and how much of a file is read, so that opening a file never reads anything
//! outside what the user opened, never blocks on a pipe and never reads a device without end.

use crate::types::budget::Budget;
use crate::types::error::ImportError;
use base64::Engine;
use std::fs::File;
use std::io::Read;
use std::path::{Component, Path};

/// Opens `file` for reading if it is a regular file (symlinks followed), with its length. A
/// directory, device, pipe or socket is refused before it is opened (opening a pipe would block);
/// the opened handle is checked again, so a file swapped in between is refused too. `shown` is the
/// file errors name (the opened scene), `what` how they call `file`.
pub(crate) fn open_regular(
    file: &Path,
    shown: &Path,
    what: &str,
) -> Result<(File, u64), ImportError> {
    let cannot = |e: std::io::Error| {
        let about = if file == shown {
            String::new()
        } else {
            format!("{what} '{}': ", file.display())
        };
        ImportError::new(shown, format!("cannot read {about}{e}"))
    };
    let not_regular = |kind: &str| {
        let subject = if file == shown {
            "it".to_owned()
        } else {
            format!("{what} '{}'", file.display())
        };
        ImportError::new(
            shown,
            format!("{subject} is {kind}, not a regular file; only regular files are read"),
        )
    };
    let meta = std::fs::metadata(file).map_err(cannot)?;
    if !meta.is_file() {
        return Err(not_regular(file_kind(&meta)));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // A pipe put in its place after the check must not block the open.
        options.custom_flags(libc::O_NONBLOCK);
    }
    let handle = options.open(file).map_err(cannot)?;
    let meta = handle.metadata().map_err(cannot)?;
    if !meta.is_file() {
        return Err(not_regular(file_kind(&meta)));
    }
    Ok((handle, meta.len()))
}

/// What a file that is not a regular one is, for a message: a device, a pipe, a socket, a link
/// (when `meta` is the link's own), a folder (`meta` from `metadata` or `symlink_metadata`).
pub fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
        if t.is_fifo() {
            return "a pipe";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if meta.file_type().is_symlink() {
        "a link"
    } else if meta.is_dir() {
        "a folder"
    } else if meta.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// Reads at most `limit` bytes of an opened file, charging them to `budget` first.
pub(crate) fn read_at_most(
    mut handle: File,
    len: u64,
    limit: u64,
    shown: &Path,
    what: &str,
    budget: &mut Budget,
) -> Result<Vec<u8>, ImportError> {
    let want = len.min(limit);
    budget.charge(want, || format!("reading {what}"))?;
    let mut out = Vec::with_capacity(want as usize);
    (&mut handle)
        .take(want)
        .read_to_end(&mut out)
        .map_err(|e| ImportError::new(shown, format!("cannot read {what}: {e}")))?;
    Ok(out)
}

/// Reads the whole of the opened scene file, which must be a regular file.
pub(crate) fn read_scene_file(path: &Path, budget: &mut Budget) -> Result<Vec<u8>, ImportError> {
    let (handle, len) = open_regular(path, path, "file")?;
    read_at_most(handle, len, len, path, "the file", budget)
}

/// Resolves a buffer or image URI: a `data:` URI, or a relative path to a regular file beside the
/// opened one (no absolute paths, no `..`, no other schemes, no link that leads out of the folder),
/// so that nothing outside what the user opened is read. At most `limit` bytes are read (a buffer's
/// declared length). `what` names the referrer in errors ("buffer", "image").
pub(crate) fn read_uri(
    path: &Path,
    dir: &Path,
    uri: &str,
    what: &str,
    limit: u64,
    budget: &mut Budget,
) -> Result<Vec<u8>, ImportError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
            ImportError::new(path, format!("a data URI {what} is not base64-encoded"))
        })?;
        let engine = base64::engine::general_purpose::STANDARD;
        budget.charge(base64::decoded_len_estimate(payload.len()) as u64, || {
            format!("a data URI {what}")
        })?;
        return engine.decode(payload).map_err(|e| {
            ImportError::new(path, format!("a data URI {what} is not valid base64: {e}"))
        });
    }
    if uri.contains(':') {
        return Err(ImportError::new(
            path,
            format!("{what} URI '{uri}' is not a relative file path"),
        ));
    }
    let decoded = percent_encoding::percent_decode_str(uri)
        .decode_utf8_lossy()
        .into_owned();
    let rel = Path::new(&decoded);
    if rel
        .components()
        .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(ImportError::new(
            path,
            format!("{what} URI '{uri}' points outside the file's folder"),
        ));
    }
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let full = dir.join(rel);
    // A link beside the file may lead anywhere: what it resolves to must stay in the folder too.
    if let (Ok(real), Ok(folder)) = (full.canonicalize(), dir.canonicalize())
        && !real.starts_with(&folder)
    {
        return Err(ImportError::new(
            path,
            format!(
                "{what} '{}' is a link that points outside the file's folder (to '{}')",
                full.display(),
                real.display()
            ),
        ));
    }
    let (handle, len) = open_regular(&full, path, what)?;
    read_at_most(
        handle,
        len,
        limit,
        path,
        &format!("{what} '{}'", full.display()),
        budget,
    )
}
