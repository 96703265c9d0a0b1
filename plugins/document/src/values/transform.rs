//! Transforms as commands and projects store them: plain arrays, checked against the range the
//! engine's arithmetic holds.

use bevy::prelude::*;
use serde::{Deserialize, Serialize};

/// A transform as commands store it (plain arrays, so scripts can write it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformValue {
    /// Position.
    pub translation: [f32; 3],
    /// Rotation quaternion, x, y, z, w.
    #[serde(default = "identity_rotation")]
    pub rotation: [f32; 4],
    /// Scale per axis.
    #[serde(default = "unit_scale")]
    pub scale: [f32; 3],
}

/// Largest magnitude of a number in a transform, material, light or camera, for commands and
/// projects alike: past it, products overflow to infinity in the engine's arithmetic.
pub const MAX_VALUE: f32 = 1.0e9;

/// Whether `v` is a number the scene accepts: finite, within [`MAX_VALUE`].
pub fn in_range(v: f32) -> bool {
    v.is_finite() && v.abs() <= MAX_VALUE
}

impl TransformValue {
    /// Whether every number is [`in_range`].
    pub fn is_valid(&self) -> bool {
        self.translation
            .iter()
            .chain(&self.rotation)
            .chain(&self.scale)
            .all(|v| in_range(*v))
    }
}

fn identity_rotation() -> [f32; 4] {
    [0.0, 0.0, 0.0, 1.0]
}

fn unit_scale() -> [f32; 3] {
    [1.0; 3]
}

impl From<Transform> for TransformValue {
    fn from(t: Transform) -> Self {
        Self {
            translation: t.translation.to_array(),
            rotation: t.rotation.to_array(),
            scale: t.scale.to_array(),
        }
    }
}

impl From<TransformValue> for Transform {
    fn from(t: TransformValue) -> Self {
        let rotation = Quat::from_array(t.rotation);
        Transform {
            translation: Vec3::from_array(t.translation),
            // A unit quaternion (within glam's tolerance) is kept bit for bit, so a transform
            // saved and read back is the same; others (hand-edited files) are made unit.
            rotation: if rotation.is_normalized() {
                rotation
            } else if rotation.is_finite() && rotation.length_squared() > 0.0 {
                rotation.normalize()
            } else {
                Quat::IDENTITY
            },
            scale: Vec3::from_array(t.scale),
        }
    }
}
