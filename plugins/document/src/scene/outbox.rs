//! What the document tells whoever shows it: the core never reaches into an editor's selection,
//! camera or menus; it writes a [`DocumentEvent`] and the shell answers it (or nobody does, as in
//! a headless run).

use crate::values::object::SceneId;
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

impl CameraValue {
    /// The nearest and farthest a view may be from its focus: what zoom and framing allow, and
    /// what a saved project's view is clamped to when it opens (as far as a project holds a
    /// number: a site of 1e9 units is framed whole).
    pub const RADIUS_RANGE: (f32, f32) = (0.05, crate::values::transform::MAX_VALUE);

    /// The elevation of a three-quarter view: looking down at about 30°.
    pub const THREE_QUARTER_PITCH: f32 = -0.52;

    /// This view within what a project saves and opens again: finite, the focus within the
    /// editor's range of values, the radius within [`Self::RADIUS_RANGE`], the pitch short of
    /// straight up or down.
    pub fn clamped(self) -> Self {
        let limit = crate::values::transform::MAX_VALUE;
        let finite = |v: f32, fallback: f32| if v.is_finite() { v } else { fallback };
        let (near, far) = Self::RADIUS_RANGE;
        Self {
            focus: self.focus.map(|v| finite(v, 0.0).clamp(-limit, limit)),
            radius: finite(self.radius, far).clamp(near, far),
            yaw: finite(self.yaw, 0.0).clamp(-limit, limit),
            pitch: finite(self.pitch, 0.0).clamp(-1.55, 1.55),
        }
    }

    /// The view a newly opened file is shown with: from above at an angle (30° down, 45°
    /// round), far enough to see the box `min`..`max`, within what a project saves and opens
    /// again (the radius within [`Self::RADIUS_RANGE`], the focus within the editor's range of
    /// values, whatever the box).
    pub fn framing(min: Vec3, max: Vec3) -> Self {
        let limit = crate::values::transform::MAX_VALUE;
        let centre = ((min.as_dvec3() + max.as_dvec3()) * 0.5).as_vec3();
        let focus = if centre.is_finite() {
            centre.clamp(Vec3::splat(-limit), Vec3::splat(limit))
        } else {
            Vec3::ZERO
        };
        let size = (max.as_dvec3() - min.as_dvec3()).length() as f32 * 1.4;
        let (near, far) = Self::RADIUS_RANGE;
        Self {
            focus: focus.to_array(),
            radius: if size.is_finite() {
                size.clamp(near, far)
            } else {
                far
            },
            yaw: std::f32::consts::FRAC_PI_4,
            pitch: Self::THREE_QUARTER_PITCH,
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
