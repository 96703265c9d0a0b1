//! Cameras a scene file brings (glTF's): scene objects the viewport can look through and renders
//! can be made from. They are not Bevy cameras (nothing renders from them until asked): a
//! `SceneCamera` holds the projection, the object's transform the place, looking along -z with +y
//! up as glTF has it.

use bevy::prelude::*;
use treelight_import::ImportedCamera;

/// How a scene camera projects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraProjection {
    /// A pinhole camera.
    Perspective {
        /// Vertical field of view, radians.
        fov_y: f32,
        /// Distance to the near plane.
        near: f32,
        /// Distance to the far plane; `None`: infinite.
        far: Option<f32>,
    },
    /// A parallel projection.
    Orthographic {
        /// The view's height in world units.
        height: f32,
        /// Distance to the near plane.
        near: f32,
        /// Distance to the far plane.
        far: f32,
    },
}

/// A camera among the scene's objects.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct SceneCamera {
    /// Its projection.
    pub projection: CameraProjection,
}

impl SceneCamera {
    /// A file's camera as the editor's.
    pub fn from_imported(c: &ImportedCamera) -> Self {
        let projection = match *c {
            ImportedCamera::Perspective {
                yfov, near, far, ..
            } => CameraProjection::Perspective {
                fov_y: yfov,
                near,
                far,
            },
            ImportedCamera::Orthographic {
                ymag, near, far, ..
            } => CameraProjection::Orthographic {
                height: 2.0 * ymag.abs(),
                near,
                far,
            },
        };
        Self { projection }
    }

    /// What it is, for the inspector: "Perspective, 40° vertical" or "Orthographic, 4 m tall".
    pub fn describe(&self) -> String {
        match self.projection {
            CameraProjection::Perspective { fov_y, .. } => {
                format!("Perspective, {:.1}° vertical", fov_y.to_degrees())
            }
            CameraProjection::Orthographic { height, .. } => {
                format!("Orthographic, {height:.3} m tall")
            }
        }
    }

    /// Bevy's projection for looking through it (an infinite far plane where the file has one
    /// too far to matter for a preview).
    pub fn bevy_projection(&self) -> Projection {
        match self.projection {
            CameraProjection::Perspective { fov_y, near, .. } => {
                Projection::Perspective(PerspectiveProjection {
                    fov: fov_y,
                    near,
                    ..default()
                })
            }
            CameraProjection::Orthographic { height, near, far } => {
                Projection::Orthographic(OrthographicProjection {
                    near,
                    far,
                    scaling_mode: bevy::camera::ScalingMode::FixedVertical {
                        viewport_height: height,
                    },
                    ..OrthographicProjection::default_3d()
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_s_cameras_become_projections() {
        let p = SceneCamera::from_imported(&ImportedCamera::Perspective {
            yfov: 0.7,
            near: 0.1,
            far: None,
            aspect: Some(1.5),
        });
        assert!(
            p.describe().starts_with("Perspective, 40.1°"),
            "{}",
            p.describe()
        );
        match p.bevy_projection() {
            Projection::Perspective(pp) => assert_eq!((pp.fov, pp.near), (0.7, 0.1)),
            other => panic!("{other:?}"),
        }
        let o = SceneCamera::from_imported(&ImportedCamera::Orthographic {
            ymag: -2.0,
            xmag: 3.0,
            near: 0.0,
            far: 50.0,
        });
        assert_eq!(
            o.projection,
            CameraProjection::Orthographic {
                height: 4.0,
                near: 0.0,
                far: 50.0
            }
        );
        assert!(matches!(o.bevy_projection(), Projection::Orthographic(_)));
    }
}
