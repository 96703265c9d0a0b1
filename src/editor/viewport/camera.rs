//! The orbit camera: rotate around a focus point, pan it, zoom towards it. Driven by the viewport
//! panel's egui response, so input over other panels never reaches it.

use crate::editor::core::view::{LookThrough, OrbitCamera, ViewChange, ViewRequest};
use bevy::camera::visibility::RenderLayers;
use bevy::camera::{CameraOutputMode, ClearColorConfig};
use bevy::prelude::*;
use bevy::render::render_resource::BlendState;
use bevy_egui::{EguiGlobalSettings, PrimaryEguiContext};
use treelight_document::edit::history::apply_edit_requests;
use treelight_document::scene::outbox::{CameraValue, DocumentEvent, DocumentView};
use treelight_document::values::object::SceneObject;

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
            for corner in treelight_document::scene::placement::box_corners(c - h, c + h) {
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

/// The bounds a framing takes in: the selection's, or every scene object's.
#[derive(bevy::ecs::system::SystemParam)]
pub struct FramedBounds<'w, 's> {
    selection: Res<'w, crate::editor::core::selection::Selection>,
    objects: Query<'w, 's, Entity, (With<SceneObject>, Without<ChildOf>)>,
    boxes: Query<
        'w,
        's,
        (
            &'static bevy::camera::primitives::Aabb,
            &'static GlobalTransform,
        ),
    >,
    children: Query<'w, 's, &'static Children>,
}

impl FramedBounds<'_, '_> {
    fn of(&self, entities: impl Iterator<Item = Entity>) -> Option<(Vec3, Vec3)> {
        entities
            .filter_map(|e| world_bounds(e, &self.boxes, &self.children))
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    }
}

/// The View keys and menu: frame the selection (its meshes and everything under it) or everything,
/// or look from the front, the side or the top; nothing happens while a text field has the
/// keyboard.
pub fn change_view(
    chords: Res<crate::editor::core::key_chords::KeyChords>,
    mut contexts: bevy_egui::EguiContexts,
    mut request: ResMut<ViewRequest>,
    bounds: FramedBounds,
    mut orbit: Query<&mut OrbitCamera>,
) {
    let keys_free = crate::editor::core::key_chords::keyboard_is_free(&mut contexts);
    let typed = ViewChange::ALL
        .into_iter()
        .find(|c| keys_free && chords.triggered(c.action()));
    let Some(change) = request.0.take().or(typed) else {
        return;
    };
    let Ok(mut o) = orbit.single_mut() else {
        return;
    };
    match change {
        ViewChange::FrameSelection => {
            if let Some((min, max)) = bounds.of(bounds.selection.entities().iter().copied()) {
                o.frame(min, max);
            }
        }
        ViewChange::FrameAll => {
            if let Some((min, max)) = bounds.of(bounds.objects.iter()) {
                o.frame_from_above(min, max);
            }
        }
        ViewChange::Front => (o.yaw, o.pitch) = (0.0, 0.0),
        ViewChange::Side => (o.yaw, o.pitch) = (std::f32::consts::FRAC_PI_2, 0.0),
        ViewChange::Top => o.pitch = -OrbitCamera::MAX_PITCH,
    }
}

/// The message for a scene without a camera of `name`, listing the cameras it has.
pub fn no_camera_named<'a>(name: &str, cameras: impl Iterator<Item = &'a str>) -> String {
    let names: Vec<&str> = cameras.collect();
    format!(
        "no camera named '{name}' in the scene (it has {})",
        if names.is_empty() {
            "none".to_owned()
        } else {
            names.join(", ")
        }
    )
}

/// Puts the orbit camera where `camera` is, looking where it looks (its roll dropped, as the orbit
/// camera has none), at the same distance from the focus as before, with its projection.
pub fn look_through(
    orbit: &mut OrbitCamera,
    projection: &mut Projection,
    at: &GlobalTransform,
    camera: &treelight_document::values::camera::SceneCamera,
) {
    let position = at.translation();
    let forward = at.forward().as_vec3();
    orbit.yaw = (-forward.x).atan2(-forward.z);
    orbit.pitch = forward
        .y
        .clamp(-1.0, 1.0)
        .asin()
        .clamp(-OrbitCamera::MAX_PITCH, OrbitCamera::MAX_PITCH);
    // The direction the clamped angles give, so the camera stays where the scene's camera is.
    let looking = orbit.rotation() * Vec3::NEG_Z;
    orbit.focus = position + looking * orbit.radius;
    *projection = camera.bevy_projection();
}

