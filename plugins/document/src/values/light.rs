//! Lights as values: what a light object is (kind, colour, intensity, range, cone, shadows), read
//! from and written to Bevy's light components, for commands, projects, undo and imports alike.
//! Intensities are Bevy's: lumens for point and spot lights, lux for directional ones; glTF's
//! candela are converted at the edges ([`candela_to_lumens`]).

use crate::values::transform::in_range;
use bevy::prelude::*;
use serde::{Deserialize, Serialize};

/// The kinds of light.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LightKind {
    /// Light from a point, in every direction.
    Point,
    /// Parallel light from far away (a sun), along the light's forward axis.
    Directional,
    /// Light from a point in a cone around the light's forward axis.
    Spot,
}

impl LightKind {
    /// Every kind, in menu order.
    pub const ALL: [LightKind; 3] = [LightKind::Point, LightKind::Spot, LightKind::Directional];

    /// A name for menus and the outliner.
    pub fn label(self) -> &'static str {
        match self {
            LightKind::Point => "Point light",
            LightKind::Directional => "Directional light",
            LightKind::Spot => "Spot light",
        }
    }

    /// Whether its light falls off with distance from a position (point and spot lights).
    pub fn is_local(self) -> bool {
        self != LightKind::Directional
    }
}

/// A light's values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightValue {
    /// Which kind.
    pub kind: LightKind,
    /// Colour, sRGB.
    pub color: [f32; 3],
    /// Lumens for a point or spot light, lux for a directional one.
    pub intensity: f32,
    /// Whether it casts shadows in the rasterised view.
    #[serde(default = "shown")]
    pub shadows: bool,
    /// A point or spot light's range: past it the light has faded to nothing (glTF's smooth
    /// window, which Bevy's rasteriser uses too). `None`: unlimited, the light falling off with
    /// the square of the distance alone (glTF's meaning of a light without `range`).
    #[serde(default)]
    pub range: Option<f32>,
    /// A spot light's cone, radians from its axis: full intensity inside `inner_angle`, fading
    /// to none at `outer_angle`.
    #[serde(default)]
    pub inner_angle: f32,
    /// See `inner_angle`.
    #[serde(default = "default_outer_angle")]
    pub outer_angle: f32,
}

fn shown() -> bool {
    true
}

fn default_outer_angle() -> f32 {
    std::f32::consts::FRAC_PI_4
}

/// The light components a query reads for [`LightValue::of_parts`] (systems cannot read whole
/// entities beside a mutable resource).
pub type LightParts = (
    Option<&'static PointLight>,
    Option<&'static SpotLight>,
    Option<&'static DirectionalLight>,
);

/// The range Bevy's light components get for a light without one ([`LightValue::range`] `None`):
/// Bevy's lights must have a finite range, and at a million metres glTF's window is 1 to within
/// f32's precision for any distance under a kilometre (its fall-off is `(d / range)^4`), so the
/// light is unlimited in effect. A component's range at or above it reads back as `None`.
pub const UNLIMITED_RANGE: f32 = 1.0e6;

/// A light component's range as a [`LightValue::range`]: `None` at [`UNLIMITED_RANGE`] and above.
fn range_of_component(range: f32) -> Option<f32> {
    (range < UNLIMITED_RANGE).then_some(range)
}

/// The luminous power of a point light of `candela` (glTF's unit for point and spot lights):
/// 4π lumens per candela, as Bevy's glTF loader converts it.
pub fn candela_to_lumens(candela: f32) -> f32 {
    candela * 4.0 * std::f32::consts::PI
}

/// The inverse of [`candela_to_lumens`].
pub fn lumens_to_candela(lumens: f32) -> f32 {
    lumens / (4.0 * std::f32::consts::PI)
}

impl LightValue {
    /// A new light of `kind` as the Add menu makes it.
    pub fn new(kind: LightKind) -> Self {
        Self {
            kind,
            color: [1.0; 3],
            intensity: match kind {
                LightKind::Point | LightKind::Spot => 200_000.0,
                LightKind::Directional => 3000.0,
            },
            shadows: true,
            range: None,
            inner_angle: 0.0,
            outer_angle: default_outer_angle(),
        }
    }

    /// The light `entity` has, if any.
    pub fn of(entity: &EntityRef) -> Option<Self> {
        Self::of_parts((
            entity.get::<PointLight>(),
            entity.get::<SpotLight>(),
            entity.get::<DirectionalLight>(),
        ))
    }

    /// The light of an entity with these light components, if any (what a [`LightParts`] query
    /// gives).
    pub fn of_parts(
        (point, spot, directional): (
            Option<&PointLight>,
            Option<&SpotLight>,
            Option<&DirectionalLight>,
        ),
    ) -> Option<Self> {
        let srgb = |c: Color| c.to_srgba().to_f32_array_no_alpha();
        if let Some(l) = point {
            return Some(Self {
                kind: LightKind::Point,
                color: srgb(l.color),
                intensity: l.intensity,
                shadows: l.shadow_maps_enabled,
                range: range_of_component(l.range),
                ..Self::new(LightKind::Point)
            });
        }
        if let Some(l) = spot {
            return Some(Self {
                kind: LightKind::Spot,
                color: srgb(l.color),
                intensity: l.intensity,
                shadows: l.shadow_maps_enabled,
                range: range_of_component(l.range),
                inner_angle: l.inner_angle,
                outer_angle: l.outer_angle,
            });
        }
        directional.map(|l| Self {
            kind: LightKind::Directional,
            color: srgb(l.color),
            intensity: l.illuminance,
            shadows: l.shadow_maps_enabled,
            range: None,
            ..Self::new(LightKind::Directional)
        })
    }

