//! Bevy assets from imported data: meshes, images and materials.

use bevy::asset::RenderAssetUsages;
use bevy::image::{ImageAddressMode, ImageSampler, ImageSamplerDescriptor};
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use treelight_import::{
    ImportedAlphaMode, ImportedMaterial, ImportedMesh, ImportedTexture, TextureRef, WrapMode,
};

/// A Bevy triangle-list mesh from an imported one (smooth normals computed where the file has none),
/// with tangents when a normal map is drawn on it (`tangents`; see [`tangents_needed`]), so the
/// raster view shows the map as the path tracer does: the file's where it has them, else made from
/// the UVs.
pub fn to_bevy_mesh(m: &ImportedMesh, tangents: bool) -> Mesh {
    let mut mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, m.geometry.positions.clone())
    .with_inserted_indices(bevy_indices(
        &m.geometry.indices,
        m.geometry.positions.len(),
    ));
    if let Some(uvs) = &m.geometry.uvs {
        mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uvs.clone());
    }
    if let Some(uvs) = &m.geometry.uvs1 {
        mesh.insert_attribute(Mesh::ATTRIBUTE_UV_1, uvs.clone());
    }
    match &m.geometry.normals {
        Some(n) => mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, n.clone()),
        None => mesh.compute_smooth_normals(),
    }
    if tangents && let Some(t) = &m.geometry.tangents {
        mesh.insert_attribute(Mesh::ATTRIBUTE_TANGENT, t.clone());
    } else if tangents
        && let (Some(uvs), Some(bevy::mesh::VertexAttributeValues::Float32x3(normals))) =
            (&m.geometry.uvs, mesh.attribute(Mesh::ATTRIBUTE_NORMAL))
    {
        let t = vertex_tangents(&m.geometry.positions, normals, uvs, &m.geometry.indices);
        mesh.insert_attribute(Mesh::ATTRIBUTE_TANGENT, t);
    }
    mesh
}

/// Triangle-list `indices` into `vertices` vertices as a Bevy mesh keeps them: 16 bits each where
/// every vertex can be named so (most meshes; glTF writers store such indices in 16 bits and the
/// importer widens them), half the bytes of 32.
pub fn bevy_indices(indices: &[u32], vertices: usize) -> Indices {
    if vertices <= usize::from(u16::MAX) + 1
        && let Ok(narrow) = indices.iter().map(|&i| u16::try_from(i)).collect()
    {
        return Indices::U16(narrow);
    }
    Indices::U32(indices.to_vec())
}

/// For each mesh of `scene`, whether its Bevy mesh needs tangents: a normal map is drawn on it, or
/// on another mesh sharing its vertices (`same_as`).
pub fn tangents_needed(scene: &treelight_import::ImportedScene) -> Vec<bool> {
    let mut needed = vec![false; scene.meshes.len()];
    for (j, m) in scene.meshes.iter().enumerate() {
        let mapped = m
            .material
            .and_then(|k| scene.materials.get(k))
            .is_some_and(|mat| mat.normal_texture.is_some());
        if mapped && let Some(n) = needed.get_mut(m.same_as.unwrap_or(j)) {
            *n = true;
        }
    }
    needed
}

/// Per-vertex tangents for normal mapping (glTF's convention, as Bevy's shader reads them): xyz the
/// direction of increasing u in the surface, w the sign that makes `cross(normal, xyz) * w` the
/// direction of increasing v. Each triangle's dP/du and dP/dv are summed at its corners (Lengyel's
/// method), then made perpendicular to the vertex normal; a vertex whose triangles have no UV
/// gradient gets any perpendicular.
pub fn vertex_tangents(
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    uvs: &[[f32; 2]],
    indices: &[u32],
) -> Vec<[f32; 4]> {
    let n = positions.len();
    let mut along_u = vec![Vec3::ZERO; n];
    let mut along_v = vec![Vec3::ZERO; n];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
        if a.max(b).max(c) >= n || a.max(b).max(c) >= uvs.len() {
            continue;
        }
        let p = |i: usize| Vec3::from(positions[i]);
        let q = |i: usize| Vec2::from(uvs[i]);
        let (e1, e2) = (p(b) - p(a), p(c) - p(a));
        let (d1, d2) = (q(b) - q(a), q(c) - q(a));
        let det = d1.x * d2.y - d2.x * d1.y;
        // A NaN determinant fails this too.
        if det.abs().partial_cmp(&1e-20) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let u = (e1 * d2.y - e2 * d1.y) / det;
        let v = (e2 * d1.x - e1 * d2.x) / det;
        if !(u.is_finite() && v.is_finite()) {
            continue;
        }
        for i in [a, b, c] {
            along_u[i] += u;
            along_v[i] += v;
        }
    }
    (0..n)
        .map(|i| {
            let normal = normals.get(i).map_or(Vec3::Y, |&v| Vec3::from(v));
            let normal = normal.try_normalize().unwrap_or(Vec3::Y);
            let t = (along_u[i] - normal * normal.dot(along_u[i]))
                .try_normalize()
                .unwrap_or_else(|| normal.any_orthonormal_vector());
            let w = if normal.cross(t).dot(along_v[i]) < 0.0 {
                -1.0
            } else {
                1.0
            };
            [t.x, t.y, t.z, w]
        })
        .collect()
}

