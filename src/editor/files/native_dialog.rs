//! The desktop's own file dialog (rfd: the XDG desktop portal, or zenity where the portal is
//! missing), used when the desktop has one; otherwise the in-window dialog of `file_dialog.rs`.

use super::file_dialog::DialogPurpose;
use crate::editor::core::rest::Waker;
use bevy::tasks::futures_lite::future::{block_on, poll_once};
use bevy::tasks::{AsyncComputeTaskPool, Task};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Whether file dialogs are the desktop's: `TREELIGHT_FILE_DIALOG=builtin` or `native` decides;
/// otherwise they are when a desktop portal or zenity is there to show one. rfd answers "no
/// dialog" exactly as it answers a cancel, so this is asked before, not after.
pub fn native_dialogs() -> bool {
    static NATIVE: OnceLock<bool> = OnceLock::new();
    *NATIVE.get_or_init(|| match std::env::var("TREELIGHT_FILE_DIALOG").as_deref() {
        Ok("builtin") => false,
        Ok("native") => true,
        _ => portal_service() || on_path("zenity"),
    })
}

/// A session bus, and the portal's service file where D-Bus would start it.
fn portal_service() -> bool {
    if std::env::var_os("DBUS_SESSION_BUS_ADDRESS").is_none_or(|a| a.is_empty()) {
        return false;
    }
    let dirs = std::env::var("XDG_DATA_DIRS")
        .ok()
        .filter(|d| !d.is_empty())
        .unwrap_or_else(|| "/usr/local/share:/usr/share".into());
    dirs.split(':').any(|d| {
        Path::new(d)
            .join("dbus-1/services/org.freedesktop.portal.Desktop.service")
            .is_file()
    })
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(program).is_file()))
}

/// A desktop file dialog, open on its own thread until it answers.
pub struct NativeDialog {
    /// What the chosen file is for.
    pub purpose: DialogPurpose,
    task: Task<Result<Option<PathBuf>, String>>,
}

impl NativeDialog {
    /// Opens the desktop's dialog for `purpose` in `dir` (with `name` filled in for a save); its
    /// answer wakes a resting editor through `waker`.
    pub fn open(purpose: DialogPurpose, dir: PathBuf, name: String, waker: Waker) -> Self {
        let dialog = rfd::AsyncFileDialog::new()
            .set_title(purpose.title())
            .set_directory(dir);
        let task = AsyncComputeTaskPool::get().spawn(async move {
            use bevy::tasks::futures_lite::FutureExt;
            let chosen = async move {
                let handle = match purpose {
                    DialogPurpose::Open => {
                        dialog
                            .add_filter("Treelight project", &["treelight"])
                            .pick_file()
                            .await
                    }
                    DialogPurpose::Import | DialogPurpose::Relink => {
                        dialog
                            .add_filter("Scene files", &["gltf", "glb", "obj", "ply"])
                            .pick_file()
                            .await
                    }
                    DialogPurpose::AssetFolder => dialog.pick_folder().await,
                    DialogPurpose::Environment => {
                        dialog
                            .add_filter("HDR panoramas", &["hdr", "exr"])
                            .pick_file()
                            .await
                    }
                    DialogPurpose::SaveAs => {
                        dialog
                            .add_filter("Treelight project", &["treelight"])
                            .set_file_name(name)
                            .save_file()
                            .await
                    }
                };
                handle.map(|h| h.path().to_owned())
            };
            // A desktop dialog that crashes ends as an error, not the editor.
            let answer = std::panic::AssertUnwindSafe(chosen)
                .catch_unwind()
                .await
                .map_err(|p| {
                    treelight_document::files::contain::crashed(
                        "the desktop file dialog".into(),
                        &*p,
                    )
                });
            waker.wake();
            answer
        });
        Self { purpose, task }
    }

    /// The answer, once given: a file, or `None` for a cancel.
    pub fn poll(&mut self) -> Option<Result<Option<PathBuf>, String>> {
        block_on(poll_once(&mut self.task))
    }
}
