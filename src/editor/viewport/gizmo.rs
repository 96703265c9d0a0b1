//! The transform gizmo: translate, rotate and scale handles drawn over the viewport, picked and
//! dragged in screen space. This module is the arithmetic (handles, picking, what a drag does to
//! the selected objects) and the settings; the viewport draws the handles and sends a drag's
//! result as a live preview, then as one undoable command on release.

use crate::editor::core::gizmo_settings::{GizmoMode, GizmoSettings};
use treelight_document::edit::history::EditHistory;

use treelight_document::edit::history::EditRequest;

use crate::editor::core::key_chords::KeyChords;
use crate::editor::core::keymap::Action;
use bevy::math::{Affine3A, Mat3, Ray3d};
use bevy::prelude::*;
use treelight_document::edit::history::EditRequests;

/// One handle of the gizmo.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Handle {
    /// Move along axis 0, 1 or 2.
    Axis(usize),
    /// Move in the plane normal to axis 0, 1 or 2.
    Plane(usize),
    /// Rotate about axis 0, 1 or 2.
    Ring(usize),
    /// Scale along axis 0, 1 or 2.
    ScaleAxis(usize),
    /// Scale the same along every axis.
    ScaleUniform,
}

/// A camera's view of the world, for projecting handles and making rays from the pointer.
pub trait ViewProjection {
    /// A world point's position in window coordinates (logical pixels), if in front of the camera.
    fn project(&self, world: Vec3) -> Option<Vec2>;
    /// The ray through a window position.
    fn ray(&self, screen: Vec2) -> Option<Ray3d>;
}

impl ViewProjection for (&Camera, &GlobalTransform) {
    fn project(&self, world: Vec3) -> Option<Vec2> {
        self.0.world_to_viewport(self.1, world).ok()
    }

    fn ray(&self, screen: Vec2) -> Option<Ray3d> {
        self.0.viewport_to_world(self.1, screen).ok()
    }
}

/// Where the gizmo is: its centre, its three unit axes, and its arms' length in world units (so
/// it keeps the same size on screen).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GizmoFrame {
    /// The centre: the selection's median point.
    pub pivot: Vec3,
    /// The axes the handles follow.
    pub axes: [Vec3; 3],
    /// Length of an arm in world units.
    pub size: f32,
}

/// Arm length on screen, logical pixels.
const ARM_PIXELS: f32 = 90.0;
/// How close the pointer must be to a handle to grab it, logical pixels.
const GRAB_PIXELS: f32 = 9.0;
/// Plane handles span this part of the arm, from the centre.
const PLANE_SPAN: (f32, f32) = (0.25, 0.45);
/// Points per ring.
const RING_SEGMENTS: usize = 64;

impl GizmoFrame {
    /// The frame at `pivot` with `axes` (made unit length), sized for the view.
    pub fn new(pivot: Vec3, axes: [Vec3; 3], view: &impl ViewProjection) -> Option<Self> {
        let axes = axes.map(|a| a.try_normalize().unwrap_or(Vec3::ZERO));
        if axes.contains(&Vec3::ZERO) {
            return None;
        }
        // World units per pixel at the pivot: from the ray through the pixel beside the pivot's.
        let centre = view.project(pivot)?;
        let r0 = view.ray(centre)?;
        let r1 = view.ray(centre + Vec2::X)?;
        let depth = (pivot - r0.origin).dot(*r0.direction);
        let per_pixel =
            (r1.get_point(depth / r1.direction.dot(*r0.direction)) - r0.get_point(depth)).length();
        (per_pixel.is_finite() && per_pixel > 0.0).then_some(Self {
            pivot,
            axes,
            size: per_pixel * ARM_PIXELS,
        })
    }

    /// Axes of a transform's rotation (and shear, if its parents have one): its matrix's columns.
    pub fn axes_of(world: &Affine3A) -> [Vec3; 3] {
        let m = world.matrix3;
        [m.x_axis.into(), m.y_axis.into(), m.z_axis.into()]
    }

