//! The orbit camera: rotate around a focus point, pan it, zoom towards it. Driven by the viewport
//! panel's egui response, so input over other panels never reaches it.

use bevy::camera::visibility::RenderLayers;
use bevy::camera::{CameraOutputMode, ClearColorConfig};
use bevy::prelude::*;
use bevy::render::render_resource::BlendState;
use bevy_egui::{EguiGlobalSettings, PrimaryEguiContext};
use treelight_document::edit::history::apply_edit_requests;
use treelight_document::outbox::{CameraValue, DocumentEvent, DocumentView};

/// Orbit parameters; the camera's transform is derived from them every frame.
#[derive(Component, Debug, Clone, Copy)]
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
        self.pitch = (self.pitch - delta.y * 0.008).clamp(-1.55, 1.55);
    }

    /// Pans the focus by a pointer drag of `delta` logical pixels in a viewport `height` pixels tall.
    pub fn pan(&mut self, delta: Vec2, height: f32) {
        let rot = self.rotation();
        let scale = self.radius / height.max(1.0) * 1.2;
        self.focus += (rot * Vec3::X) * (-delta.x * scale) + (rot * Vec3::Y) * (delta.y * scale);
    }

    /// Zooms by `steps` wheel notches (positive: closer).
    pub fn zoom(&mut self, steps: f32) {
        self.radius = (self.radius * (-steps * 0.1).exp()).clamp(0.05, 1.0e5);
    }

    /// Orientation looking at the focus.
    pub fn rotation(&self) -> Quat {
        Quat::from_euler(EulerRot::YXZ, self.yaw, self.pitch, 0.0)
    }

    /// Looks at a box from the current direction, far enough to see all of it.
    pub fn frame(&mut self, min: Vec3, max: Vec3) {
        self.focus = (min + max) * 0.5;
        self.radius = ((max - min).length() * 1.4).max(0.05);
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

/// World-space bounds of an entity's meshes and its descendants' meshes, from their local boxes.
pub fn world_bounds(
    root: Entity,
    boxes: &Query<(&bevy::camera::primitives::Aabb, &GlobalTransform)>,
    children: &Query<&Children>,
) -> Option<(Vec3, Vec3)> {
    let mut out: Option<(Vec3, Vec3)> = None;
    let mut stack = vec![root];
    while let Some(e) = stack.pop() {
        if let Ok((aabb, gt)) = boxes.get(e) {
            let (c, h) = (Vec3::from(aabb.center), Vec3::from(aabb.half_extents));
            for corner in treelight_document::placement::box_corners(c - h, c + h) {
                let p = gt.transform_point(corner);
                out = Some(out.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
            }
        }
        if let Ok(kids) = children.get(e) {
            stack.extend(kids.iter());
        }
    }
    out
}

/// Asks for the selection to be framed this frame (View → Frame selection).
#[derive(Resource, Debug, Default)]
pub struct FrameRequest(pub bool);

/// The Frame key frames the selection (its meshes and everything under it); nothing happens while
/// a text field has the keyboard.
pub fn frame_selection_on_f(
    chords: Res<crate::editor::input::key_chords::KeyChords>,
    mut contexts: bevy_egui::EguiContexts,
    mut request: ResMut<FrameRequest>,
    selection: Res<crate::editor::viewport::selection::Selection>,
    boxes: Query<(&bevy::camera::primitives::Aabb, &GlobalTransform)>,
    children: Query<&Children>,
    mut orbit: Query<&mut OrbitCamera>,
) {
    let key = chords.triggered(crate::editor::input::keymap::Action::Frame)
        && crate::editor::input::key_chords::keyboard_is_free(&mut contexts);
    if !key && !std::mem::take(&mut request.0) {
        return;
    }
    let bounds = selection
        .entities()
        .iter()
        .filter_map(|e| world_bounds(*e, &boxes, &children))
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
    if let Some((min, max)) = bounds
        && let Ok(mut o) = orbit.single_mut()
    {
        o.frame(min, max);
    }
}

/// The orbit camera and its keys.
pub struct CameraPlugin;

impl Plugin for CameraPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<FrameRequest>()
            .add_systems(Startup, setup_cameras)
            .add_systems(
                Update,
                (
                    follow_document.after(apply_edit_requests),
                    frame_selection_on_f.before(apply_orbit),
                    apply_orbit.after(follow_document),
                    record_view.after(apply_orbit),
                ),
            );
    }
}

