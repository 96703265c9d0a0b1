//! The viewport tab as a system: gathers what the viewport shows (the selection's boxes, icons, the
//! drag's targets), draws it with [`ViewportPanel`] and keeps what the user did for
//! [`super::actions`]; writes back the camera's orbit, the render mode, the gizmo's settings and
//! where the panel is, which the 3D camera's viewport follows ([`fit_camera_viewport`]).

use crate::editor::core::gizmo_settings::GizmoSettings;
use crate::editor::core::key_chords::KeyChords;
use crate::editor::core::keymap::Action;
use crate::editor::core::object_item::{Objects, parent_of};
use crate::editor::core::selection::Selection;
use crate::editor::core::view::OrbitCamera;
use crate::editor::core::viewport_render::ViewportRender;
use crate::editor::core::widget_rects::WidgetRects;
use crate::editor::viewport::actions::ViewportActions;
use crate::editor::viewport::camera::world_bounds;
use crate::editor::viewport::gizmo::ActiveDrag;
use crate::editor::viewport::panel::{
    IconKind, ViewportInteraction, ViewportPanel, ViewportScene, drag_targets,
};
use bevy::camera::Viewport;
use bevy::camera::primitives::Aabb;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_egui::egui;
use treelight_document::scene::placement::box_corners;
use treelight_document::values::look::SceneLook;

/// Where the viewport panel is, in physical pixels, for the 3D camera.
#[derive(Resource, Debug, Default, Clone, Copy, PartialEq)]
pub struct ViewportRect {
    /// Top-left corner.
    pub position: UVec2,
    /// Size; zero while the panel is hidden.
    pub size: UVec2,
}

/// What the viewport reads of the scene.
#[derive(SystemParam)]
pub struct SceneView<'w, 's> {
    selection: Res<'w, Selection>,
    objects: Objects<'w, 's>,
    boxes: Query<'w, 's, (&'static Aabb, &'static GlobalTransform)>,
    children: Query<'w, 's, &'static Children>,
    cameras: Query<'w, 's, (&'static Camera, &'static GlobalTransform), With<OrbitCamera>>,
    look: Res<'w, SceneLook>,
    environment: Res<'w, treelight_document::scene::environment::SceneEnvironment>,
    tracer: Option<Res<'w, treelight_render::PathTracerStats>>,
}

/// What the viewport changes.
#[derive(SystemParam)]
pub struct ViewportState<'w, 's> {
    orbit: Query<'w, 's, &'static mut OrbitCamera>,
    render: ResMut<'w, ViewportRender>,
    gizmo: ResMut<'w, GizmoSettings>,
    drag: ResMut<'w, ActiveDrag>,
    interaction: ResMut<'w, ViewportInteraction>,
    actions: ResMut<'w, ViewportActions>,
    rect: ResMut<'w, ViewportRect>,
    widgets: ResMut<'w, WidgetRects>,
    window: Single<'w, 's, &'static Window, With<PrimaryWindow>>,
    chords: Res<'w, KeyChords>,
}

