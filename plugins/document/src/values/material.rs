//! Materials as commands and projects store them: the values of a `StandardMaterial` a user edits.

use crate::values::transform::in_range;
use bevy::prelude::*;
use serde::{Deserialize, Serialize};

/// What a material's alpha means (glTF's alpha modes).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum MaterialAlpha {
    /// Alpha is ignored: the surface is solid.
    Opaque,
    /// Cut away where alpha is below the cutoff.
    Mask(f32),
    /// Lets `1 - alpha` of the light through.
    Blend,
}

impl MaterialAlpha {
    /// The three modes, for menus (the mask at glTF's default cutoff).
    pub const ALL: [MaterialAlpha; 3] = [
        MaterialAlpha::Opaque,
        MaterialAlpha::Mask(0.5),
        MaterialAlpha::Blend,
    ];

    /// The mode's name in the UI.
    pub fn label(self) -> &'static str {
        match self {
            MaterialAlpha::Opaque => "Opaque",
            MaterialAlpha::Mask(_) => "Mask",
            MaterialAlpha::Blend => "Blend",
        }
    }

    /// Bevy's alpha mode for this one.
    pub fn to_bevy(self) -> AlphaMode {
        match self {
            MaterialAlpha::Opaque => AlphaMode::Opaque,
            MaterialAlpha::Mask(c) => AlphaMode::Mask(c),
            MaterialAlpha::Blend => AlphaMode::Blend,
        }
    }

    /// This crate's mode for Bevy's (its other blending modes read as blend, alpha to coverage as
    /// a mask at one half).
    pub fn of_bevy(mode: AlphaMode) -> Self {
        match mode {
            AlphaMode::Opaque => MaterialAlpha::Opaque,
            AlphaMode::Mask(c) => MaterialAlpha::Mask(c),
            AlphaMode::AlphaToCoverage => MaterialAlpha::Mask(0.5),
            _ => MaterialAlpha::Blend,
        }
    }
}

/// A material's editable values, as commands store them. The optional ones were added with
/// project version 3: a file without them leaves those values as the material has them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialValue {
    /// Base colour, sRGB with alpha.
    pub base_color: [f32; 4],
    /// Metallic, 0 to 1.
    pub metallic: f32,
    /// Perceptual roughness, 0 to 1.
    pub perceptual_roughness: f32,
    /// Emitted light, linear RGB (colour times strength).
    #[serde(default)]
    pub emissive: [f32; 3],
    /// Whether back faces are drawn too.
    #[serde(default)]
    pub double_sided: bool,
    /// What alpha means.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<MaterialAlpha>,
    /// Fraction of the unreflected light passing through (thin-walled), 0 to 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmission: Option<f32>,
    /// Strength of a clear coat, 0 to 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clearcoat: Option<f32>,
    /// Perceptual roughness of the clear coat, 0 to 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clearcoat_roughness: Option<f32>,
}

impl MaterialValue {
    /// The values of `m`.
    pub fn of(m: &StandardMaterial) -> Self {
        let c = m.base_color.to_srgba();
        Self {
            base_color: [c.red, c.green, c.blue, c.alpha],
            metallic: m.metallic,
            perceptual_roughness: m.perceptual_roughness,
            emissive: [m.emissive.red, m.emissive.green, m.emissive.blue],
            double_sided: m.double_sided,
            alpha: Some(MaterialAlpha::of_bevy(m.alpha_mode)),
            transmission: Some(m.specular_transmission),
            clearcoat: Some(m.clearcoat),
            clearcoat_roughness: Some(m.clearcoat_perceptual_roughness),
        }
    }

    /// Writes the values into `m` (a double-sided material is not culled).
    pub fn write(&self, m: &mut StandardMaterial) {
        let [r, g, b, a] = self.base_color;
        m.base_color = Color::srgba(r, g, b, a);
        m.metallic = self.metallic;
        m.perceptual_roughness = self.perceptual_roughness;
        let [r, g, b] = self.emissive;
        m.emissive = LinearRgba::rgb(r, g, b);
        m.double_sided = self.double_sided;
        m.cull_mode = if self.double_sided {
            None
        } else {
            Some(bevy::render::render_resource::Face::Back)
        };
        if let Some(alpha) = self.alpha {
            m.alpha_mode = alpha.to_bevy();
        }
        if let Some(t) = self.transmission {
            m.specular_transmission = t;
        }
        if let Some(c) = self.clearcoat {
            m.clearcoat = c;
        }
        if let Some(r) = self.clearcoat_roughness {
            m.clearcoat_perceptual_roughness = r;
        }
    }

    /// Whether every value is [`in_range`], the emission is not negative and the fractions lie
    /// within 0 to 1.
    pub fn is_valid(&self) -> bool {
        let unit = |v: Option<f32>| v.is_none_or(|v| (0.0..=1.0).contains(&v));
        let cutoff = match self.alpha {
            Some(MaterialAlpha::Mask(c)) => Some(c),
            _ => None,
        };
        self.base_color
            .iter()
            .chain(&self.emissive)
            .chain([&self.metallic, &self.perceptual_roughness])
            .all(|v| in_range(*v))
            && self.emissive.iter().all(|v| *v >= 0.0)
            && [
                self.transmission,
                self.clearcoat,
                self.clearcoat_roughness,
                cutoff,
            ]
            .into_iter()
            .all(unit)
    }
}
