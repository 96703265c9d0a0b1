//! The viewport: its tab ([`tab`], drawn by [`panel`]) and what is done there ([`actions`]: picking
//! and placing), the orbit camera ([`camera`]), the transform gizmo ([`gizmo`]), selecting
//! ([`selection`]), the render mode ([`render_mode`]) and the look ([`look`]: exposure and tone
//! curve; [`sky_box`]: the sky panorama behind the raster view), and files dropped on the window
//! ([`drop`](mod@drop), [`x11_pointer`]). What it shares with the other features (the selection,
//! the camera's parameters, the render settings) lives in [`crate::editor::core`].

pub mod actions;
pub mod camera;
pub mod drop;
pub mod gizmo;
pub mod look;
pub mod map_transforms;
pub mod panel;
pub mod render_mode;
pub mod selection;
pub mod sky_box;
pub mod tab;
pub mod x11_pointer;

use crate::editor::core::ui_order::UiStep;
use bevy::prelude::*;

/// The camera, the gizmo, the selection, the render mode and drops on the window.
pub struct ViewportPlugin;

impl Plugin for ViewportPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins((
            camera::CameraPlugin,
            gizmo::GizmoPlugin,
            selection::SelectionPlugin,
        ))
        .init_resource::<tab::ViewportRect>()
        .init_resource::<panel::ViewportInteraction>()
        .init_resource::<actions::ViewportActions>()
        .init_resource::<sky_box::SkyBoxCube>()
        .add_plugins(sky_box::SkyLightPlugin)
        .add_systems(Startup, render_mode::adapt_to_adapter)
        .add_systems(
            Update,
            (
                drop::import_dropped_files,
                render_mode::fall_back_when_too_large.before(render_mode::apply_viewport_render),
                look::sky_to_tracer.before(render_mode::apply_viewport_render),
                render_mode::apply_viewport_render,
                render_mode::report_texture_downsizing,
                look::apply_look,
                look::environment_to_tracer,
                map_transforms::map_transforms_to_tracer,
                sky_box::make_sky_box,
                sky_box::sky_box_to_camera.after(sky_box::make_sky_box),
                tab::fit_camera_viewport,
            ),
        )
        .add_systems(
            Last,
            sky_box::sky_box_activity.in_set(crate::editor::core::rest::ActivitySources),
        )
        .add_systems(
            bevy_egui::EguiPrimaryContextPass,
            (
                look::ask_for_panorama.in_set(UiStep::Menus),
                (look::take_chosen_panorama, actions::apply_viewport_actions)
                    .chain()
                    .in_set(UiStep::Viewport),
            ),
        );
    }
}
