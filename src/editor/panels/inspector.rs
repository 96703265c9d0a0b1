//! The inspector: the active object's name, transform, material and light. Every change leaves as
//! a command; the changes of one drag of a field, or one text field's typing, continue one step.

use treelight_document::edit::command::EditCommand;

use treelight_document::edit::history::EditRequest;

use crate::editor::core::object_item::Objects;
use crate::editor::core::selection::Selection;
use crate::editor::core::widget_rects::WidgetRects;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy_egui::egui;
use bevy_egui::{EguiTextureHandle, EguiUserTextures};
use treelight_document::edit::command::{MaterialAlpha, MaterialValue};
use treelight_document::edit::history::EditRequests;
use treelight_document::values::light::{
    LightKind, LightParts, LightValue, candela_to_lumens, lumens_to_candela,
};
use treelight_document::values::object::SceneId;
use treelight_document::values::object::SceneObject;

/// The active object's material as the inspector shows it.
#[derive(Clone, PartialEq)]
pub struct MaterialView {
    /// Its values.
    pub value: MaterialValue,
    /// How many scene objects use it.
    pub users: usize,
    /// Its base-colour texture, registered with egui, and the texture's size in pixels.
    pub texture: Option<(egui::TextureId, UVec2)>,
}

/// Editable copy of the active object's properties; compared with the original after the UI, so
/// an untouched inspector sends nothing.
#[derive(Clone, PartialEq)]
pub struct InspectorState {
    /// The object.
    pub id: SceneId,
    /// Its name.
    pub name: String,
    /// Its position relative to its parent.
    pub translation: Vec3,
    /// Its rotation as Euler angles (Y, X, Z order), degrees.
    pub rotation_deg: Vec3,
    /// Its scale.
    pub scale: Vec3,
    /// Its material, for a mesh.
    pub material: Option<MaterialView>,
    /// Its light, for a light.
    pub light: Option<LightValue>,
    /// What camera it is, for a camera (glTF's): its projection in words.
    pub camera: Option<String>,
    /// Set when the user asks to look through it.
    pub look_through: bool,
    /// How many objects are selected.
    pub selected: usize,
}

impl InspectorState {
    /// The state of object `id` with `name` and local transform `t`.
    pub fn new(id: SceneId, name: &str, t: &Transform) -> Self {
        let (y, x, z) = t.rotation.to_euler(EulerRot::YXZ);
        Self {
            id,
            name: name.to_owned(),
            translation: t.translation,
            rotation_deg: Vec3::new(x, y, z).map(f32::to_degrees),
            scale: t.scale,
            material: None,
            light: None,
            camera: None,
            look_through: false,
            selected: 1,
        }
    }

    fn transform(&self) -> Transform {
        let r = self.rotation_deg.map(f32::to_radians);
        Transform {
            translation: self.translation,
            rotation: Quat::from_euler(EulerRot::YXZ, r.y, r.x, r.z),
            scale: self.scale,
        }
    }
}

/// The inspector panel. `make_unique` is set when the user asks for the material to be the
/// object's own.
pub fn inspector_ui(
    ui: &mut egui::Ui,
    state: Option<&mut InspectorState>,
    make_unique: &mut bool,
    widgets: &mut WidgetRects,
) {
    let Some(state) = state else {
        ui.weak("Select an object in the viewport or the outliner.");
        return;
    };
    if state.selected > 1 {
        ui.weak(format!(
            "{} objects selected; showing the active one.",
            state.selected
        ));
    }
    egui::Grid::new("inspector")
        .num_columns(2)
        .spacing([8.0, 6.0])
        .show(ui, |ui| {
            ui.label("Name");
            ui.text_edit_singleline(&mut state.name);
            ui.end_row();
            vec3_row(ui, "Translation", &mut state.translation, 0.05);
            vec3_row(ui, "Rotation (°)", &mut state.rotation_deg, 1.0);
            vec3_row(ui, "Scale", &mut state.scale, 0.01);
        });
    if let Some(light) = state.light.as_mut() {
        ui.separator();
        light_ui(ui, light, widgets);
    }
    if let Some(camera) = &state.camera {
        ui.separator();
        ui.strong("Camera");
        ui.label(camera);
        let button = ui
            .button("Look through")
            .on_hover_text("Put the viewport where this camera is, looking where it looks");
        widgets.push("Look through", button.rect);
        if button.clicked() {
            state.look_through = true;
        }
    }
    let Some(material) = state.material.as_mut() else {
        return;
    };
    ui.separator();
    ui.horizontal(|ui| {
        ui.strong("Material");
        if material.users > 1 {
            ui.weak(format!("shared by {} objects", material.users));
            if ui
                .button("Make unique")
                .on_hover_text(
                    "Give this object its own copy, so edits no longer change the others",
                )
                .clicked()
            {
                *make_unique = true;
            }
        }
    });
    material_ui(ui, material, widgets);
}