/// Whether `--camera`'s camera was found (or the scene settled without it: then a notice).
#[derive(Resource, Debug, Default)]
struct NamedCameraMissing(bool);

/// Looks through the camera asked for: at once for an object, or once the scene holds a camera of
/// the asked name (a notice says so when the scene has settled without one).
fn apply_look_through(
    mut request: ResMut<LookThrough>,
    cameras: Query<(
        Entity,
        &Name,
        &GlobalTransform,
        &treelight_document::values::camera::SceneCamera,
    )>,
    mut orbit: Query<(&mut OrbitCamera, &mut Projection)>,
    loading: treelight_document::app::SceneLoading,
    mut missing: ResMut<NamedCameraMissing>,
    mut notices: ResMut<treelight_document::scene::notice::Notices>,
) {
    let found = match &*request {
        LookThrough::None => return,
        LookThrough::Object(e) => cameras.get(*e).ok(),
        // Once the scene has settled, so that framing the opened file does not undo it.
        LookThrough::Named(_) if !loading.settled() => return,
        LookThrough::Named(name) => cameras.iter().find(|c| c.1.as_str() == name),
    };
    let Some((_, _, at, camera)) = found else {
        if let LookThrough::Named(name) = &*request
            && !missing.0
        {
            missing.0 = true;
            notices.error(no_camera_named(name, cameras.iter().map(|c| c.1.as_str())));
        }
        if matches!(*request, LookThrough::Object(_)) {
            *request = LookThrough::None;
        }
        return;
    };
    if let Ok((mut o, mut p)) = orbit.single_mut() {
        look_through(&mut o, &mut p, at, camera);
    }
    *request = LookThrough::None;
}

/// The orbit camera and its keys.
pub struct CameraPlugin;

impl Plugin for CameraPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ViewRequest>()
            .init_resource::<LookThrough>()
            .init_resource::<NamedCameraMissing>()
            .add_systems(Startup, setup_cameras)
            // After transforms are propagated, so a camera spawned this frame is where it stands;
            // the orbit camera follows in the next frame's Update.
            .add_systems(
                PostUpdate,
                apply_look_through.after(bevy::transform::TransformSystems::Propagate),
            )
            .add_systems(
                Update,
                (
                    follow_document.after(apply_edit_requests),
                    change_view.before(apply_orbit),
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
        // Always HDR, so the tone curve is applied after everything the raster view draws (the
        // sky panorama's cube map too), as it is to the path tracer's image; and switching views
        // keeps one picture pipeline.
        bevy::camera::Hdr,
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
            DocumentEvent::Frame { min, max } => o.frame_from_above(*min, *max),
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
    use treelight_document::scene::placement::box_corners;

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
    fn a_flat_scene_opened_is_seen_whole_from_above() {
        // A flat city 200 × 2 × 200: from ground level it would be a line.
        let (min, max) = (Vec3::new(-100.0, 0.0, -100.0), Vec3::new(100.0, 2.0, 100.0));
        for start in [
            OrbitCamera::default(),
            OrbitCamera::from(CameraValue::default()),
        ] {
            let mut o = start;
            o.frame_from_above(min, max);
            let t = o.transform();
            assert!(t.translation.y > 50.0, "{t:?}");
            // Every corner within 22.5° of the view's axis: inside Bevy's default 45° field.
            let forward = *t.forward();
            for c in box_corners(min, max) {
                let angle = forward.angle_between(c - t.translation).to_degrees();
                assert!(angle < 22.5, "{c}: {angle}°");
            }
            // F on a view at ground level lifts it too.
            let mut f = OrbitCamera::default();
            f.frame(min, max);
            assert!(f.transform().translation.y > 50.0);
        }
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
