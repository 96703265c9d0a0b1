//! The transform gizmo's settings (mode, space, snapping), shared by the viewport that draws it,
//! the menus that switch it and the settings file that remembers it.

use bevy::prelude::*;

/// Which handles the gizmo shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum GizmoMode {
    /// Arrows along the axes and squares for the planes between them (W).
    #[default]
    Translate,
    /// A ring about each axis (E).
    Rotate,
    /// Axis handles ending in boxes and a centre handle for uniform scale (R).
    Scale,
}

impl GizmoMode {
    /// A name for the toolbar.
    pub fn label(self) -> &'static str {
        match self {
            GizmoMode::Translate => "Move",
            GizmoMode::Rotate => "Rotate",
            GizmoMode::Scale => "Scale",
        }
    }
}

/// Whether the handles follow the world's axes or the active object's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum GizmoSpace {
    /// The world's axes.
    #[default]
    World,
    /// The active object's own axes (scaling always uses them).
    Local,
}

/// The gizmo's settings: mode, axes, and the snapping steps used while Ctrl is held.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct GizmoSettings {
    /// Which handles are shown.
    pub mode: GizmoMode,
    /// Which axes they follow.
    pub space: GizmoSpace,
    /// Grid step for moves while snapping, in world units.
    pub grid_step: f32,
    /// Angle step for rotations while snapping, degrees.
    pub angle_step_deg: f32,
    /// Factor step for scaling while snapping.
    pub scale_step: f32,
}

impl Default for GizmoSettings {
    fn default() -> Self {
        Self {
            mode: GizmoMode::Translate,
            space: GizmoSpace::World,
            grid_step: 0.25,
            angle_step_deg: 15.0,
            scale_step: 0.1,
        }
    }
}
