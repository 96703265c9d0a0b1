//! The scene's look in the viewport: the toolbar's exposure, tone-curve and sky controls (a colour,
//! or an HDR panorama turned, scaled, shown or hidden), which edit the document's [`SceneLook`] and
//! [`SceneEnvironment`] through commands (one scrub is one step), and the systems that put the look
//! on the 3D camera (so the raster view and the path tracer show the same exposure and curve) and
//! the sky into the path tracer's settings.

use crate::editor::core::file_requests::{FileAction, FileChosen, FileRequest};
use crate::editor::core::view::OrbitCamera;
use crate::editor::core::widget_rects::WidgetRects;
use bevy::camera::Exposure;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy_egui::egui;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::EditRequest;
use treelight_document::scene::environment::{
    LoadedEnvironment, MAX_ENVIRONMENT_INTENSITY, SceneEnvironment,
};
use treelight_document::values::look::{MAX_EXPOSURE_STOPS, SceneLook, ToneCurve};
use treelight_render::PathTracedEnvironment;

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
    mut render: ResMut<crate::editor::core::viewport_render::ViewportRender>,
) {
    if look.is_changed() {
        render.settings.sky = look.sky_radiance();
    }
}

/// The document's panorama, once read, in the path tracer's environment (every traced view of the
/// app: the viewport's, a render's).
pub fn environment_to_tracer(
    environment: Res<SceneEnvironment>,
    loaded: Res<LoadedEnvironment>,
    mut tracer: ResMut<PathTracedEnvironment>,
) {
    if !environment.is_changed() && !loaded.is_changed() {
        return;
    }
    tracer.set_if_neq(PathTracedEnvironment {
        image: environment.image.as_ref().and(loaded.image.clone()),
        rotation: environment.rotation_radians(),
        intensity: environment.intensity,
        shown: environment.shown,
    });
}

/// Asks the File feature for a panorama when the sky menu's Choose… was clicked (its dialog starts
/// in the folder of the panorama in use).
pub fn ask_for_panorama(
    actions: Res<crate::editor::viewport::actions::ViewportActions>,
    environment: Res<SceneEnvironment>,
    mut files: MessageWriter<FileRequest>,
) {
    if actions.choose_panorama {
        files.write(FileRequest(FileAction::ChoosePanorama(
            environment.image.clone(),
        )));
    }
}

/// Turns the panorama chosen into the scene's sky (keeping its rotation, intensity and
/// visibility).
pub fn take_chosen_panorama(
    mut chosen: MessageReader<FileChosen>,
    environment: Res<SceneEnvironment>,
    mut requests: ResMut<treelight_document::edit::history::EditRequests>,
) {
    for chosen in chosen.read() {
        let FileChosen::Panorama(image) = chosen else {
            continue;
        };
        requests.0.push(EditRequest::Apply {
            command: EditCommand::SetEnvironment {
                environment: SceneEnvironment {
                    image: Some(image.clone()),
                    ..environment.clone()
                },
            },
            continuing: false,
        });
    }
}

/// What the toolbar's look controls ask for.
#[derive(Default)]
pub struct LookEdits {
    /// Edit requests for what the user changed.
    pub requests: Vec<EditRequest>,
    /// Whether the user asked to choose a sky panorama file.
    pub choose_panorama: bool,
}

/// The toolbar's look controls: exposure in stops (drag or type; double-click resets), the tone
/// curve, and the sky (a colour and strength, or a panorama with its rotation, intensity and
/// visibility), named "Exposure", "Tone curve", "Sky" and the sky menu's entries in `widgets`.
pub fn look_controls(
    ui: &mut egui::Ui,
    look: &SceneLook,
    environment: &SceneEnvironment,
    widgets: &mut WidgetRects,
) -> LookEdits {
    let mut out = Vec::new();
    let mut choose_panorama = false;
    let mut new_environment = environment.clone();
    let mut environment_continuing = false;
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
    let mut colour_changed = false;
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
                        .range(0.0..=treelight_document::values::look::MAX_SKY)
                        .max_decimals(1)
                        .suffix(" nits"),
                );
                widgets.push("Sky strength", s.rect);
                sky_continuing = (s.dragged() && !s.drag_started())
                    || s.has_focus()
                    || c.is_pointer_button_down_on();
                colour_changed = c.changed();
            });
            ui.separator();
            environment_continuing = panorama_controls(
                ui,
                environment,
                &mut new_environment,
                &mut choose_panorama,
                widgets,
            );
        })
        .response
        .on_hover_text("The sky's colour and brightness");
    widgets.push("Sky", sky.rect);
    let new_sky = colour.map(|c| c * new_strength);
    // The colour button gives back the colour through its own conversions: only a change the
    // user made counts (opening the menu once made a step of its own).
    if new_strength != strength || colour_changed {
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
    if new_environment != *environment {
        out.push(EditRequest::Apply {
            command: EditCommand::SetEnvironment {
                environment: new_environment,
            },
            continuing: environment_continuing,
        });
    }
    LookEdits {
        requests: out,
        choose_panorama,
    }
}

/// The sky menu's panorama: its file (choose, remove), rotation, intensity and whether it is
/// seen. Edits `edited`; returns whether a scrub continues.
fn panorama_controls(
    ui: &mut egui::Ui,
    environment: &SceneEnvironment,
    edited: &mut SceneEnvironment,
    choose: &mut bool,
    widgets: &mut WidgetRects,
) -> bool {
    ui.label("Or an HDR panorama (.hdr, .exr): it lights the scene in place of the colour");
    let mut continuing = false;
    ui.horizontal(|ui| {
        let name = environment.image.as_deref().map_or("None".into(), |p| {
            p.file_name()
                .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into())
        });
        ui.label(format!("Panorama: {name}"));
        let pick = ui
            .button("Choose…")
            .on_hover_text("Choose an HDR panorama file");
        widgets.push("Choose panorama", pick.rect);
        *choose |= pick.clicked();
        if environment.image.is_some() {
            let remove = ui
                .button("Remove")
                .on_hover_text("Light the scene with the colour again");
            widgets.push("Remove panorama", remove.rect);
            if remove.clicked() {
                edited.image = None;
            }
        }
    });
    if environment.image.is_none() {
        return false;
    }
    ui.horizontal(|ui| {
        ui.label("Rotation");
        let r = ui.add(
            egui::DragValue::new(&mut edited.rotation_degrees)
                .speed(1.0)
                .range(-180.0..=180.0)
                .max_decimals(1)
                .suffix("°"),
        );
        widgets.push("Panorama rotation", r.rect);
        ui.label("Intensity");
        let i = ui
            .add(
                egui::DragValue::new(&mut edited.intensity)
                    .speed((environment.intensity * 0.01).max(1.0))
                    .range(0.0..=MAX_ENVIRONMENT_INTENSITY)
                    .max_decimals(1)
                    .suffix(" nits"),
            )
            .on_hover_text("The brightness of a panorama value of 1");
        widgets.push("Panorama intensity", i.rect);
        continuing = [&r, &i]
            .iter()
            .any(|w| (w.dragged() && !w.drag_started()) || w.has_focus());
    });
    let shown = ui
        .checkbox(&mut edited.shown, "Show behind the scene")
        .on_hover_text(
            "Hidden, the sky colour is seen behind the scene, while the panorama still lights it",
        );
    widgets.push("Show panorama", shown.rect);
    continuing
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