    /// The handles of `mode` as polylines in window coordinates, with whether each closes.
    pub fn handles(&self, mode: GizmoMode, view: &impl ViewProjection) -> Vec<(Handle, Vec<Vec2>)> {
        let mut out = Vec::new();
        let p = self.pivot;
        let s = self.size;
        let project_all = |points: &[Vec3]| -> Option<Vec<Vec2>> {
            points.iter().map(|q| view.project(*q)).collect()
        };
        match mode {
            GizmoMode::Translate | GizmoMode::Scale => {
                let scale = mode == GizmoMode::Scale;
                for (i, a) in self.axes.iter().enumerate() {
                    if let Some(line) = project_all(&[p, p + *a * s]) {
                        out.push((
                            if scale {
                                Handle::ScaleAxis(i)
                            } else {
                                Handle::Axis(i)
                            },
                            line,
                        ));
                    }
                }
                if scale {
                    if let Some(c) = view.project(p) {
                        out.push((Handle::ScaleUniform, vec![c]));
                    }
                } else {
                    for i in 0..3 {
                        let (u, v) = (self.axes[(i + 1) % 3] * s, self.axes[(i + 2) % 3] * s);
                        let (a, b) = PLANE_SPAN;
                        let quad = [
                            p + u * a + v * a,
                            p + u * b + v * a,
                            p + u * b + v * b,
                            p + u * a + v * b,
                        ];
                        if let Some(q) = project_all(&quad) {
                            out.push((Handle::Plane(i), q));
                        }
                    }
                }
            }
            GizmoMode::Rotate => {
                for i in 0..3 {
                    let (u, v) = (self.axes[(i + 1) % 3], self.axes[(i + 2) % 3]);
                    let ring: Vec<Vec3> = (0..=RING_SEGMENTS)
                        .map(|k| {
                            let t = k as f32 / RING_SEGMENTS as f32 * std::f32::consts::TAU;
                            p + (u * t.cos() + v * t.sin()) * s
                        })
                        .collect();
                    if let Some(r) = project_all(&ring) {
                        out.push((Handle::Ring(i), r));
                    }
                }
            }
        }
        out
    }

    /// The handle under the pointer, if any: the nearest within reach, plane squares by area.
    pub fn pick(
        &self,
        mode: GizmoMode,
        view: &impl ViewProjection,
        pointer: Vec2,
    ) -> Option<Handle> {
        let mut best: Option<(Handle, f32)> = None;
        for (handle, shape) in self.handles(mode, view) {
            let d = match handle {
                Handle::Plane(_) => {
                    if inside_polygon(&shape, pointer) {
                        // Inside the square: as good as on a line, so axes near it still win.
                        GRAB_PIXELS * 0.5
                    } else {
                        continue;
                    }
                }
                Handle::ScaleUniform => shape[0].distance(pointer) - 4.0,
                _ => distance_to_polyline(&shape, pointer),
            };
            if d <= GRAB_PIXELS && best.is_none_or(|(_, b)| d < b) {
                best = Some((handle, d));
            }
        }
        best.map(|(h, _)| h)
    }
}

/// Distance from `p` to the nearest segment of a polyline.
pub fn distance_to_polyline(points: &[Vec2], p: Vec2) -> f32 {
    if points.len() == 1 {
        return points[0].distance(p);
    }
    points
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let ab = b - a;
            let t = ((p - a).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
            (a + ab * t).distance(p)
        })
        .fold(f32::INFINITY, f32::min)
}

/// Whether `p` is inside a convex or concave polygon (even-odd rule).
pub fn inside_polygon(poly: &[Vec2], p: Vec2) -> bool {
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
    }
    inside
}

