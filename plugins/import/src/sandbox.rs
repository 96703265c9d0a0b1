//! The file sandbox the readers share: what a scene file may reference (embedded data, or files beside
//! it), so that opening a file never reads anything outside what the user opened.

use crate::ImportError;
use base64::Engine;
use std::path::{Component, Path};

/// Resolves a buffer or image URI: a `data:` URI, or a relative path to a file beside the opened one
/// (no absolute paths, no `..`, no other schemes), so that nothing outside what the user opened is
/// read. `what` names the referrer in errors ("buffer", "image").
pub(crate) fn read_uri(
    path: &Path,
    dir: &Path,
    uri: &str,
    what: &str,
) -> Result<Vec<u8>, ImportError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
            ImportError::new(path, format!("a data URI {what} is not base64-encoded"))
        })?;
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| {
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
    let full = dir.join(rel);
    std::fs::read(&full).map_err(|e| {
        ImportError::new(
            path,
            format!("cannot read {what} '{}': {e}", full.display()),
        )
    })
}
