//! The sky panorama in the raster view: Bevy's [`Skybox`] needs a cube map, so the panorama the
//! path tracer samples as it is (equirectangular) is resampled into six faces on a thread of its
//! own, turned and scaled as the path tracer turns and scales it. Shown behind the scene while the
//! view is rasterised and the panorama is set to be seen (the path tracer draws its own sky); and,
//! shown or hidden, it lights the raster view's meshes as it lights the path tracer's, through
//! Bevy's environment map light filtered from the same cube on the GPU.

use crate::editor::core::rest::Activity;
use crate::editor::core::view::OrbitCamera;
use crate::editor::core::viewport_render::ViewportRender;
use bevy::asset::RenderAssetUsages;
use bevy::light::{EnvironmentMapLight, GeneratedEnvironmentMapLight, Skybox};
use bevy::pbr::generate::{GeneratorBindGroups, GeneratorPipelines, RenderEnvironmentMap};
use bevy::prelude::*;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::PipelineCache;
use bevy::render::render_resource::{
    Extent3d, TextureDimension, TextureFormat, TextureViewDescriptor, TextureViewDimension,
};
use bevy::render::texture::GpuImage;
use bevy::render::{Extract, ExtractSchedule, Render, RenderApp, RenderSystems};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};
use treelight_document::scene::environment::{LoadedEnvironment, SceneEnvironment};

/// Largest cube face side: a 2048-wide panorama's texels per quarter turn (the raster view is a
/// preview; the path tracer samples the panorama at its full size).
pub const MAX_FACE_SIDE: u32 = 512;

/// Where a cube map's texel looks: Bevy samples its sky cube at the world direction with z
/// negated, so face `face` (+X, −X, +Y, −Y, +Z, −Z), at `(s, t)` in −1..1 across and down the
/// face, holds the panorama's value in this direction (the panorama's own frame, before its turn).
pub fn face_direction(face: usize, s: f32, t: f32) -> Vec3 {
    // The cube map's sample vector for the face and position (the Vulkan and D3D convention).
    let sample = match face {
        0 => Vec3::new(1.0, -t, -s),
        1 => Vec3::new(-1.0, -t, s),
        2 => Vec3::new(s, 1.0, t),
        3 => Vec3::new(s, -1.0, -t),
        4 => Vec3::new(s, -t, 1.0),
        _ => Vec3::new(-s, -t, -1.0),
    };
    Vec3::new(sample.x, sample.y, -sample.z).normalize()
}

/// A panorama's value in direction `d` (its own frame), bilinearly filtered: wrapping around the
/// horizon, held at the poles. `rgba` holds `width × height` linear RGBA pixels, top row first.
fn panorama_at(rgba: &[[f32; 4]], width: u32, height: u32, d: Vec3) -> [f32; 3] {
    let uv = treelight_render::panorama_coordinates(d);
    let x = uv.x * width as f32 - 0.5;
    let y = (uv.y * height as f32 - 0.5).clamp(0.0, (height - 1) as f32);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let column = |i: i64| i.rem_euclid(i64::from(width)) as usize;
    let (c0, c1) = (column(x0 as i64), column(x0 as i64 + 1));
    let (r0, r1) = (y0 as usize, (y0 as usize + 1).min(height as usize - 1));
    let at = |r: usize, c: usize| rgba[r * width as usize + c];
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let top = at(r0, c0)[k] * (1.0 - fx) + at(r0, c1)[k] * fx;
        let bottom = at(r1, c0)[k] * (1.0 - fx) + at(r1, c1)[k] * fx;
        *o = top * (1.0 - fy) + bottom * fy;
    }
    out
}