/// The material's values: base colour (with its texture), metallic, roughness, alpha, the
/// extensions' fractions, emission and sides.
fn material_ui(ui: &mut egui::Ui, material: &mut MaterialView, widgets: &mut WidgetRects) {
    let texture = material.texture;
    let v = &mut material.value;
    egui::Grid::new("material")
        .num_columns(2)
        .spacing([8.0, 6.0])
        .show(ui, |ui| {
            ui.label("Base colour");
            base_colour_ui(ui, v, texture);
            ui.end_row();
            ui.label("Metallic");
            ui.add(egui::Slider::new(&mut v.metallic, 0.0..=1.0));
            ui.end_row();
            ui.label("Roughness");
            ui.add(egui::Slider::new(&mut v.perceptual_roughness, 0.0..=1.0));
            ui.end_row();
            ui.label("Alpha");
            alpha_ui(ui, v, widgets);
            ui.end_row();
            let mut fraction =
                |ui: &mut egui::Ui, label: &str, value: &mut Option<f32>, hint: &str| {
                    ui.label(label);
                    let mut x = value.unwrap_or(0.0);
                    let slider = ui
                        .add(egui::Slider::new(&mut x, 0.0..=1.0))
                        .on_hover_text(hint);
                    widgets.push(format!("Material {}", label.to_lowercase()), slider.rect);
                    if slider.changed() {
                        *value = Some(x);
                    }
                    ui.end_row();
                };
            fraction(
                ui,
                "Transmission",
                &mut v.transmission,
                "Light the surface lets through a thin wall, tinted by the base colour (glass)",
            );
            fraction(
                ui,
                "Clear coat",
                &mut v.clearcoat,
                "A glossy varnish layer over the surface",
            );
            fraction(
                ui,
                "Coat roughness",
                &mut v.clearcoat_roughness,
                "How blurred the clear coat's reflection is",
            );
            ui.label("Emission");
            emission_ui(ui, v);
            ui.end_row();
            ui.label("Double-sided");
            ui.checkbox(&mut v.double_sided, "");
            ui.end_row();
        });
}

/// The base colour's picker, and its texture beside it.
fn base_colour_ui(
    ui: &mut egui::Ui,
    v: &mut MaterialValue,
    texture: Option<(egui::TextureId, UVec2)>,
) {
    ui.horizontal(|ui| {
        let [r, g, b, a] = v
            .base_color
            .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
        let mut srgba = egui::Color32::from_rgba_unmultiplied(r, g, b, a);
        if egui::color_picker::color_edit_button_srgba(
            ui,
            &mut srgba,
            egui::color_picker::Alpha::OnlyBlend,
        )
        .changed()
        {
            v.base_color = srgba.to_srgba_unmultiplied().map(|c| c as f32 / 255.0);
        }
        if let Some((texture, size)) = texture {
            let h = 48.0;
            let w = h * size.x as f32 / size.y.max(1) as f32;
            ui.add(egui::Image::new((texture, egui::vec2(w.min(160.0), h))))
                .on_hover_text(format!(
                    "Base-colour texture, {} × {} pixels; the colour multiplies it",
                    size.x, size.y
                ));
        }
    });
}