/// One object a drag moves: where it was when the drag began, and its parent's world transform.
#[derive(Clone, Copy, Debug)]
pub struct DragTarget {
    /// The object.
    pub id: treelight_document::values::object::SceneId,
    /// Its world transform at the start.
    pub start_world: Affine3A,
    /// Its parent's world transform (identity at the top).
    pub parent_world: Affine3A,
}

impl DragTarget {
    /// The local transform that puts the object at `delta * start_world`. Moves are exact under any
    /// parent; a rotation under a non-uniformly scaled parent loses the shear no transform holds.
    pub fn local_after(&self, delta: Affine3A) -> Transform {
        Transform::from_matrix((self.parent_world.inverse() * delta * self.start_world).into())
    }
}

/// A drag in progress: the handle, the frame and pointer ray when it began.
#[derive(Clone, Debug)]
pub struct GizmoDrag {
    /// The handle dragged.
    pub handle: Handle,
    /// The gizmo's frame at the start.
    pub frame: GizmoFrame,
    /// Where the pointer was pressed, window coordinates.
    pub start_pointer: Vec2,
    /// The pivot on screen at the start.
    pub start_pivot_screen: Vec2,
    /// The pointer's ray at the start.
    pub start_ray: Ray3d,
    /// A rotation measured on screen, for a ring seen edge-on; with the sign of the axis towards the
    /// viewer.
    pub screen_rotation: Option<f32>,
    /// The objects moved.
    pub targets: Vec<DragTarget>,
}

/// How far a drag has gone, as a world-space transform applied about the pivot, and a text for
/// the viewport (the distance, angle or factor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DragResult {
    /// The change, in world space.
    pub delta: Affine3A,
    /// What the drag amounts to, for the user.
    pub amount: f32,
}

/// Parameter along the line `origin + t * axis` of its point nearest to `ray`; `None` when the ray
/// runs nearly along the line.
fn line_parameter(origin: Vec3, axis: Vec3, ray: Ray3d) -> Option<f32> {
    let d = Vec3::from(ray.direction);
    let w = origin - ray.origin;
    let b = axis.dot(d);
    let denom = 1.0 - b * b;
    if denom < 1e-3 {
        return None;
    }
    Some((b * w.dot(d) - w.dot(axis)) / denom)
}

/// Where `ray` meets the plane through `point` normal to `normal`.
fn plane_hit(point: Vec3, normal: Vec3, ray: Ray3d) -> Option<Vec3> {
    let d = Vec3::from(ray.direction);
    let denom = normal.dot(d);
    if denom.abs() < 1e-4 {
        return None;
    }
    let t = normal.dot(point - ray.origin) / denom;
    (t > 0.0).then(|| ray.get_point(t))
}

fn snap(v: f32, step: f32) -> f32 {
    if step > 0.0 {
        (v / step).round() * step
    } else {
        v
    }
}

impl GizmoDrag {
    /// Starts dragging `handle`, the pointer pressed at `pointer`.
    pub fn start(
        handle: Handle,
        frame: GizmoFrame,
        pointer: Vec2,
        view: &impl ViewProjection,
        targets: Vec<DragTarget>,
    ) -> Option<Self> {
        let start_ray = view.ray(pointer)?;
        let start_pivot_screen = view.project(frame.pivot)?;
        let screen_rotation = match handle {
            Handle::Ring(i) => {
                let axis = frame.axes[i];
                let facing = axis.dot(*start_ray.direction);
                // Edge-on rings turn with the pointer's angle about the pivot on screen.
                (facing.abs() < 0.2).then_some(if facing > 0.0 { 1.0 } else { -1.0 })
            }
            _ => None,
        };
        Some(Self {
            handle,
            frame,
            start_pointer: pointer,
            start_pivot_screen,
            start_ray,
            screen_rotation,
            targets,
        })
    }