/// How a map's texels are stored on the GPU: colour (sRGB-encoded) or data (linear), with the
/// glTF scales Bevy's material has no field for baked into the texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ImageRole {
    /// Base colour or emission: sRGB.
    Colour,
    /// Metallic-roughness, or a normal or occlusion map at full strength: linear, as stored.
    Data,
    /// A normal map whose x and y are scaled (the `f32`'s bits): linear, scaled and renormalised.
    ScaledNormal(u32),
    /// An occlusion map applied at a strength below one (the `f32`'s bits): its red channel
    /// lifted towards 1.
    WeakOcclusion(u32),
}

/// Which image a material's map needs: the texture, its wrap modes and how it is stored.
pub type ImageKey = (usize, [WrapMode; 2], ImageRole);

/// The slots of Bevy's `StandardMaterial` an imported material fills with images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapSlot {
    /// `base_color_texture`.
    BaseColor,
    /// `metallic_roughness_texture`.
    MetallicRoughness,
    /// `normal_map_texture`.
    Normal,
    /// `occlusion_texture`.
    Occlusion,
    /// `emissive_texture`.
    Emissive,
}

/// Each map of `m` with the image it needs.
pub fn material_maps(m: &ImportedMaterial) -> Vec<(MapSlot, TextureRef, ImageRole)> {
    let normal = if m.normal_scale == 1.0 {
        ImageRole::Data
    } else {
        ImageRole::ScaledNormal(m.normal_scale.to_bits())
    };
    let occlusion = if m.occlusion_strength >= 1.0 {
        ImageRole::Data
    } else {
        ImageRole::WeakOcclusion(m.occlusion_strength.to_bits())
    };
    [
        (MapSlot::BaseColor, m.base_color_texture, ImageRole::Colour),
        (
            MapSlot::MetallicRoughness,
            m.metallic_roughness_texture,
            ImageRole::Data,
        ),
        (MapSlot::Normal, m.normal_texture, normal),
        (MapSlot::Occlusion, m.occlusion_texture, occlusion),
        (MapSlot::Emissive, m.emissive_texture, ImageRole::Colour),
    ]
    .into_iter()
    .filter_map(|(slot, r, role)| Some((slot, r?, role)))
    .collect()
}

/// Puts `image` into the material's `slot`, read through UV set `tex_coord` (0 or 1).
pub fn put_map(m: &mut StandardMaterial, slot: MapSlot, image: Handle<Image>, tex_coord: u32) {
    use bevy::mesh::UvChannel;
    let channel = if tex_coord == 1 {
        UvChannel::Uv1
    } else {
        UvChannel::Uv0
    };
    let (texture, uvs) = match slot {
        MapSlot::BaseColor => (&mut m.base_color_texture, &mut m.base_color_channel),
        MapSlot::MetallicRoughness => (
            &mut m.metallic_roughness_texture,
            &mut m.metallic_roughness_channel,
        ),
        MapSlot::Normal => (&mut m.normal_map_texture, &mut m.normal_map_channel),
        MapSlot::Occlusion => (&mut m.occlusion_texture, &mut m.occlusion_channel),
        MapSlot::Emissive => (&mut m.emissive_texture, &mut m.emissive_channel),
    };
    *texture = Some(image);
    *uvs = channel;
}

/// The texels of `t` as `role` stores them.
fn role_texels(t: &ImportedTexture, role: ImageRole) -> Vec<u8> {
    let mut texels = t.rgba8.clone();
    match role {
        ImageRole::Colour | ImageRole::Data => {}
        ImageRole::ScaledNormal(bits) => {
            let scale = f32::from_bits(bits);
            for p in texels.chunks_exact_mut(4) {
                let c = |v: u8| f32::from(v) / 127.5 - 1.0;
                let n = Vec3::new(c(p[0]) * scale, c(p[1]) * scale, c(p[2]));
                let n = n.try_normalize().unwrap_or(Vec3::Z);
                let q = |v: f32| ((v + 1.0) * 127.5).round().clamp(0.0, 255.0) as u8;
                p[0] = q(n.x);
                p[1] = q(n.y);
                p[2] = q(n.z);
            }
        }
        ImageRole::WeakOcclusion(bits) => {
            let strength = f32::from_bits(bits).clamp(0.0, 1.0);
            for p in texels.chunks_exact_mut(4) {
                let ao = f32::from(p[0]) / 255.0;
                p[0] = ((1.0 + strength * (ao - 1.0)) * 255.0).round() as u8;
            }
        }
    }
    texels
}