/// Draws the viewport tab into `ui`.
pub fn viewport_tab(InMut(ui): InMut<egui::Ui>, view: SceneView, state: ViewportState) {
    let ViewportState {
        mut orbit,
        mut render,
        mut gizmo,
        mut drag,
        mut interaction,
        mut actions,
        rect: mut viewport_rect,
        mut widgets,
        window,
        chords,
    } = state;
    // The path tracer outlines the selected meshes' silhouettes itself
    // (selection::outline_selected_meshes); the rasteriser gets their boxes.
    let mut scene = viewport_scene(&view, render.traced.is_none());
    if render.traced.is_some()
        && let Some(kernel) = view
            .tracer
            .as_ref()
            .and_then(|t| t.preparing_kernel())
            .filter(|k| k.noticeable())
    {
        scene.waiting = Some(if kernel.split {
            "Preparing the path tracer for a large scene: the first time on this machine, minutes"
        } else {
            "Preparing the path tracer: the first time on this machine, up to a minute"
        });
    }
    let mut orbit_copy = orbit.single().ok().copied();
    let mut render_copy = *render;
    let mut gizmo_copy = *gizmo;
    let mut rect = egui::Rect::NOTHING;
    let mut done = ViewportActions::default();
    ViewportPanel {
        scene: &scene,
        orbit: orbit_copy.as_mut(),
        render: &mut render_copy,
        gizmo: &mut gizmo_copy,
        look: &view.look,
        environment: &view.environment,
        widgets: &mut widgets,
        drag: &mut drag.0,
        interaction: &mut interaction,
        rect: &mut rect,
        actions: &mut done,
        cancel: chords.triggered(Action::Cancel),
    }
    .ui(ui);
    *actions = done;
    render.set_if_neq(render_copy);
    gizmo.set_if_neq(gizmo_copy);
    if let (Ok(mut o), Some(copy)) = (orbit.single_mut(), orbit_copy) {
        o.set_if_neq(copy);
    }
    let scale = window.scale_factor();
    let physical = if rect.is_positive() {
        ViewportRect {
            position: UVec2::new((rect.min.x * scale) as u32, (rect.min.y * scale) as u32),
            size: UVec2::new(
                (rect.width() * scale) as u32,
                (rect.height() * scale) as u32,
            ),
        }
    } else {
        ViewportRect::default()
    };
    viewport_rect.set_if_neq(physical);
}

/// Gathers what the viewport draws (the selection's boxes, when `show_boxes`; icons) and what a
/// drag moves.
fn viewport_scene(view: &SceneView, show_boxes: bool) -> ViewportScene {
    let SceneView {
        selection,
        objects,
        boxes,
        children,
        cameras,
        ..
    } = view;
    let mut out = ViewportScene {
        camera: cameras.single().ok().map(|(c, g)| (c.clone(), *g)),
        ..default()
    };
    let active = selection.active();
    for &e in selection.entities().iter().filter(|_| show_boxes) {
        let Ok(o) = objects.get(e) else {
            continue;
        };
        let is_active = Some(e) == active;
        // A mesh shows its own box, turned with it; a group the box around everything under it.
        if o.mesh.is_some()
            && let Ok((aabb, gt)) = boxes.get(e)
        {
            let (c, h) = (Vec3::from(aabb.center), Vec3::from(aabb.half_extents));
            out.outlines.push((
                box_corners(c - h, c + h).map(|p| gt.transform_point(p)),
                is_active,
            ));
        } else if let Some((min, max)) = world_bounds(e, boxes, children) {
            out.outlines.push((box_corners(min, max), is_active));
        }
    }
    (out.targets, out.active_world) = drag_targets(
        selection,
        |e| objects.get(e).ok().map(|o| (*o.id, o.global.affine())),
        |e| parent_of(objects, e),
    );
    for o in objects.iter() {
        let kind = if let Some(light) = o.light_kind() {
            IconKind::Light(light)
        } else if o.camera {
            IconKind::Camera
        } else if o.mesh.is_none() {
            IconKind::Empty
        } else {
            continue;
        };
        out.icons.push((
            o.entity,
            o.global.translation(),
            kind,
            selection.contains(o.entity),
        ));
    }
    out
}

/// Fits the 3D camera's viewport to the viewport panel.
pub fn fit_camera_viewport(
    rect: Res<ViewportRect>,
    window: Single<&Window, With<PrimaryWindow>>,
    mut cameras: Query<&mut Camera, With<OrbitCamera>>,
) {
    let max = UVec2::new(window.physical_width(), window.physical_height());
    for mut camera in &mut cameras {
        let pos = rect.position.min(max);
        let size = rect.size.min(max.saturating_sub(pos));
        camera.is_active = size.x > 0 && size.y > 0;
        let size = size.max(UVec2::ONE);
        let same = camera
            .viewport
            .as_ref()
            .is_some_and(|v| v.physical_position == pos && v.physical_size == size);
        if !same {
            camera.viewport = Some(Viewport {
                physical_position: pos,
                physical_size: size,
                ..default()
            });
        }
    }
}