    /// What the drag does with the pointer at `pointer` (snapped to the settings' steps when `snap`
    /// is set); `None` while the pointer's ray gives no answer (e.g. along the dragged axis).
    pub fn result(
        &self,
        pointer: Vec2,
        view: &impl ViewProjection,
        settings: &GizmoSettings,
        snapping: bool,
    ) -> Option<DragResult> {
        let ray = view.ray(pointer)?;
        let f = &self.frame;
        let p = f.pivot;
        let about_pivot =
            |m: Affine3A| Affine3A::from_translation(p) * m * Affine3A::from_translation(-p);
        let grid = if snapping { settings.grid_step } else { 0.0 };
        Some(match self.handle {
            Handle::Axis(i) => {
                let a = f.axes[i];
                let t = line_parameter(p, a, ray)? - line_parameter(p, a, self.start_ray)?;
                let t = snap(t, grid);
                DragResult {
                    delta: Affine3A::from_translation(a * t),
                    amount: t,
                }
            }
            Handle::Plane(i) => {
                let n = f.axes[i];
                let d = plane_hit(p, n, ray)? - plane_hit(p, n, self.start_ray)?;
                let (u, v) = (f.axes[(i + 1) % 3], f.axes[(i + 2) % 3]);
                // Components along the (possibly skewed) in-plane axes.
                let basis = Mat3::from_cols(u, v, n);
                let c = basis.inverse() * d;
                let (cu, cv) = (snap(c.x, grid), snap(c.y, grid));
                let moved = u * cu + v * cv;
                DragResult {
                    delta: Affine3A::from_translation(moved),
                    amount: moved.length(),
                }
            }
            Handle::Ring(i) => {
                let a = f.axes[i];
                let angle = match self.screen_rotation {
                    Some(sign) => {
                        let v0 = self.start_pointer - self.start_pivot_screen;
                        let v1 = pointer - self.start_pivot_screen;
                        // Screen y points down, so a counter-clockwise turn on screen is negative.
                        -sign * v0.angle_to(v1)
                    }
                    None => {
                        let v0 = plane_hit(p, a, self.start_ray)? - p;
                        let v1 = plane_hit(p, a, ray)? - p;
                        a.dot(v0.cross(v1)).atan2(v0.dot(v1))
                    }
                };
                let angle = if snapping {
                    snap(angle, settings.angle_step_deg.to_radians())
                } else {
                    angle
                };
                DragResult {
                    delta: about_pivot(Affine3A::from_axis_angle(a, angle)),
                    amount: angle.to_degrees(),
                }
            }
            Handle::ScaleAxis(i) => {
                let a = f.axes[i];
                let t0 = line_parameter(p, a, self.start_ray)?;
                let t1 = line_parameter(p, a, ray)?;
                if t0.abs() < 1e-6 {
                    return None;
                }
                let mut factor = t1 / t0;
                if snapping {
                    factor = snap(factor, settings.scale_step);
                }
                let factor = clamp_factor(factor);
                // Scale along `a` only, in the frame of the axes.
                let basis = Mat3::from_cols(f.axes[0], f.axes[1], f.axes[2]);
                let mut s = Vec3::ONE;
                s[i] = factor;
                let m = basis * Mat3::from_diagonal(s) * basis.inverse();
                DragResult {
                    delta: about_pivot(Affine3A::from_mat3(m)),
                    amount: factor,
                }
            }
            Handle::ScaleUniform => {
                let d0 = (self.start_pointer - self.start_pivot_screen).length();
                let d1 = (pointer - self.start_pivot_screen).length();
                let mut factor = if d0 < 1.0 { 1.0 } else { d1 / d0 };
                if snapping {
                    factor = snap(factor, settings.scale_step);
                }
                let factor = clamp_factor(factor);
                DragResult {
                    delta: about_pivot(Affine3A::from_scale(Vec3::splat(factor))),
                    amount: factor,
                }
            }
        })
    }

