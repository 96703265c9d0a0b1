//! What the document tells whoever shows it: the core never reaches into an editor's selection,
//! camera or menus; it writes a [`DocumentEvent`] and the shell answers it (or nobody does, as in
//! a headless run).

use crate::object::SceneId;
use bevy::prelude::*;
use std::path::PathBuf;

/// The view a project saves and restores: an orbit around a focus.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CameraValue {
    /// Point orbited around.
    pub focus: [f32; 3],
    /// Distance from the focus.
    pub radius: f32,
    /// Rotation about the world up axis, radians.
    pub yaw: f32,
    /// Elevation, radians.
    pub pitch: f32,
}

impl Default for CameraValue {
    /// The view a new scene starts with: the default room seen from the front.
    fn default() -> Self {
        Self {
            focus: [0.0, 2.5, 0.0],
            radius: 9.5,
            yaw: 0.0,
            pitch: 0.0,
        }
    }
}

/// Something that happened to the document that a shell may want to follow.
#[derive(Message, Clone, Debug, PartialEq)]
pub enum DocumentEvent {
    /// An edit made these objects (a duplicate, a new shape or light, a group): an editor selects
    /// them.
    Made(Vec<SceneId>),
    /// The whole scene was replaced (new, opened, recovered): what pointed into the old one ends.
    Replaced,
    /// A file was imported without a place to stand: an editor frames its world-space bounds.
    Frame {
        /// Lower corner.
        min: Vec3,
        /// Upper corner.
        max: Vec3,
    },
    /// A project was opened with this view.
    View(CameraValue),
    /// A project was opened from this file.
    Opened(PathBuf),
    /// The project was saved to this file.
    Saved(PathBuf),
    /// A save to this file failed (the error is a notice).
    SaveFailed(PathBuf),
}

/// The view the next save records: kept by whoever owns a camera (the editor's orbit camera),
/// set by opening a project, so a headless open-and-save keeps it too.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct DocumentView(pub Option<CameraValue>);
