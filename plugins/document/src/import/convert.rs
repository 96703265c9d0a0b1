//! Bevy assets from imported data: meshes, images and materials.

use bevy::asset::RenderAssetUsages;
use bevy::image::{ImageAddressMode, ImageSampler, ImageSamplerDescriptor};
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use treelight_import::{ImportedMaterial, ImportedMesh, ImportedTexture, WrapMode};

/// A Bevy triangle-list mesh from an imported one (smooth normals computed where the file has none).
pub fn to_bevy_mesh(m: &ImportedMesh) -> Mesh {
    let mut mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, m.geometry.positions.clone())
    .with_inserted_indices(Indices::U32(m.geometry.indices.clone()));
    if let Some(uvs) = &m.geometry.uvs {
        mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uvs.clone());
    }
    match &m.geometry.normals {
        Some(n) => mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, n.clone()),
        None => mesh.compute_smooth_normals(),
    }
    mesh
}

/// A GPU-only Bevy image from a decoded texture (sRGB colour, the file's wrap modes, bilinear).
pub fn to_bevy_image(t: &ImportedTexture, wrap: [WrapMode; 2]) -> Image {
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
        t.rgba8.clone(),
        TextureFormat::Rgba8UnormSrgb,
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

/// A Bevy material from an imported one (alpha below 1 blends).
pub fn material(m: &ImportedMaterial) -> StandardMaterial {
    let [r, g, b, a] = m.base_color;
    StandardMaterial {
        base_color: Color::LinearRgba(LinearRgba::new(r, g, b, a)),
        metallic: m.metallic,
        perceptual_roughness: m.roughness,
        emissive: LinearRgba::rgb(m.emissive[0], m.emissive[1], m.emissive[2]),
        alpha_mode: if a < 1.0 {
            AlphaMode::Blend
        } else {
            AlphaMode::Opaque
        },
        ..default()
    }
}