    /// Each target's id and local transform after `delta`.
    pub fn transforms(
        &self,
        delta: Affine3A,
    ) -> Vec<(treelight_document::values::object::SceneId, Transform)> {
        self.targets
            .iter()
            .map(|t| (t.id, t.local_after(delta)))
            .collect()
    }
}

/// Keeps a scale factor away from zero (a collapsed object cannot be scaled back).
fn clamp_factor(f: f32) -> f32 {
    if f.abs() < 0.01 {
        0.01_f32.copysign(if f == 0.0 { 1.0 } else { f })
    } else {
        f
    }
}

/// The drag in progress, if any, shared by the viewport (which starts, updates and ends it) and the
/// Escape key (which cancels it).
#[derive(Resource, Default)]
pub struct ActiveDrag(pub Option<GizmoDrag>);

/// Cancel (Escape) during a drag puts the objects back and makes no history step; the key then
/// does nothing else this frame.
pub fn cancel_drag_on_escape(
    mut chords: ResMut<KeyChords>,
    mut drag: ResMut<ActiveDrag>,
    mut requests: ResMut<EditRequests>,
) {
    if drag.0.is_some() && chords.triggered(Action::Cancel) {
        drag.0 = None;
        requests.0.push(EditRequest::CancelPreview);
        chords.consume();
    }
}

/// The mode keys choose the gizmo's handles (not while a text field has the keyboard).
pub fn gizmo_mode_keys(
    chords: Res<KeyChords>,
    mut contexts: bevy_egui::EguiContexts,
    mut settings: ResMut<GizmoSettings>,
    history: Res<EditHistory>,
) {
    if chords.current.is_none()
        || history.previewing()
        || !crate::editor::core::key_chords::keyboard_is_free(&mut contexts)
    {
        return;
    }
    for (key, mode) in [
        (Action::MoveMode, GizmoMode::Translate),
        (Action::RotateMode, GizmoMode::Rotate),
        (Action::ScaleMode, GizmoMode::Scale),
    ] {
        if chords.triggered(key) && settings.mode != mode {
            settings.mode = mode;
        }
    }
}

/// The gizmo's settings, the drag in progress and their keys.
pub struct GizmoPlugin;