    /// Whether the values are ones a light can take: finite numbers in range, a non-negative
    /// intensity and colour, a positive range, and a cone with `0 <= inner <= outer <= π/2`.
    pub fn is_valid(&self) -> bool {
        self.color
            .iter()
            .chain([&self.intensity, &self.inner_angle, &self.outer_angle])
            .all(|v| in_range(*v))
            && self.color.iter().all(|c| *c >= 0.0)
            && self.intensity >= 0.0
            && self.range.is_none_or(|r| in_range(r) && r > 0.0)
            && (0.0..=self.outer_angle).contains(&self.inner_angle)
            && self.outer_angle <= std::f32::consts::FRAC_PI_2
    }

    /// Gives `e` this light, in place of any light it had.
    pub fn put_on(&self, e: &mut EntityWorldMut) {
        e.remove::<(PointLight, SpotLight, DirectionalLight)>();
        let [r, g, b] = self.color;
        let color = Color::srgb(r, g, b);
        let range = self
            .range
            .filter(|r| *r > 0.0)
            .map_or(UNLIMITED_RANGE, |r| r.min(UNLIMITED_RANGE));
        match self.kind {
            LightKind::Point => e.insert(PointLight {
                color,
                intensity: self.intensity,
                range,
                shadow_maps_enabled: self.shadows,
                ..default()
            }),
            LightKind::Spot => e.insert(SpotLight {
                color,
                intensity: self.intensity,
                range,
                inner_angle: self.inner_angle,
                outer_angle: self.outer_angle,
                shadow_maps_enabled: self.shadows,
                ..default()
            }),
            LightKind::Directional => e.insert(DirectionalLight {
                color,
                illuminance: self.intensity,
                shadow_maps_enabled: self.shadows,
                ..default()
            }),
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_reads_back_as_it_was_put() {
        let mut world = World::new();
        for kind in LightKind::ALL {
            let value = LightValue {
                color: [0.5, 0.25, 1.0],
                intensity: 1234.0,
                shadows: false,
                range: kind.is_local().then_some(7.0),
                inner_angle: if kind == LightKind::Spot { 0.2 } else { 0.0 },
                outer_angle: if kind == LightKind::Spot {
                    0.6
                } else {
                    default_outer_angle()
                },
                ..LightValue::new(kind)
            };
            let mut e = world.spawn_empty();
            LightValue::new(LightKind::Point).put_on(&mut e);
            value.put_on(&mut e);
            let id = e.id();
            let back = LightValue::of(&world.entity(id)).unwrap();
            assert_eq!(back.kind, kind);
            for (a, b) in back.color.iter().zip(value.color) {
                assert!((a - b).abs() < 1e-5, "{kind:?}: {back:?}");
            }
            assert_eq!(
                (back.intensity, back.shadows, back.range),
                (1234.0, false, value.range)
            );
            assert_eq!(
                (back.inner_angle, back.outer_angle),
                (value.inner_angle, value.outer_angle)
            );
            // Only one light component.
            let e = world.entity(id);
            let count = [
                e.contains::<PointLight>(),
                e.contains::<SpotLight>(),
                e.contains::<DirectionalLight>(),
            ]
            .iter()
            .filter(|b| **b)
            .count();
            assert_eq!(count, 1);
        }
    }

    #[test]
    fn bad_values_are_refused() {
        let good = LightValue::new(LightKind::Spot);
        assert!(good.is_valid());
        for bad in [
            LightValue {
                intensity: -1.0,
                ..good
            },
            LightValue {
                intensity: f32::NAN,
                ..good
            },
            LightValue {
                color: [0.0, -1.0, 0.0],
                ..good
            },
            LightValue {
                range: Some(0.0),
                ..good
            },
            LightValue {
                inner_angle: 0.9,
                outer_angle: 0.5,
                ..good
            },
            LightValue {
                outer_angle: 2.0,
                ..good
            },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
        assert!((lumens_to_candela(candela_to_lumens(3.0)) - 3.0).abs() < 1e-6);
    }

    #[test]
    fn a_light_without_range_stays_unlimited_through_bevy_s_components() {
        let mut world = World::new();
        for kind in [LightKind::Point, LightKind::Spot] {
            let value = LightValue::new(kind);
            assert_eq!(value.range, None, "a new light is unlimited");
            let mut e = world.spawn_empty();
            value.put_on(&mut e);
            let id = e.id();
            let component_range = match kind {
                LightKind::Point => world.get::<PointLight>(id).unwrap().range,
                _ => world.get::<SpotLight>(id).unwrap().range,
            };
            // glTF's window at a kilometre from the light is 1 in f32.
            let f = (1000.0f32 / component_range).powi(4);
            assert_eq!((1.0 - f).max(0.0).powi(2), 1.0, "{kind:?}");
            assert_eq!(LightValue::of(&world.entity(id)).unwrap().range, None);
            // A range given stays that range.
            let limited = LightValue {
                range: Some(12.5),
                ..value
            };
            limited.put_on(&mut world.entity_mut(id));
            assert_eq!(LightValue::of(&world.entity(id)).unwrap().range, Some(12.5));
        }
    }
}