/// The alpha mode's menu (its items named in `widgets`), and a mask's cutoff.
fn alpha_ui(ui: &mut egui::Ui, v: &mut MaterialValue, widgets: &mut WidgetRects) {
    ui.horizontal(|ui| {
        let mut alpha = v.alpha.unwrap_or(MaterialAlpha::Opaque);
        let combo = egui::ComboBox::from_id_salt("material-alpha")
            .selected_text(alpha.label())
            .show_ui(ui, |ui| {
                for mode in MaterialAlpha::ALL {
                    let same = std::mem::discriminant(&alpha) == std::mem::discriminant(&mode);
                    let item = ui.selectable_label(same, mode.label());
                    if item.clicked() && !same {
                        alpha = mode;
                    }
                    widgets.push(format!("Material alpha {}", mode.label()), item.rect);
                }
            });
        widgets.push("Material alpha", combo.response.rect);
        if let MaterialAlpha::Mask(cutoff) = &mut alpha {
            ui.add(egui::Slider::new(cutoff, 0.0..=1.0).text("cutoff"))
                .on_hover_text("Parts whose alpha is below the cutoff are cut away");
        }
        if v.alpha.is_some() || alpha != MaterialAlpha::Opaque {
            v.alpha = Some(alpha);
        }
    });
}

/// Emission as a colour and a strength (the material stores their product).
fn emission_ui(ui: &mut egui::Ui, v: &mut MaterialValue) {
    let strength = v.emissive.iter().copied().fold(0.0f32, f32::max);
    let mut colour = if strength > 0.0 {
        v.emissive.map(|c| c / strength)
    } else {
        [1.0; 3]
    };
    let mut new_strength = strength;
    ui.horizontal(|ui| {
        ui.color_edit_button_rgb(&mut colour);
        ui.add(
            egui::DragValue::new(&mut new_strength)
                .speed(0.1)
                .range(0.0..=1.0e5)
                .prefix("strength "),
        );
    });
    if new_strength != strength || (strength > 0.0 && colour != v.emissive.map(|c| c / strength)) {
        v.emissive = colour.map(|c| c * new_strength);
    }
}