impl Plugin for GizmoPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<GizmoSettings>()
            .init_resource::<ActiveDrag>()
            .add_systems(
                Update,
                (cancel_drag_on_escape, gizmo_mode_keys)
                    .before(treelight_document::edit::history::apply_edit_requests),
            );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pinhole camera at `eye` looking down -z, 800 × 600 logical pixels, 60° vertical field.
    struct Pinhole {
        eye: Vec3,
    }

    impl ViewProjection for Pinhole {
        fn project(&self, w: Vec3) -> Option<Vec2> {
            let v = w - self.eye;
            if v.z >= -1e-4 {
                return None;
            }
            let f = 300.0 / (30f32.to_radians()).tan();
            Some(Vec2::new(400.0 + f * v.x / -v.z, 300.0 - f * v.y / -v.z))
        }
        fn ray(&self, s: Vec2) -> Option<Ray3d> {
            let f = 300.0 / (30f32.to_radians()).tan();
            let d = Vec3::new((s.x - 400.0) / f, -(s.y - 300.0) / f, -1.0);
            Some(Ray3d::new(self.eye, Dir3::new(d).ok()?))
        }
    }

    fn view() -> Pinhole {
        Pinhole {
            eye: Vec3::new(0.0, 0.0, 10.0),
        }
    }

    fn frame(axes: [Vec3; 3]) -> GizmoFrame {
        GizmoFrame::new(Vec3::ZERO, axes, &view()).unwrap()
    }

    const WORLD: [Vec3; 3] = [Vec3::X, Vec3::Y, Vec3::Z];

    #[test]
    fn the_gizmo_keeps_its_size_on_screen() {
        let f = frame(WORLD);
        let v = view();
        let tip = v.project(f.pivot + f.axes[0] * f.size).unwrap();
        let centre = v.project(f.pivot).unwrap();
        assert!((tip.distance(centre) - ARM_PIXELS).abs() < 0.5);
    }

    #[test]
    fn handles_are_picked_where_they_are_drawn() {
        let f = frame(WORLD);
        let v = view();
        let centre = v.project(Vec3::ZERO).unwrap();
        // Halfway along the x arrow, and a few pixels off it.
        let on_x = centre + Vec2::new(ARM_PIXELS * 0.7, 3.0);
        assert_eq!(
            f.pick(GizmoMode::Translate, &v, on_x),
            Some(Handle::Axis(0))
        );
        let on_y = centre + Vec2::new(-2.0, -ARM_PIXELS * 0.8);
        assert_eq!(
            f.pick(GizmoMode::Translate, &v, on_y),
            Some(Handle::Axis(1))
        );
        // Inside the square between x and y (the plane normal to z).
        let in_xy = centre + Vec2::new(ARM_PIXELS * 0.35, -ARM_PIXELS * 0.35);
        assert_eq!(
            f.pick(GizmoMode::Translate, &v, in_xy),
            Some(Handle::Plane(2))
        );
        let far = centre + Vec2::new(-60.0, 60.0);
        assert_eq!(f.pick(GizmoMode::Translate, &v, far), None);
        // The z ring faces the camera: a circle of the arm's radius.
        let on_ring = centre + Vec2::new(1.0, 1.0).normalize() * ARM_PIXELS;
        assert_eq!(
            f.pick(GizmoMode::Rotate, &v, on_ring),
            Some(Handle::Ring(2))
        );
        assert_eq!(
            f.pick(GizmoMode::Scale, &v, centre),
            Some(Handle::ScaleUniform)
        );
    }

    fn drag(handle: Handle, axes: [Vec3; 3], from: Vec2, to: Vec2, snap: bool) -> DragResult {
        let v = view();
        let d = GizmoDrag::start(handle, frame(axes), from, &v, Vec::new()).unwrap();
        d.result(to, &v, &GizmoSettings::default(), snap).unwrap()
    }

    #[test]
    fn an_axis_drag_moves_along_the_axis_only() {
        let v = view();
        let c = v.project(Vec3::ZERO).unwrap();
        let r = drag(
            Handle::Axis(0),
            WORLD,
            c + Vec2::new(50.0, 0.0),
            c + Vec2::new(150.0, 40.0),
            false,
        );
        let moved = r.delta.translation;
        assert!(moved.x > 0.5 && moved.y == 0.0 && moved.z == 0.0, "{moved}");
        // Along the axis on screen, the grabbed point stays under the pointer: where the rays
        // through the two pointer positions cross the axis (at depth 10, z = 0).
        let r = drag(
            Handle::Axis(0),
            WORLD,
            c + Vec2::new(50.0, 0.0),
            c + Vec2::new(150.0, 0.0),
            false,
        );
        let at_axis = |x: f32| {
            let ray = v.ray(c + Vec2::new(x, 0.0)).unwrap();
            ray.get_point(10.0 / -ray.direction.z).x
        };
        let expected = at_axis(150.0) - at_axis(50.0);
        assert!((r.delta.translation.x - expected).abs() < 1e-4);
        // Snapped to the grid.
        let r = drag(
            Handle::Axis(0),
            WORLD,
            c + Vec2::new(50.0, 0.0),
            c + Vec2::new(150.0, 0.0),
            true,
        );
        let x = r.delta.translation.x;
        assert!(((x / 0.25).round() * 0.25 - x).abs() < 1e-5 && x > 0.0);
    }

    #[test]
    fn a_local_axis_drag_follows_the_tilted_axis() {
        let v = view();
        let c = v.project(Vec3::ZERO).unwrap();
        let tilt = Quat::from_rotation_z(0.5);
        let axes = [tilt * Vec3::X, tilt * Vec3::Y, Vec3::Z];
        let r = drag(
            Handle::Axis(0),
            axes,
            c + Vec2::new(40.0, -20.0),
            c + Vec2::new(120.0, -60.0),
            false,
        );
        let moved = Vec3::from(r.delta.translation);
        assert!(moved.length() > 0.1);
        assert!(moved.normalize().dot(axes[0]) > 0.99999, "{moved}");
    }

    #[test]
    fn a_ring_drag_turns_about_its_axis() {
        let v = view();
        let c = v.project(Vec3::ZERO).unwrap();
        // A quarter turn on screen about the z ring (facing the camera): from +x to +y (screen up).
        let r = drag(
            Handle::Ring(2),
            WORLD,
            c + Vec2::new(90.0, 0.0),
            c + Vec2::new(0.0, -90.0),
            false,
        );
        let turned = r.delta.transform_vector3(Vec3::X);
        assert!(turned.distance(Vec3::Y) < 1e-3, "{turned}");
        assert!((r.amount - 90.0).abs() < 0.1);
        // Snapped: 40° becomes 45°.
        let a = 40f32.to_radians();
        let to = c + Vec2::new(a.cos(), -a.sin()) * 90.0;
        let r = drag(Handle::Ring(2), WORLD, c + Vec2::new(90.0, 0.0), to, true);
        assert!((r.amount - 45.0).abs() < 1e-3, "{}", r.amount);
        // The y ring is edge-on: the pointer's angle about the pivot turns it.
        let r = drag(
            Handle::Ring(1),
            WORLD,
            c + Vec2::new(90.0, 0.0),
            c + Vec2::new(0.0, -90.0),
            false,
        );
        assert!((r.amount.abs() - 90.0).abs() < 0.1, "{}", r.amount);
    }

    #[test]
    fn scale_handles_scale_about_the_pivot() {
        let v = view();
        let c = v.project(Vec3::ZERO).unwrap();
        let r = drag(
            Handle::ScaleAxis(1),
            WORLD,
            c + Vec2::new(0.0, -45.0),
            c + Vec2::new(0.0, -90.0),
            false,
        );
        assert!((r.amount - 2.0).abs() < 1e-3);
        assert!(
            r.delta
                .transform_vector3(Vec3::ONE)
                .distance(Vec3::new(1.0, 2.0, 1.0))
                < 1e-3
        );
        let r = drag(
            Handle::ScaleUniform,
            WORLD,
            c + Vec2::new(20.0, 0.0),
            c + Vec2::new(0.0, 30.0),
            false,
        );
        assert!((r.amount - 1.5).abs() < 1e-4);
        // Never to zero.
        let r = drag(
            Handle::ScaleUniform,
            WORLD,
            c + Vec2::new(20.0, 0.0),
            c,
            false,
        );
        assert!(r.amount >= 0.01);
    }

    #[test]
    fn a_child_of_a_rotated_stretched_parent_moves_exactly_along_the_world_axis() {
        let parent = Affine3A::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.0),
            Quat::from_rotation_y(0.7) * Quat::from_rotation_x(0.3),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let child_local =
            Transform::from_xyz(0.3, -0.2, 0.5).with_rotation(Quat::from_rotation_z(0.4));
        let start_world = parent * child_local.compute_affine();
        let target = DragTarget {
            id: treelight_document::values::object::SceneId(1),
            start_world,
            parent_world: parent,
        };
        let delta = Affine3A::from_translation(Vec3::new(0.75, 0.0, 0.0));
        let local = target.local_after(delta);
        let after = parent * local.compute_affine();
        let moved = Vec3::from(after.translation - start_world.translation);
        assert!(moved.distance(Vec3::new(0.75, 0.0, 0.0)) < 1e-5, "{moved}");
        // Orientation unchanged.
        assert!(after.matrix3.abs_diff_eq(start_world.matrix3, 1e-5));
    }
}
