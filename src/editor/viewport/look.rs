//! The scene's look in the viewport: the toolbar's exposure and tone-curve controls, which edit
//! the document's [`SceneLook`] through commands (one scrub is one step), and the system that puts
//! it on the 3D camera, so the raster view and the path tracer show the same exposure and curve.

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
