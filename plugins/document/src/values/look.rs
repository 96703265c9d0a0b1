//! How the scene's light becomes the picture: the camera's exposure and the tone curve, and the
//! sky's radiance that rays escaping the scene meet. Part of the document: changed by a command with undo (`EditCommand::SetLook`) and
//! saved in projects; an editor puts it on its cameras, raster and path-traced alike.

use bevy::prelude::*;
use serde::{Deserialize, Serialize};

/// The exposure and tone curve every view of the scene uses.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneLook {
    /// Exposure compensation in stops (EV) over a physical camera's default exposure (Bevy's
    /// `Exposure::default()`, EV100 9.7): +1 doubles the picture's brightness.
    #[serde(default)]
    pub exposure: f32,
    /// The curve that maps the exposed radiance to the display.
    #[serde(default)]
    pub tone: ToneCurve,
    /// The sky's radiance, linear RGB in nits (the exposure scales it like every light): what
    /// rays leaving the scene meet, lighting it and seen behind it.
    #[serde(default = "default_sky")]
    pub sky: [f32; 3],
}

/// The editor's sky: a pale blue of 200 nits at its brightest.
pub const DEFAULT_SKY: [f32; 3] = [110.0, 140.0, 200.0];

/// The brightest sky a look takes, in nits (about the sun's disc at noon is 1.6e9; a clear sky is
/// under 1e4).
pub const MAX_SKY: f32 = 1.0e6;

fn default_sky() -> [f32; 3] {
    DEFAULT_SKY
}

impl Default for SceneLook {
    fn default() -> Self {
        Self {
            exposure: 0.0,
            tone: ToneCurve::default(),
            sky: DEFAULT_SKY,
        }
    }
}

/// The widest exposure compensation, in stops either way: from starlight to the sun's disc.
pub const MAX_EXPOSURE_STOPS: f32 = 24.0;

/// A physical camera's default exposure value at ISO 100 (Bevy's `Exposure::EV100_BLENDER`): the
/// value that compensation 0 gives.
pub const DEFAULT_EV100: f32 = 9.7;

impl SceneLook {
    /// Whether the values are ones the scene accepts: a finite exposure within
    /// [`MAX_EXPOSURE_STOPS`], a sky of finite, non-negative radiance up to [`MAX_SKY`].
    pub fn is_valid(&self) -> bool {
        self.exposure.is_finite()
            && self.exposure.abs() <= MAX_EXPOSURE_STOPS
            && self
                .sky
                .iter()
                .all(|c| c.is_finite() && (0.0..=MAX_SKY).contains(c))
    }

    /// The sky's radiance as the path tracer takes it.
    pub fn sky_radiance(&self) -> LinearRgba {
        let [r, g, b] = self.sky;
        LinearRgba::rgb(r, g, b)
    }

    /// The camera's exposure value at ISO 100 this look asks for (one stop brighter is one EV100
    /// lower).
    pub fn ev100(&self) -> f32 {
        DEFAULT_EV100 - self.exposure
    }
}

/// Tone curves, by what a user knows them as. Each is one of Bevy's tonemappers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ToneCurve {
    /// A filmic curve that desaturates bright colours toward white (Tony McMapface): Bevy's
    /// default, and the editor's.
    #[default]
    Filmic,
    /// Blender's AgX: filmic, with a gentler hue shift.
    AgX,
    /// Khronos PBR Neutral: keeps base colours as authored up to the highlights, for checking
    /// materials against their values.
    Neutral,
    /// The ACES filmic fit many engines use.
    Aces,
    /// Reinhard on luminance: simple, keeps hues.
    Reinhard,
    /// None: exposed radiance clipped at 1.
    None,
}

impl ToneCurve {
    /// Every curve, in the order menus list them.
    pub const ALL: [ToneCurve; 6] = [
        ToneCurve::Filmic,
        ToneCurve::AgX,
        ToneCurve::Neutral,
        ToneCurve::Aces,
        ToneCurve::Reinhard,
        ToneCurve::None,
    ];

    /// A name for menus.
    pub fn label(self) -> &'static str {
        match self {
            ToneCurve::Filmic => "Filmic",
            ToneCurve::AgX => "AgX",
            ToneCurve::Neutral => "Neutral (Khronos PBR)",
            ToneCurve::Aces => "ACES",
            ToneCurve::Reinhard => "Reinhard",
            ToneCurve::None => "None (clip)",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposure_in_stops_moves_the_ev100_the_other_way() {
        let mut look = SceneLook::default();
        assert_eq!(look.ev100(), DEFAULT_EV100);
        look.exposure = 2.0;
        assert_eq!(look.ev100(), DEFAULT_EV100 - 2.0);
        assert!(look.is_valid());
        look.exposure = f32::NAN;
        assert!(!look.is_valid());
        look.exposure = MAX_EXPOSURE_STOPS + 1.0;
        assert!(!look.is_valid());
    }

    #[test]
    fn a_look_reads_back_as_written_and_fields_default() {
        let look = SceneLook {
            exposure: -1.5,
            tone: ToneCurve::Neutral,
            sky: [1.0, 2.0, 3.0],
        };
        let text = ron::to_string(&look).unwrap();
        assert_eq!(ron::from_str::<SceneLook>(&text).unwrap(), look);
        assert_eq!(
            ron::from_str::<SceneLook>("(tone: Aces)").unwrap(),
            SceneLook {
                exposure: 0.0,
                tone: ToneCurve::Aces,
                sky: DEFAULT_SKY,
            }
        );
        let dark = SceneLook {
            sky: [0.0, -1.0, 0.0],
            ..look
        };
        assert!(!dark.is_valid());
    }
}