/// Writes orbit parameters into the camera transform.
pub fn apply_orbit(mut cameras: Query<(&OrbitCamera, &mut Transform), Changed<OrbitCamera>>) {
    for (orbit, mut transform) in &mut cameras {
        *transform = orbit.transform();
    }
}

/// Spawns the editor's 3D camera (an orbit camera) and the camera egui draws with.
pub fn setup_cameras(mut commands: Commands, mut egui_settings: ResMut<EguiGlobalSettings>) {
    let orbit = OrbitCamera::default();
    commands.spawn((
        Name::new("Editor camera"),
        Camera3d::default(),
        orbit.transform(),
        orbit,
    ));
    // egui gets its own camera drawn over the 3D view, so the 3D camera's viewport can shrink to the
    // viewport panel without clipping the panels.
    egui_settings.auto_create_primary_context = false;
    commands.spawn((
        Name::new("Editor UI camera"),
        // egui antialiases its own shapes; multisampling this camera would only add a copy of the
        // whole window each frame (Bevy's MSAA writeback of the 3D camera's output).
        Msaa::Off,
        PrimaryEguiContext,
        Camera2d,
        RenderLayers::none(),
        Camera {
            order: 1,
            output_mode: CameraOutputMode::Write {
                blend_state: Some(BlendState::ALPHA_BLENDING),
                clear_color: ClearColorConfig::None,
            },
            clear_color: ClearColorConfig::Custom(Color::NONE),
            ..default()
        },
    ));
}

/// Follows the document: a project's saved view is taken up, an import opened without a drop is
/// framed.
pub fn follow_document(
    mut events: MessageReader<DocumentEvent>,
    mut orbit: Query<&mut OrbitCamera>,
) {
    for event in events.read() {
        let Ok(mut o) = orbit.single_mut() else {
            continue;
        };
        match event {
            DocumentEvent::View(c) => *o = OrbitCamera::from(*c),
            DocumentEvent::Frame { min, max } => {
                o.focus = (*min + *max) * 0.5;
                o.radius = (*max - *min).length().max(1e-3) * 1.4;
            }
            _ => {}
        }
    }
}

/// Keeps the view the next save records ([`DocumentView`]) that of the orbit camera.
pub fn record_view(
    orbit: Query<&OrbitCamera, Changed<OrbitCamera>>,
    mut view: ResMut<DocumentView>,
) {
    if let Some(o) = orbit.iter().next() {
        let value = Some(CameraValue::from(*o));
        if view.0 != value {
            view.0 = value;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_looks_at_focus_from_radius() {
        let mut o = OrbitCamera::default();
        o.rotate(Vec2::new(120.0, -40.0));
        let t = o.transform();
        assert!((t.translation.distance(o.focus) - o.radius).abs() < 1e-4);
        let forward = t.forward();
        assert!((o.focus - t.translation).normalize().dot(*forward) > 0.9999);
    }

    #[test]
    fn framing_puts_the_box_in_view() {
        let mut o = OrbitCamera::default();
        let (min, max) = (Vec3::new(4.0, 0.0, -1.0), Vec3::new(6.0, 2.0, 1.0));
        o.frame(min, max);
        assert_eq!(o.focus, Vec3::new(5.0, 1.0, 0.0));
        // The whole box is in front of the camera, further than its half diagonal.
        let eye = o.transform().translation;
        assert!((eye - o.focus).length() > (max - min).length() * 0.5);
    }

    #[test]
    fn zoom_and_pan_move_the_right_way() {
        let mut o = OrbitCamera::default();
        o.zoom(3.0);
        assert!(o.radius < 9.5);
        let before = o.focus;
        o.pan(Vec2::new(100.0, 0.0), 600.0);
        // Dragging right moves the scene right, so the focus moves left in camera space.
        assert!(o.focus.x < before.x);
        o.pitch = 10.0;
        o.rotate(Vec2::ZERO);
        assert!(o.pitch < 1.56);
    }
}
