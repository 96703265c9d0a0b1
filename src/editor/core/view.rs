//! The editor's view of the scene: the orbit camera's parameters, the view changes the menus and
//! keys ask for, and the scene camera to look through.

use crate::editor::core::keymap::Action;
use bevy::prelude::*;
use treelight_document::scene::outbox::CameraValue;

/// Orbit parameters; the camera's transform is derived from them every frame.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct OrbitCamera {
    /// Point orbited around.
    pub focus: Vec3,
    /// Distance from the focus.
    pub radius: f32,
    /// Rotation about the world up axis, radians.
    pub yaw: f32,
    /// Elevation, radians, kept inside (-π/2, π/2).
    pub pitch: f32,
}

impl Default for OrbitCamera {
    fn default() -> Self {
        Self::from(CameraValue::default())
    }
}

impl From<CameraValue> for OrbitCamera {
    fn from(c: CameraValue) -> Self {
        Self {
            focus: Vec3::from_array(c.focus),
            radius: c.radius,
            yaw: c.yaw,
            pitch: c.pitch,
        }
    }
}

impl From<OrbitCamera> for CameraValue {
    fn from(o: OrbitCamera) -> Self {
        Self {
            focus: o.focus.to_array(),
            radius: o.radius,
            yaw: o.yaw,
            pitch: o.pitch,
        }
    }
}

impl OrbitCamera {
    /// Rotates by a pointer drag of `delta` logical pixels.
    pub fn rotate(&mut self, delta: Vec2) {
        self.yaw -= delta.x * 0.008;
        self.pitch = (self.pitch - delta.y * 0.008).clamp(-Self::MAX_PITCH, Self::MAX_PITCH);
    }

    /// Pans the focus by a pointer drag of `delta` logical pixels in a viewport `height` pixels tall.
    pub fn pan(&mut self, delta: Vec2, height: f32) {
        let rot = self.rotation();
        let scale = self.radius / height.max(1.0) * 1.2;
        self.focus += (rot * Vec3::X) * (-delta.x * scale) + (rot * Vec3::Y) * (delta.y * scale);
    }

    /// Zooms by `steps` wheel notches (positive: closer).
    pub fn zoom(&mut self, steps: f32) {
        let (near, far) = CameraValue::RADIUS_RANGE;
        self.radius = (self.radius * (-steps * 0.1).exp()).clamp(near, far);
    }

    /// Orientation looking at the focus.
    pub fn rotation(&self) -> Quat {
        Quat::from_euler(EulerRot::YXZ, self.yaw, self.pitch, 0.0)
    }

    /// The steepest the camera looks up or down, radians (just short of straight).
    pub const MAX_PITCH: f32 = 1.55;

    /// The elevation of a three-quarter view: looking down at about 30°.
    pub const THREE_QUARTER_PITCH: f32 = CameraValue::THREE_QUARTER_PITCH;

    /// Looks at a box from the current direction, far enough to see all of it; a view from
    /// about ground level is lifted to a three-quarter view first, so a flat scene is not a line.
    pub fn frame(&mut self, min: Vec3, max: Vec3) {
        if self.pitch > -0.15 {
            self.pitch = Self::THREE_QUARTER_PITCH;
        }
        let framed = CameraValue::framing(min, max);
        self.focus = Vec3::from_array(framed.focus);
        self.radius = framed.radius;
    }

    /// Looks at a box from above at an angle (a three-quarter view: 30° down, 45° round), far
    /// enough to see all of it, as a newly opened file is shown ([`CameraValue::framing`]:
    /// within what a saved project opens with).
    pub fn frame_from_above(&mut self, min: Vec3, max: Vec3) {
        *self = Self::from(CameraValue::framing(min, max));
    }

    /// The camera transform these parameters describe.
    pub fn transform(&self) -> Transform {
        let rot = self.rotation();
        Transform {
            translation: self.focus + rot * Vec3::Z * self.radius,
            rotation: rot,
            ..default()
        }
    }
}

/// A change of view the View menu or a key asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewChange {
    /// The selection, whole.
    FrameSelection,
    /// Everything in the scene, whole, from above at an angle.
    FrameAll,
    /// Look along -Z.
    Front,
    /// Look along -X, from the right.
    Side,
    /// Look straight down.
    Top,
}

impl ViewChange {
    /// The key that asks for it.
    pub fn action(self) -> Action {
        match self {
            ViewChange::FrameSelection => Action::Frame,
            ViewChange::FrameAll => Action::FrameAll,
            ViewChange::Front => Action::ViewFront,
            ViewChange::Side => Action::ViewSide,
            ViewChange::Top => Action::ViewTop,
        }
    }

    /// Every change, in the View menu's order.
    pub const ALL: [ViewChange; 5] = [
        ViewChange::FrameSelection,
        ViewChange::FrameAll,
        ViewChange::Front,
        ViewChange::Side,
        ViewChange::Top,
    ];

    /// Its name in the View menu.
    pub fn label(self) -> &'static str {
        match self {
            ViewChange::FrameSelection => "Frame selection",
            ViewChange::FrameAll => "Frame everything",
            ViewChange::Front => "Front view",
            ViewChange::Side => "Side view",
            ViewChange::Top => "Top view",
        }
    }
}

/// The view change the View menu asked for this frame.
#[derive(Resource, Debug, Default)]
pub struct ViewRequest(pub Option<ViewChange>);

/// A scene camera to look through, asked for by the inspector, the View menu or `--camera`.
#[derive(Resource, Debug, Default)]
pub enum LookThrough {
    /// Nothing asked.
    #[default]
    None,
    /// This camera object.
    Object(Entity),
    /// The scene camera of this name, once the scene has one (`--camera NAME`).
    Named(String),
}