/// A GPU-only Bevy image from a decoded texture (the file's wrap modes, bilinear), stored as
/// `role` says.
pub fn to_bevy_image(t: &ImportedTexture, wrap: [WrapMode; 2], role: ImageRole) -> Image {
    let address = |w: WrapMode| match w {
        WrapMode::Repeat => ImageAddressMode::Repeat,
        WrapMode::ClampToEdge => ImageAddressMode::ClampToEdge,
        WrapMode::MirroredRepeat => ImageAddressMode::MirrorRepeat,
    };
    let mut image = Image::new(
        Extent3d {
            width: t.width,
            height: t.height,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        role_texels(t, role),
        if role == ImageRole::Colour {
            TextureFormat::Rgba8UnormSrgb
        } else {
            TextureFormat::Rgba8Unorm
        },
        // The pixels are only needed on the GPU (the path tracer resamples from there too).
        RenderAssetUsages::RENDER_WORLD,
    );
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        address_mode_u: address(wrap[0]),
        address_mode_v: address(wrap[1]),
        ..ImageSamplerDescriptor::linear()
    });
    image
}

/// Bevy's reflectance for a dielectric of index of refraction `ior` whose specular is scaled by
/// `specular` (`KHR_materials_specular`): Bevy's f0 is `0.16 reflectance²`.
fn reflectance(ior: f32, specular: f32) -> f32 {
    let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2) * specular;
    (f0 / 0.16).sqrt().clamp(0.0, 1.0)
}