/// A light's kind, colour, intensity (in glTF's units: candela for point and spot lights, lux for
/// directional ones), range, cone and shadows; the kind menu and its items, and the intensity, are
/// named in `widgets` ("Light kind", "Light kind Spot light", "Light intensity").
fn light_ui(ui: &mut egui::Ui, light: &mut LightValue, widgets: &mut WidgetRects) {
    ui.strong("Light");
    egui::Grid::new("light")
        .num_columns(2)
        .spacing([8.0, 6.0])
        .show(ui, |ui| {
            ui.label("Kind");
            let combo = egui::ComboBox::from_id_salt("light-kind")
                .selected_text(light.kind.label())
                .show_ui(ui, |ui| {
                    for kind in LightKind::ALL {
                        let item = ui.selectable_value(&mut light.kind, kind, kind.label());
                        widgets.push(format!("Light kind {}", kind.label()), item.rect);
                    }
                });
            widgets.push("Light kind", combo.response.rect);
            ui.end_row();
            ui.label("Colour");
            ui.color_edit_button_rgb(&mut light.color);
            ui.end_row();
            ui.label("Intensity");
            if light.kind.is_local() {
                // Shown in candela, stored in lumens: a value the user typed reads back as typed.
                let shown = lumens_to_candela(light.intensity);
                let mut candela = shown;
                let field = ui
                    .add(
                        egui::DragValue::new(&mut candela)
                            .speed((shown * 0.01).max(0.1))
                            .range(0.0..=1.0e8)
                            .max_decimals(1)
                            .suffix(" cd"),
                    )
                    .on_hover_text(
                        "Luminous intensity in candela (lumens per steradian), as glTF gives it",
                    );
                widgets.push("Light intensity", field.rect);
                if candela != shown {
                    light.intensity = candela_to_lumens(candela);
                }
            } else {
                let speed = (light.intensity * 0.01).max(0.1);
                let field = ui
                    .add(
                        egui::DragValue::new(&mut light.intensity)
                            .speed(speed)
                            .range(0.0..=1.0e6)
                            .max_decimals(1)
                            .suffix(" lx"),
                    )
                    .on_hover_text("Illuminance in lux on a surface facing the light");
                widgets.push("Light intensity", field.rect);
            }
            ui.end_row();
            if light.kind.is_local() {
                light_range(ui, light, widgets);
                ui.end_row();
            }
            if light.kind == LightKind::Spot {
                let mut inner = light.inner_angle.to_degrees();
                let mut outer = light.outer_angle.to_degrees();
                ui.label("Cone (°)");
                ui.horizontal(|ui| {
                    ui.add(
                        egui::DragValue::new(&mut inner)
                            .speed(0.5)
                            .range(0.0..=90.0)
                            .max_decimals(1)
                            .prefix("inner "),
                    )
                    .on_hover_text("Full intensity within this angle of the axis");
                    ui.add(
                        egui::DragValue::new(&mut outer)
                            .speed(0.5)
                            .range(0.0..=90.0)
                            .max_decimals(1)
                            .prefix("outer "),
                    )
                    .on_hover_text("No light past this angle of the axis");
                });
                ui.end_row();
                if outer != light.outer_angle.to_degrees() {
                    light.outer_angle = outer.to_radians().min(std::f32::consts::FRAC_PI_2);
                    light.inner_angle = light.inner_angle.min(light.outer_angle);
                } else if inner != light.inner_angle.to_degrees() {
                    light.inner_angle = inner.to_radians().min(light.outer_angle);
                }
            }
            ui.label("Shadows");
            ui.checkbox(&mut light.shadows, "").on_hover_text(
                "Whether it casts shadows in the raster view (the path tracer always traces them)",
            );
            ui.end_row();
        });
}

/// A point or spot light's range: unlimited (glTF's light without one: the inverse square alone),
/// or limited to a distance at which it has faded to nothing ("Light range limited" in `widgets`).
fn light_range(ui: &mut egui::Ui, light: &mut LightValue, widgets: &mut WidgetRects) {
    ui.label("Range");
    ui.horizontal(|ui| {
        let mut limited = light.range.is_some();
        let check = ui
            .checkbox(&mut limited, "limited")
            .on_hover_text("Off: the light falls off with the square of the distance alone");
        widgets.push("Light range limited", check.rect);
        if check.changed() {
            light.range = limited.then_some(LIMITED_RANGE);
        }
        if let Some(mut range) = light.range {
            let field = ui
                .add(
                    egui::DragValue::new(&mut range)
                        .speed(0.1)
                        .range(0.01..=1.0e5)
                        .max_decimals(2)
                        .suffix(" m"),
                )
                .on_hover_text("Distance at which the light has faded to nothing");
            if field.changed() {
                light.range = Some(range);
            }
        }
    });
}

/// The range a light gets when the user first limits it, in metres.
const LIMITED_RANGE: f32 = 20.0;

fn vec3_row(ui: &mut egui::Ui, label: &str, v: &mut Vec3, speed: f32) {
    ui.label(label);
    ui.horizontal(|ui| {
        for (axis, c) in ["x", "y", "z"]
            .into_iter()
            .zip([&mut v.x, &mut v.y, &mut v.z])
        {
            ui.label(axis);
            ui.add(egui::DragValue::new(c).speed(speed).max_decimals(3));
        }
    });
    ui.end_row();
}

