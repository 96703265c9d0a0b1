//! The scene's look in the viewport: the toolbar's exposure, tone-curve and sky controls, which edit
//! the document's [`SceneLook`] through commands (one scrub is one step), and the systems that put
//! it on the 3D camera (so the raster view and the path tracer show the same exposure and curve) and
//! the sky into the path tracer's settings.

use crate::editor::viewport::camera::OrbitCamera;
use crate::editor::widget_rects::WidgetRects;
use bevy::camera::Exposure;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy_egui::egui;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::EditRequest;
use treelight_document::look::{MAX_EXPOSURE_STOPS, SceneLook, ToneCurve};

/// Bevy's tonemapper for a curve.
pub fn tonemapping(curve: ToneCurve) -> Tonemapping {
    match curve {
        ToneCurve::Filmic => Tonemapping::TonyMcMapface,
        ToneCurve::AgX => Tonemapping::AgX,
        ToneCurve::Neutral => Tonemapping::KhronosPbrNeutral,
        ToneCurve::Aces => Tonemapping::AcesFitted,
        ToneCurve::Reinhard => Tonemapping::ReinhardLuminance,
        ToneCurve::None => Tonemapping::None,
    }
}

/// Puts the document's look on the viewport camera (when it changes, or the camera is new).
pub fn apply_look(
    look: Res<SceneLook>,
    mut cameras: Query<(&mut Exposure, &mut Tonemapping), With<OrbitCamera>>,
    added: Query<(), Added<OrbitCamera>>,
) {
    if !look.is_changed() && added.is_empty() {
        return;
    }
    for (mut exposure, mut curve) in &mut cameras {
        let ev100 = look.ev100();
        if exposure.ev100 != ev100 {
            exposure.ev100 = ev100;
        }
        curve.set_if_neq(tonemapping(look.tone));
    }
}

/// The document's sky in the viewport's path-tracer settings (which every traced view of the
/// editor starts from).
pub fn sky_to_tracer(
    look: Res<SceneLook>,
    mut render: ResMut<crate::editor::viewport::render_mode::ViewportRender>,
) {
    if look.is_changed() {
        render.settings.sky = look.sky_radiance();
    }
}

/// The toolbar's look controls: exposure in stops (drag or type; double-click resets) and the tone
/// curve, named "Exposure" and "Tone curve" in `widgets`. Returns the requests for what the user
/// changed.
pub fn look_controls(
    ui: &mut egui::Ui,
    look: &SceneLook,
    widgets: &mut WidgetRects,
) -> Vec<EditRequest> {
    let mut out = Vec::new();
    let mut exposure = look.exposure;
    let response = ui
        .add(
            egui::DragValue::new(&mut exposure)
                .speed(0.02)
                .range(-MAX_EXPOSURE_STOPS..=MAX_EXPOSURE_STOPS)
                .fixed_decimals(1)
                .prefix("Exposure ")
                .suffix(" EV"),
        )
        .on_hover_text(
            "Exposure compensation in stops: +1 doubles the picture's brightness (double-click to reset)",
        );
    widgets.push("Exposure", response.rect);
    if response.double_clicked() {
        exposure = 0.0;
    }
    if exposure != look.exposure {
        out.push(EditRequest::Apply {
            command: EditCommand::SetLook {
                look: SceneLook { exposure, ..*look },
            },
            // A drag or typing after its first change continues the same step.
            continuing: (response.dragged() && !response.drag_started()) || response.has_focus(),
        });
    }
    let mut tone = look.tone;
    let combo = egui::ComboBox::from_id_salt("tone-curve")
        .selected_text(tone.label())
        .show_ui(ui, |ui| {
            for curve in ToneCurve::ALL {
                let item = ui.selectable_value(&mut tone, curve, curve.label());
                widgets.push(format!("Tone curve {}", curve.label()), item.rect);
            }
        })
        .response
        .on_hover_text("The tone curve that maps the exposed light to the screen");
    widgets.push("Tone curve", combo.rect);
    // The sky as a colour and a strength in nits (the look stores their product).
    let strength = look.sky.iter().copied().fold(0.0f32, f32::max);
    let mut colour = if strength > 0.0 {
        look.sky.map(|c| c / strength)
    } else {
        [1.0; 3]
    };
    let mut new_strength = strength;
    let mut sky_continuing = false;
    let sky = ui
        .menu_button("Sky", |ui| {
            ui.label("What rays leaving the scene meet: it lights the scene and is seen behind it");
            ui.horizontal(|ui| {
                ui.label("Colour");
                let c = ui.color_edit_button_rgb(&mut colour);
                ui.label("Strength");
                let s = ui.add(
                    egui::DragValue::new(&mut new_strength)
                        .speed((strength * 0.01).max(0.1))
                        .range(0.0..=treelight_document::look::MAX_SKY)
                        .max_decimals(1)
                        .suffix(" nits"),
                );
                widgets.push("Sky strength", s.rect);
                sky_continuing = (s.dragged() && !s.drag_started())
                    || s.has_focus()
                    || c.is_pointer_button_down_on();
            });
        })
        .response
        .on_hover_text("The sky's colour and brightness");
    widgets.push("Sky", sky.rect);
    let new_sky = colour.map(|c| c * new_strength);
    if new_strength != strength || (strength > 0.0 && colour != look.sky.map(|c| c / strength)) {
        out.push(EditRequest::Apply {
            command: EditCommand::SetLook {
                look: SceneLook {
                    sky: new_sky,
                    ..*look
                },
            },
            continuing: sky_continuing,
        });
    }
    if tone != look.tone {
        out.push(EditRequest::Apply {
            command: EditCommand::SetLook {
                look: SceneLook { tone, ..*look },
            },
            continuing: false,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_curve_has_its_own_tonemapper() {
        let mut seen: Vec<Tonemapping> = ToneCurve::ALL.map(tonemapping).to_vec();
        seen.dedup();
        assert_eq!(seen.len(), ToneCurve::ALL.len());
        assert_eq!(tonemapping(ToneCurve::default()), Tonemapping::default());
    }
}