/// A Bevy material from an imported one, without its images ([`material_maps`] and [`put_map`]
/// add them). The maps share one UV transform, the first map's (Bevy's material has one).
pub fn material(m: &ImportedMaterial) -> StandardMaterial {
    let [r, g, b, a] = m.base_color;
    let [sr, sg, sb] = m.specular_color;
    let uv_transform = material_maps(m)
        .first()
        .map_or(bevy::math::Affine2::IDENTITY, |(_, r, _)| {
            crate::values::map_transforms::affine(r.uv_transform)
        });
    StandardMaterial {
        base_color: Color::LinearRgba(LinearRgba::new(r, g, b, a)),
        metallic: m.metallic,
        perceptual_roughness: m.roughness,
        emissive: LinearRgba::rgb(m.emissive[0], m.emissive[1], m.emissive[2]),
        alpha_mode: match m.alpha_mode {
            ImportedAlphaMode::Opaque => AlphaMode::Opaque,
            ImportedAlphaMode::Mask { cutoff } => AlphaMode::Mask(cutoff),
            ImportedAlphaMode::Blend => AlphaMode::Blend,
        },
        reflectance: reflectance(m.ior, m.specular),
        specular_tint: Color::linear_rgb(sr, sg, sb),
        specular_transmission: m.transmission,
        ior: m.ior,
        clearcoat: m.clearcoat,
        clearcoat_perceptual_roughness: m.clearcoat_roughness,
        uv_transform,
        ..default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use treelight_import::UV_IDENTITY;

    fn texture(rgba: [u8; 4]) -> ImportedTexture {
        ImportedTexture {
            name: "t".into(),
            width: 1,
            height: 1,
            rgba8: rgba.to_vec(),
        }
    }

    #[test]
    fn indices_take_16_bits_where_every_vertex_fits() {
        let small = bevy_indices(&[0, 1, 2, 2, 1, 65_535], 65_536);
        assert!(matches!(&small, Indices::U16(i) if i == &[0, 1, 2, 2, 1, 65_535]));
        let large = bevy_indices(&[0, 1, 65_536], 65_537);
        assert!(matches!(&large, Indices::U32(i) if i == &[0, 1, 65_536]));
        // A mesh with few vertices never has an index past them, but if one came it would not
        // be cut short.
        assert!(matches!(bevy_indices(&[0, 1, 70_000], 3), Indices::U32(_)));
    }

    #[test]
    fn tangents_point_along_u_and_their_sign_gives_v() {
        // A floor quad: u along +x, v along +z (glTF's v runs down the image), normal up.
        let positions = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
        ];
        let normals = [[0.0, 1.0, 0.0]; 4];
        let uvs = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let indices = [0, 2, 1, 0, 3, 2];
        for t in vertex_tangents(&positions, &normals, &uvs, &indices) {
            let (xyz, w) = (Vec3::new(t[0], t[1], t[2]), t[3]);
            assert!((xyz - Vec3::X).length() < 1e-6, "{t:?}");
            // cross(y, x) = -z, so v (+z) needs w = -1.
            assert!((Vec3::Y.cross(xyz) * w - Vec3::Z).length() < 1e-6, "{t:?}");
        }
        // Mirrored UVs flip the sign; tangents stay perpendicular to a tilted normal.
        let mirrored = [[1.0, 0.0], [0.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        let tilted = [[0.0, 0.8, 0.6]; 4];
        for t in vertex_tangents(&positions, &tilted, &mirrored, &indices) {
            let (xyz, w) = (Vec3::new(t[0], t[1], t[2]), t[3]);
            assert!(xyz.dot(Vec3::new(0.0, 0.8, 0.6)).abs() < 1e-6);
            assert!((xyz.length() - 1.0).abs() < 1e-6);
            assert!(xyz.x < -0.9 && w == 1.0, "{t:?}");
        }
        // No UV gradient (every corner at one UV), and indices out of range: still unit tangents.
        let flat = [[0.5, 0.5]; 4];
        for t in vertex_tangents(&positions, &normals, &flat, &[0, 1, 9]) {
            let xyz = Vec3::new(t[0], t[1], t[2]);
            assert!((xyz.length() - 1.0).abs() < 1e-6 && xyz.y.abs() < 1e-6);
        }
    }

    #[test]
    fn imported_materials_become_bevy_materials_value_for_value() {
        let m = ImportedMaterial {
            alpha_mode: ImportedAlphaMode::Mask { cutoff: 0.3 },
            transmission: 0.6,
            clearcoat: 0.75,
            clearcoat_roughness: 0.2,
            ior: 1.5,
            specular: 0.5,
            specular_color: [1.0, 0.5, 0.25],
            ..Default::default()
        };
        let b = material(&m);
        assert_eq!(b.alpha_mode, AlphaMode::Mask(0.3));
        assert_eq!(b.specular_transmission, 0.6);
        assert_eq!((b.clearcoat, b.clearcoat_perceptual_roughness), (0.75, 0.2));
        // f0 = 4% at ior 1.5, halved by the specular factor: 0.16 r² = 0.02.
        assert!((0.16 * b.reflectance * b.reflectance - 0.02).abs() < 1e-6);
        assert_eq!(b.specular_tint.to_linear(), LinearRgba::rgb(1.0, 0.5, 0.25));
        assert_eq!(
            material(&ImportedMaterial::default()).alpha_mode,
            AlphaMode::Opaque
        );
    }

    #[test]
    fn maps_are_stored_as_colour_or_data_with_their_scales_baked_in() {
        let r = TextureRef {
            texture: 0,
            wrap: [WrapMode::Repeat; 2],
            uv_transform: UV_IDENTITY,
            tex_coord: 0,
        };
        let m = ImportedMaterial {
            base_color_texture: Some(r),
            normal_texture: Some(r),
            normal_scale: 0.5,
            occlusion_texture: Some(r),
            occlusion_strength: 0.25,
            ..Default::default()
        };
        let maps = material_maps(&m);
        assert_eq!(maps.len(), 3);
        let role = |slot| maps.iter().find(|x| x.0 == slot).unwrap().2;
        assert_eq!(role(MapSlot::BaseColor), ImageRole::Colour);
        let colour = to_bevy_image(&texture([10, 20, 30, 255]), r.wrap, ImageRole::Colour);
        assert_eq!(
            colour.texture_descriptor.format,
            TextureFormat::Rgba8UnormSrgb
        );
        // A normal tilted 45° towards +x, at half scale: x halved, then renormalised.
        let normal = to_bevy_image(
            &texture([218, 128, 218, 255]),
            r.wrap,
            role(MapSlot::Normal),
        );
        assert_eq!(normal.texture_descriptor.format, TextureFormat::Rgba8Unorm);
        let px = normal.data.as_ref().unwrap();
        let x = f32::from(px[0]) / 127.5 - 1.0;
        let z = f32::from(px[2]) / 127.5 - 1.0;
        assert!((x / z - 0.5).abs() < 0.05, "x {x}, z {z}");
        // Full occlusion (0) at strength 1/4 leaves 3/4 of the light.
        let ao = to_bevy_image(&texture([0, 7, 9, 255]), r.wrap, role(MapSlot::Occlusion));
        let px = ao.data.as_ref().unwrap();
        assert_eq!(px[..3], [191, 7, 9]);
    }
}