/// The requests for what changed between `before` and `after`; `continuing` merges them into
/// the step the same widget's gesture began.
pub fn changes(
    before: &InspectorState,
    after: &InspectorState,
    continuing: bool,
) -> Vec<EditRequest> {
    let mut out = Vec::new();
    let id = after.id;
    let mut push = |command| {
        out.push(EditRequest::Apply {
            command,
            continuing,
        })
    };
    if before.name != after.name {
        push(EditCommand::Rename {
            id,
            name: after.name.clone(),
        });
    }
    if (before.translation, before.rotation_deg, before.scale)
        != (after.translation, after.rotation_deg, after.scale)
    {
        push(EditCommand::SetTransform {
            id,
            transform: after.transform().into(),
        });
    }
    if let (Some(a), Some(b)) = (&before.material, &after.material)
        && a.value != b.value
    {
        push(EditCommand::SetMaterial {
            id,
            material: b.value,
        });
    }
    if let (Some(a), Some(b)) = (before.light, after.light)
        && a != b
    {
        push(EditCommand::SetLight { id, light: b });
    }
    out
}

/// What the inspector tab reads and changes.
#[derive(SystemParam)]
pub struct InspectorAccess<'w, 's> {
    selection: Res<'w, Selection>,
    objects: Objects<'w, 's>,
    materials: Res<'w, Assets<StandardMaterial>>,
    images: Res<'w, Assets<Image>>,
    material_of: Query<'w, 's, &'static MeshMaterial3d<StandardMaterial>, With<SceneObject>>,
    lights: Query<'w, 's, LightParts, With<SceneObject>>,
    widgets: ResMut<'w, WidgetRects>,
    requests: ResMut<'w, EditRequests>,
    textures: ResMut<'w, EguiUserTextures>,
    cameras:
        Query<'w, 's, &'static treelight_document::values::camera::SceneCamera, With<SceneObject>>,
    look: ResMut<'w, crate::editor::core::view::LookThrough>,
    /// The widget whose drag or typing made the last request, to merge what it does next.
    gesture: Local<'s, Option<egui::Id>>,
}

/// The inspector's copy of the active object, with its material and how many objects share it.
fn inspected(access: &mut InspectorAccess) -> Option<InspectorState> {
    let e = access.selection.active()?;
    let o = access.objects.get(e).ok()?;
    let mut state = InspectorState::new(*o.id, o.name.as_str(), o.transform);
    state.selected = access.selection.entities().len();
    state.light = access.lights.get(e).ok().and_then(LightValue::of_parts);
    state.camera = access.cameras.get(e).ok().map(|c| c.describe());
    if let Ok(handle) = access.material_of.get(e)
        && let Some(m) = access.materials.get(&handle.0)
    {
        let users = access
            .material_of
            .iter()
            .filter(|h| h.0.id() == handle.0.id())
            .count();
        let texture = m.base_color_texture.as_ref().and_then(|t| {
            let size = access.images.get(t)?.size();
            let id = access.textures.add_image(EguiTextureHandle::Weak(t.id()));
            Some((id, size))
        });
        state.material = Some(MaterialView {
            value: MaterialValue::of(m),
            users,
            texture,
        });
    }
    Some(state)
}

/// Draws the inspector tab into `ui` and turns what the user changed into edit requests (a drag
/// or typing in one field merges into one step).
pub fn inspector_tab(InMut(ui): InMut<egui::Ui>, mut access: InspectorAccess) {
    let original = inspected(&mut access);
    let mut edited = original.clone();
    let mut make_unique = false;
    inspector_ui(ui, edited.as_mut(), &mut make_unique, &mut access.widgets);
    if make_unique && let Some(state) = &original {
        access
            .requests
            .apply(EditCommand::MakeMaterialUnique { id: state.id });
    }
    if edited.as_ref().is_some_and(|s| s.look_through)
        && let Some(e) = access.selection.active()
    {
        *access.look = crate::editor::core::view::LookThrough::Object(e);
    }
    let ctx = ui.ctx();
    let active = ctx.dragged_id().or_else(|| ctx.memory(|m| m.focused()));
    if let (Some(before), Some(after)) = (&original, &edited)
        && before != after
    {
        let continuing = active.is_some() && *access.gesture == active;
        access.requests.0.extend(changes(before, after, continuing));
    }
    *access.gesture = active;
}
