//! The scene's environment: an equirectangular HDR panorama (`.hdr`, `.exr`) that lights the scene
//! in place of the look's flat sky, turned about the vertical, scaled, and shown behind the scene
//! or hidden ([`SceneEnvironment`], edited by command, saved in projects). The file is read on a
//! thread of its own ([`LoadedEnvironment`]); a file that cannot be read is a notice naming it, and
//! the scene keeps the flat sky.

use crate::scene::notice::Notices;
use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use treelight_import::{EnvironmentImage, ImportError};

/// Largest intensity the panorama takes, nits per unit of its values.
pub const MAX_ENVIRONMENT_INTENSITY: f32 = 1.0e7;

/// The panorama's default intensity: a sky of value 1 shines at 1,000 nits, about an overcast
/// day, which the default exposure shows as a mid grey.
pub const DEFAULT_ENVIRONMENT_INTENSITY: f32 = 1000.0;

/// The panorama lighting the scene.
#[derive(Resource, Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneEnvironment {
    /// The panorama's file; `None` lights the scene with the look's sky colour. Projects store it
    /// relative to their folder when inside it.
    #[serde(default)]
    pub image: Option<PathBuf>,
    /// Turn about the vertical axis, degrees (counter-clockwise seen from above).
    #[serde(default)]
    pub rotation_degrees: f32,
    /// Radiance in nits of a panorama value of 1 (the exposure scales it like every light).
    #[serde(default = "default_intensity")]
    pub intensity: f32,
    /// Whether the panorama is seen behind the scene; hidden, the look's sky colour is, while the
    /// panorama still lights the scene.
    #[serde(default = "shown")]
    pub shown: bool,
}

fn default_intensity() -> f32 {
    DEFAULT_ENVIRONMENT_INTENSITY
}

fn shown() -> bool {
    true
}

impl Default for SceneEnvironment {
    fn default() -> Self {
        Self {
            image: None,
            rotation_degrees: 0.0,
            intensity: DEFAULT_ENVIRONMENT_INTENSITY,
            shown: true,
        }
    }
}

impl SceneEnvironment {
    /// Whether the values are ones the scene accepts: a finite rotation within a full turn either
    /// way, a finite intensity from 0 to [`MAX_ENVIRONMENT_INTENSITY`], a file named `.hdr` or
    /// `.exr`.
    pub fn is_valid(&self) -> bool {
        self.rotation_degrees.is_finite()
            && self.rotation_degrees.abs() <= 360.0
            && self.intensity.is_finite()
            && (0.0..=MAX_ENVIRONMENT_INTENSITY).contains(&self.intensity)
            && self.image.as_deref().is_none_or(is_environment_file)
    }

    /// The rotation in radians, as the path tracer takes it.
    pub fn rotation_radians(&self) -> f32 {
        self.rotation_degrees.to_radians()
    }
}

/// Whether a path names a panorama the editor reads (by its extension).
pub fn is_environment_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("hdr") || e.eq_ignore_ascii_case("exr"))
}

/// A read's result, set once by its thread.
type Reading = Arc<OnceLock<Result<EnvironmentImage, ImportError>>>;

/// The panorama read for [`SceneEnvironment::image`]: its image asset once read.
#[derive(Resource, Default)]
pub struct LoadedEnvironment {
    /// The file the image (or the failure) is for.
    path: Option<PathBuf>,
    /// The panorama as a linear `Rgba32Float` image, kept in the main world only.
    pub image: Option<Handle<Image>>,
    /// A read under way.
    reading: Option<(PathBuf, Reading)>,
}

impl LoadedEnvironment {
    /// Whether a file is still being read.
    pub fn loading(&self) -> bool {
        self.reading.is_some()
    }
}

/// Starts reading the panorama the scene names when it changes, and takes the result: the image,
/// or a notice naming the file and what is wrong with it.
pub fn load_environment(
    environment: Res<SceneEnvironment>,
    mut loaded: ResMut<LoadedEnvironment>,
    mut images: ResMut<Assets<Image>>,
    mut notices: ResMut<Notices>,
) {
    let wanted = environment.image.clone();
    if let Some((path, slot)) = &loaded.reading
        && let Some(result) = slot.get()
    {
        let path = path.clone();
        match result {
            Ok(panorama) => {
                for w in &panorama.warnings {
                    notices.warn(format!("Sky panorama {}: {w}", path.display()));
                }
                loaded.image = Some(images.add(panorama_image(panorama)));
            }
            Err(e) => {
                notices.error(format!("Cannot use the sky panorama: {e}"));
                loaded.image = None;
            }
        }
        loaded.path = Some(path);
        loaded.reading = None;
    }
    let reading_wanted = loaded
        .reading
        .as_ref()
        .is_some_and(|(p, _)| Some(p) == wanted.as_ref());
    if reading_wanted || (loaded.reading.is_none() && loaded.path == wanted) {
        return;
    }
    let Some(path) = wanted else {
        loaded.path = None;
        loaded.image = None;
        loaded.reading = None;
        return;
    };
    let slot = Reading::default();
    let result = slot.clone();
    let file = path.clone();
    let spawned = std::thread::Builder::new()
        .name("treelight sky panorama".into())
        .spawn(move || {
            // A decoder that panics on a hostile file is an error naming it, not a read that
            // never ends (the scene would never settle).
            let read = std::panic::catch_unwind(|| treelight_import::read_environment(&file))
                .unwrap_or_else(|p| {
                    Err(ImportError {
                        file: file.clone(),
                        problem: crate::files::contain::crashed("reading it".into(), &*p),
                    })
                });
            let _ = result.set(read);
        });
    match spawned {
        Ok(_) => loaded.reading = Some((path, slot)),
        Err(e) => {
            notices.error(format!(
                "Cannot read the sky panorama {}: {e}",
                path.display()
            ));
            loaded.path = Some(path);
            loaded.image = None;
        }
    }
}

/// The panorama as a Bevy image: linear RGBA floats, in the main world only (the path tracer
/// makes its own texture of it).
pub fn panorama_image(panorama: &EnvironmentImage) -> Image {
    let data: Vec<u8> = panorama
        .rgb
        .iter()
        .flat_map(|&[r, g, b]| [r, g, b, 1.0])
        .flat_map(f32::to_le_bytes)
        .collect();
    Image::new(
        Extent3d {
            width: panorama.width,
            height: panorama.height,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba32Float,
        RenderAssetUsages::MAIN_WORLD,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_environment_reads_back_as_written_and_fields_default() {
        let e = SceneEnvironment {
            image: Some(PathBuf::from("skies/noon.hdr")),
            rotation_degrees: -35.0,
            intensity: 2500.0,
            shown: false,
        };
        let text = ron::to_string(&e).unwrap();
        assert_eq!(ron::from_str::<SceneEnvironment>(&text).unwrap(), e);
        assert_eq!(
            ron::from_str::<SceneEnvironment>("()").unwrap(),
            SceneEnvironment::default()
        );
        assert!(e.is_valid());
        for bad in [
            SceneEnvironment {
                rotation_degrees: f32::NAN,
                ..e.clone()
            },
            SceneEnvironment {
                intensity: -1.0,
                ..e.clone()
            },
            SceneEnvironment {
                image: Some(PathBuf::from("/dev/zero")),
                ..e.clone()
            },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }
}