/// A cube map of the panorama for Bevy's [`Skybox`], and the factor its half floats were divided
/// by (a panorama brighter than a half float holds is stored scaled down).
pub fn cube_from_panorama(rgba: &[[f32; 4]], width: u32, height: u32) -> (Image, f32) {
    // A power of two: Bevy filters the environment light's mip chain from it.
    let side = (width / 4).next_power_of_two().clamp(16, MAX_FACE_SIDE);
    let mut texels = Vec::with_capacity(6 * (side * side) as usize);
    for face in 0..6 {
        for row in 0..side {
            let t = (row as f32 + 0.5) / side as f32 * 2.0 - 1.0;
            for column in 0..side {
                let s = (column as f32 + 0.5) / side as f32 * 2.0 - 1.0;
                texels.push(panorama_at(rgba, width, height, face_direction(face, s, t)));
            }
        }
    }
    let brightest = texels
        .iter()
        .flatten()
        .fold(0.0f32, |m, &v| if v.is_finite() { m.max(v) } else { m });
    let scale = (brightest / 60000.0).max(1.0);
    let data: Vec<u8> = texels
        .iter()
        .flat_map(|c| {
            let [r, g, b] = c.map(|v| half::f16::from_f32(v / scale));
            [r, g, b, half::f16::ONE]
        })
        .flat_map(half::f16::to_le_bytes)
        .collect();
    let mut image = Image::new(
        Extent3d {
            width: side,
            height: side,
            depth_or_array_layers: 6,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba16Float,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.texture_view_descriptor = Some(TextureViewDescriptor {
        dimension: Some(TextureViewDimension::Cube),
        ..default()
    });
    (image, scale)
}

/// A cube map made (or being made) from the loaded panorama.
#[derive(Resource, Default)]
pub struct SkyBoxCube {
    /// The panorama image the cube is of.
    source: Option<AssetId<Image>>,
    /// The cube and its scale, once made.
    cube: Option<(Handle<Image>, f32)>,
    /// A conversion under way, for `source`.
    making: Option<Arc<OnceLock<(Image, f32)>>>,
}

/// Starts a cube map of the scene's panorama on a thread when a new one is read, and takes it when
/// it is made.
pub fn make_sky_box(
    loaded: Res<LoadedEnvironment>,
    mut cube: ResMut<SkyBoxCube>,
    mut images: ResMut<Assets<Image>>,
) {
    if let Some(slot) = &cube.making
        && let Some((image, scale)) = slot.get()
    {
        let made = (images.add(image.clone()), *scale);
        cube.cube = Some(made);
        cube.making = None;
    }
    let wanted = loaded.image.as_ref().map(Handle::id);
    if wanted == cube.source {
        return;
    }
    cube.source = wanted;
    if let Some((old, _)) = cube.cube.take() {
        images.remove(old.id());
    }
    cube.making = None;
    let Some(panorama) = wanted.and_then(|id| images.get(id)) else {
        return;
    };
    let (width, height) = (panorama.width(), panorama.height());
    let Some(bytes) = panorama.data.as_ref() else {
        return;
    };
    if width == 0 || height == 0 || bytes.len() != (width * height * 16) as usize {
        return;
    }
    let rgba: Vec<[f32; 4]> = bytes
        .chunks_exact(16)
        .map(|p| std::array::from_fn(|k| f32::from_le_bytes(std::array::from_fn(|b| p[4 * k + b]))))
        .collect();
    let slot: Arc<OnceLock<(Image, f32)>> = Arc::default();
    let result = slot.clone();
    let spawned = std::thread::Builder::new()
        .name("treelight sky box".into())
        .spawn(move || {
            let _ = result.set(cube_from_panorama(&rgba, width, height));
        });
    if spawned.is_ok() {
        cube.making = Some(slot);
    }
}

/// The longest a new sky light keeps the editor drawing while its filters are not seen to run (a
/// machine whose adapter cannot filter, or whose filter pipelines fail, rests after it).
const SKY_LIGHT_WAIT: Duration = Duration::from_secs(120);

/// Whether the raster view's light from the panorama has reached its meshes. Bevy filters the
/// cube into the light on the GPU a few frames after the camera is given it (its images uploaded,
/// the view's light extracted, the filter and mesh pipelines compiled), with no sign in the main
/// world: the render world counts the frames in which it filtered each cube, and a new light
/// keeps the editor drawing until its cube has been filtered in two (the mesh pipelines those
/// frames queued are then in [`crate::render_file::PipelinesReady`]'s count), so a resting editor
/// never shows it unlit.
#[derive(Resource, Default)]
pub struct SkyLight {
    /// The cube the render world filtered last, and in how many frames.
    filtered: FilteredFrames,
    /// The cube the camera's newest light is filtered from, and since when.
    awaited: Option<(AssetId<Image>, Instant)>,
}

/// The render world's cube filtered last and its count of frames, shared with the main world.
#[derive(Resource, Clone, Default)]
pub struct FilteredFrames(Arc<Mutex<(Option<AssetId<Image>>, u64)>>);

/// The cube whose light was extracted for the view this render frame, if one was.
#[derive(Resource, Default)]
struct ExtractedSkyLight(Option<AssetId<Image>>);

/// Keeps [`SkyLight`], and the render world's count behind it where the app renders.
pub struct SkyLightPlugin;

impl Plugin for SkyLightPlugin {
    fn build(&self, app: &mut App) {
        let light = SkyLight::default();
        let frames = light.filtered.clone();
        app.insert_resource(light);
        if let Some(render) = app.get_sub_app_mut(RenderApp) {
            render
                .insert_resource(frames)
                .init_resource::<ExtractedSkyLight>()
                .add_systems(ExtractSchedule, extract_sky_light)
                .add_systems(
                    Render,
                    count_filtered_frames
                        .after(RenderSystems::PrepareBindGroups)
                        .before(RenderSystems::Render),
                );
        }
    }
}

/// The cube of the camera's light, where Bevy's generator extracts it this frame: the cube and
/// the two maps filtered from it are on the GPU.
fn extract_sky_light(
    cameras: Extract<Query<(&GeneratedEnvironmentMapLight, &EnvironmentMapLight)>>,
    images: Res<RenderAssets<GpuImage>>,
    mut extracted: ResMut<ExtractedSkyLight>,
) {
    extracted.0 = cameras.iter().find_map(|(generated, light)| {
        let on_gpu = |h: &Handle<Image>| images.get(h).is_some();
        (on_gpu(&generated.environment_map)
            && on_gpu(&light.diffuse_map)
            && on_gpu(&light.specular_map))
        .then(|| generated.environment_map.id())
    });
}

/// Counts a render frame in which Bevy's generator filters the extracted cube: a view with its map
/// and bind groups, and every filter pipeline compiled.
fn count_filtered_frames(
    maps: Query<(), (With<RenderEnvironmentMap>, With<GeneratorBindGroups>)>,
    pipelines: Option<Res<GeneratorPipelines>>,
    cache: Res<PipelineCache>,
    extracted: Res<ExtractedSkyLight>,
    frames: Res<FilteredFrames>,
) {
    let compiled = pipelines.is_some_and(|p| {
        [
            p.downsample_first,
            p.downsample_second,
            p.copy,
            p.radiance,
            p.irradiance,
        ]
        .into_iter()
        .all(|id| cache.get_compute_pipeline(id).is_some())
    });
    let (Some(cube), true, false) = (extracted.0, compiled, maps.is_empty()) else {
        return;
    };
    let mut shared = frames.0.lock().unwrap_or_else(|p| p.into_inner());
    *shared = match *shared {
        (Some(last), n) if last == cube => (Some(cube), n + 1),
        _ => (Some(cube), 1),
    };
}

/// A cube being made keeps the editor drawing until it is in, and a new sky light until it lights.
pub fn sky_box_activity(
    cube: Res<SkyBoxCube>,
    mut light: ResMut<SkyLight>,
    mut activity: ResMut<Activity>,
) {
    if cube.making.is_some() {
        activity.busy("sky box");
    }
    if let Some((awaited, since)) = light.awaited {
        let (filtered, frames) = *light.filtered.0.lock().unwrap_or_else(|p| p.into_inner());
        if (filtered == Some(awaited) && frames >= 2) || since.elapsed() > SKY_LIGHT_WAIT {
            light.awaited = None;
        } else {
            activity.busy("sky light");
        }
    }
}

/// The environment light the viewport camera has: the one Bevy filters from the cube, with the
/// panorama's turn and scale.
type CameraLight<'a> = (
    Option<&'a GeneratedEnvironmentMapLight>,
    Option<&'a mut EnvironmentMapLight>,
);

/// Puts the panorama's cube map behind the viewport camera while it rasterises and the panorama is
/// shown, and lights the raster view with it whether shown or not, turned and scaled as the path
/// tracer has it; takes both away otherwise.
pub fn sky_box_to_camera(
    mut commands: Commands,
    cube: Res<SkyBoxCube>,
    environment: Res<SceneEnvironment>,
    render: Res<ViewportRender>,
    mut sky_light: ResMut<SkyLight>,
    mut cameras: Query<(Entity, Option<&Skybox>, CameraLight), With<OrbitCamera>>,
) {
    let light = match (&cube.cube, &environment.image) {
        (Some((image, scale)), Some(_)) if render.traced.is_none() => {
            Some(GeneratedEnvironmentMapLight {
                environment_map: image.clone(),
                intensity: environment.intensity * scale,
                rotation: Quat::from_rotation_y(environment.rotation_radians()),
                ..default()
            })
        }
        _ => None,
    };
    if light.is_none() && sky_light.awaited.is_some() {
        // No light to wait for (the view went path traced, the panorama went): no busy frames.
        sky_light.awaited = None;
    }
    let wanted = match (&cube.cube, &environment.image) {
        (Some((image, scale)), Some(_)) if environment.shown && render.traced.is_none() => {
            Some(Skybox {
                image: Some(image.clone()),
                brightness: environment.intensity * scale,
                rotation: Quat::from_rotation_y(environment.rotation_radians()),
            })
        }
        _ => None,
    };
    for (entity, current, (generated, mut filtered)) in &mut cameras {
        match (&light, generated) {
            (None, Some(_)) => {
                commands
                    .entity(entity)
                    .remove::<(GeneratedEnvironmentMapLight, EnvironmentMapLight)>();
            }
            // A new cube: filtered again.
            (Some(l), g) if g.is_none_or(|g| g.environment_map != l.environment_map) => {
                commands
                    .entity(entity)
                    .remove::<EnvironmentMapLight>()
                    .insert(l.clone());
                sky_light.awaited = Some((l.environment_map.id(), Instant::now()));
            }
            // A new turn or scale: the maps filtered from the cube stay.
            (Some(l), Some(g)) if g.intensity != l.intensity || g.rotation != l.rotation => {
                if let Some(f) = filtered.as_mut() {
                    f.intensity = l.intensity;
                    f.rotation = l.rotation;
                }
                commands.entity(entity).insert(l.clone());
            }
            _ => {}
        }
        match (&wanted, current) {
            (None, Some(_)) => {
                commands.entity(entity).remove::<Skybox>();
            }
            (Some(w), current)
                if current.is_none_or(|c| {
                    c.image != w.image || c.brightness != w.brightness || c.rotation != w.rotation
                }) =>
            {
                commands.entity(entity).insert(w.clone());
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_face_looks_along_its_axis_and_the_faces_cover_every_direction_once() {
        // Bevy samples at (x, y, −z) of the world direction: face 4 (+Z) holds −Z.
        let centres = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, -Vec3::Z, Vec3::Z];
        for (face, c) in centres.iter().enumerate() {
            assert!(
                face_direction(face, 0.0, 0.0).distance(*c) < 1e-6,
                "face {face}"
            );
        }
        // Along each face's edge, the neighbouring face continues it.
        for face in 0..6 {
            for (s, t) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
                let d = face_direction(face, s, t);
                let others = (0..6)
                    .filter(|&f| f != face)
                    .filter(|&f| {
                        [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
                            .iter()
                            .any(|&(a, b)| face_direction(f, a, b).distance(d) < 1e-5)
                    })
                    .count();
                assert_eq!(others, 1, "face {face} at ({s}, {t})");
            }
        }
    }

    #[test]
    fn the_cube_holds_the_panorama_in_each_direction() {
        // A smooth panorama: each texel's value is its direction, mapped to 0..1.
        let (w, h) = (256u32, 128u32);
        let rgba: Vec<[f32; 4]> = (0..h)
            .flat_map(|y| {
                (0..w).map(move |x| {
                    let d = treelight_render::panorama_direction(
                        (x as f32 + 0.5) / w as f32,
                        (y as f32 + 0.5) / h as f32,
                    );
                    [d.x * 0.5 + 0.5, d.y * 0.5 + 0.5, d.z * 0.5 + 0.5, 1.0]
                })
            })
            .collect();
        let (cube, scale) = cube_from_panorama(&rgba, w, h);
        assert_eq!(scale, 1.0);
        let side = cube.width();
        assert_eq!(
            (side, cube.texture_descriptor.size.depth_or_array_layers),
            (64, 6)
        );
        let texel = |face: u32, row: u32, column: u32| {
            let i = ((face * side + row) * side + column) as usize * 8;
            let data = cube.data.as_ref().unwrap();
            [0, 1, 2]
                .map(|k| half::f16::from_le_bytes([data[i + 2 * k], data[i + 2 * k + 1]]).to_f32())
        };
        for face in 0..6u32 {
            for (row, column) in [(0, 0), (10, 50), (32, 32), (63, 7)] {
                let s = (column as f32 + 0.5) / side as f32 * 2.0 - 1.0;
                let t = (row as f32 + 0.5) / side as f32 * 2.0 - 1.0;
                let d = face_direction(face as usize, s, t);
                let got = texel(face, row, column);
                let want = [d.x * 0.5 + 0.5, d.y * 0.5 + 0.5, d.z * 0.5 + 0.5];
                for k in 0..3 {
                    assert!(
                        (got[k] - want[k]).abs() < 0.03,
                        "face {face} ({row}, {column}): {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_sun_brighter_than_a_half_float_is_stored_scaled() {
        let mut rgba = vec![[1.0, 1.0, 1.0, 1.0]; 64 * 32];
        rgba[16 * 64 + 32] = [1.0e6, 1.0e6, 1.0e6, 1.0];
        let (cube, scale) = cube_from_panorama(&rgba, 64, 32);
        assert!(scale > 10.0, "{scale}");
        let data = cube.data.as_ref().unwrap();
        let values: Vec<f32> = data
            .chunks_exact(2)
            .map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32())
            .collect();
        assert!(values.iter().all(|v| v.is_finite()));
    }
}
