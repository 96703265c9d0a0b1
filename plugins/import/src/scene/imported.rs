//! What a reader returns: meshes with their world transforms, materials, lights and cameras.

use crate::scene::texture::{ImportedTexture, TextureRef};
use glam::{Mat4, Vec3};
use std::sync::Arc;

/// How a material's alpha (base colour alpha times the texture's) is used.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum ImportedAlphaMode {
    /// Alpha is ignored: the surface is solid.
    #[default]
    Opaque,
    /// Where alpha is below the cutoff the surface is not there at all (leaves, fences).
    Mask {
        /// The alpha below which a point is cut away (glTF's default 0.5).
        cutoff: f32,
    },
    /// The surface lets `1 - alpha` of the light through.
    Blend,
}

/// Surface parameters: glTF's metallic-roughness model with its maps, alpha mode and the common
/// material extensions (`KHR_materials_transmission`, `ior`, `clearcoat`, `specular`,
/// `emissive_strength`). Each map names the UV set it reads (`TextureRef::tex_coord`).
#[derive(Clone, Debug, PartialEq)]
pub struct ImportedMaterial {
    /// Material name, or a generated one.
    pub name: String,
    /// Linear RGBA base colour factor.
    pub base_color: [f32; 4],
    /// Metalness factor.
    pub metallic: f32,
    /// Perceptual roughness factor.
    pub roughness: f32,
    /// Linear emitted radiance (factor times strength).
    pub emissive: [f32; 3],
    /// Base-colour texture (sRGB colour, linear alpha), multiplied with `base_color`.
    pub base_color_texture: Option<TextureRef>,
    /// Roughness in its green channel and metalness in its blue (linear), multiplying the factors.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Tangent-space normal map (linear).
    pub normal_texture: Option<TextureRef>,
    /// Scale of the normal map's x and y.
    pub normal_scale: f32,
    /// Ambient occlusion in its red channel (linear).
    pub occlusion_texture: Option<TextureRef>,
    /// How much of the occlusion map applies, 0 to 1.
    pub occlusion_strength: f32,
    /// Emission map (sRGB), multiplying `emissive`.
    pub emissive_texture: Option<TextureRef>,
    /// What alpha means.
    pub alpha_mode: ImportedAlphaMode,
    /// Fraction of the light that is not reflected which passes through (thin-walled), 0 to 1.
    pub transmission: f32,
    /// Index of refraction of the dielectric (1.5 by default).
    pub ior: f32,
    /// Strength of a clear coat over the surface, 0 to 1.
    pub clearcoat: f32,
    /// Perceptual roughness of the clear coat.
    pub clearcoat_roughness: f32,
    /// Strength of the dielectric's specular reflection (`KHR_materials_specular`), 0 to 1.
    pub specular: f32,
    /// Linear tint of the dielectric's specular reflection at normal incidence.
    pub specular_color: [f32; 3],
}

impl ImportedMaterial {
    /// Its maps: base colour, metallic-roughness, normal, occlusion, emission.
    pub fn maps(&self) -> [Option<TextureRef>; 5] {
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            self.occlusion_texture,
            self.emissive_texture,
        ]
    }
}

impl Default for ImportedMaterial {
    fn default() -> Self {
        Self {
            name: "default".into(),
            base_color: [0.8, 0.8, 0.8, 1.0],
            metallic: 0.0,
            roughness: 0.6,
            emissive: [0.0; 3],
            base_color_texture: None,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive_texture: None,
            alpha_mode: ImportedAlphaMode::Opaque,
            transmission: 0.0,
            ior: 1.5,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            specular: 1.0,
            specular_color: [1.0; 3],
        }
    }
}

/// One node of a file's hierarchy (glTF nodes; OBJ and PLY files have none).
#[derive(Clone, Debug, PartialEq)]
pub struct ImportedNode {
    /// The node's name (`node N` when it has none).
    pub name: String,
    /// Index of its parent in [`ImportedScene::nodes`]; parents come before their children.
    pub parent: Option<usize>,
    /// Node to parent (to the file's root for a top-level node).
    pub local: Mat4,
    /// A key that finds the node again in a later version of the file: the names from the top,
    /// joined by `/`, each `#index` where a node has no name.
    pub key: String,
    /// The light at the node (glTF's `KHR_lights_punctual`), shining along the node's -z axis.
    pub light: Option<ImportedLight>,
    /// The camera at the node, looking along the node's -z axis with +y up.
    pub camera: Option<ImportedCamera>,
}

/// A glTF camera, checked: finite values, a field of view within (0, π), `0 < near < far`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ImportedCamera {
    /// A pinhole camera.
    Perspective {
        /// Vertical field of view, radians.
        yfov: f32,
        /// Distance to the near plane.
        near: f32,
        /// Distance to the far plane; `None`: infinite.
        far: Option<f32>,
        /// Width over height the file meant; `None`: the viewport's.
        aspect: Option<f32>,
    },
    /// A parallel projection.
    Orthographic {
        /// Half the view's height.
        ymag: f32,
        /// Half the view's width.
        xmag: f32,
        /// Distance to the near plane.
        near: f32,
        /// Distance to the far plane.
        far: f32,
    },
}

/// A punctual light as glTF gives it, checked: finite, non-negative colour and intensity, a
/// positive range, a cone within `0 <= inner <= outer <= π/2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportedLight {
    /// Which kind.
    pub kind: ImportedLightKind,
    /// Colour, linear RGB.
    pub color: [f32; 3],
    /// Candela for point and spot lights, lux for directional ones.
    pub intensity: f32,
    /// Distance at which the light has faded to nothing; `None`: no limit.
    pub range: Option<f32>,
}

/// The kinds of punctual light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ImportedLightKind {
    /// Light from a point, in every direction.
    Point,
    /// Parallel light along the node's -z axis.
    Directional,
    /// Light from a point in a cone around the node's -z axis.
    Spot {
        /// Full intensity within this angle of the axis (radians).
        inner_angle: f32,
        /// No light past this angle (radians).
        outer_angle: f32,
    },
}

/// A mesh's vertex data, in object space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshGeometry {
    /// Vertex positions, all finite.
    pub positions: Vec<[f32; 3]>,
    /// Vertex normals, one per position, if the file has them.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Texture coordinates, one per position, if the file has them: glTF's `TEXCOORD_0`, or its
    /// `TEXCOORD_1` where the mesh's material reads all its colour, metallic-roughness, normal and
    /// emission maps through that set (the sets are then exchanged, and the maps' `tex_coord`s, so
    /// that a consumer reading one set draws the material whole).
    pub uvs: Option<Vec<[f32; 2]>>,
    /// A second set of texture coordinates (which maps such as baked occlusion may read), one per
    /// position, if the file has them: glTF's `TEXCOORD_1`, or `TEXCOORD_0` where the sets were
    /// exchanged.
    pub uvs1: Option<Vec<[f32; 2]>>,
    /// Vertex tangents for normal maps, one per position, if the file has them (glTF's
    /// `TANGENT`): xyz of unit length, w the bitangent's sign (±1).
    pub tangents: Option<Vec<[f32; 4]>>,
    /// Triangle list indices into the vertex arrays, all in range.
    pub indices: Vec<u32>,
}

/// One triangle mesh placed in the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportedMesh {
    /// Node (or object) name.
    pub name: String,
    /// Object to world: the product of its node's and its ancestors' local transforms.
    pub transform: Mat4,
    /// The node it hangs under, in [`ImportedScene::nodes`] (`None` for OBJ and PLY meshes).
    pub node: Option<usize>,
    /// Its vertex data, shared (not copied) by every node that places the same mesh.
    pub geometry: Arc<MeshGeometry>,
    /// Index into [`ImportedScene::materials`].
    pub material: Option<usize>,
    /// The earlier mesh in [`ImportedScene::meshes`] with the same vertex data, when the file
    /// places one mesh at several nodes or primitives share their accessors (glTF): both hold the
    /// same [`MeshGeometry`], and a consumer may share its own copy of that mesh too.
    pub same_as: Option<usize>,
}

impl ImportedMesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.geometry.indices.len() / 3
    }

    /// Triangles in world space, in index order.
    pub fn world_triangles(&self) -> impl Iterator<Item = [Vec3; 3]> + '_ {
        let m = self.transform;
        let g = &self.geometry;
        g.indices.chunks_exact(3).map(move |f| {
            [f[0], f[1], f[2]].map(|i| m.transform_point3(Vec3::from(g.positions[i as usize])))
        })
    }
}

/// What a file held.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportedScene {
    /// Meshes in file order.
    pub meshes: Vec<ImportedMesh>,
    /// The node hierarchy the meshes hang under, parents first.
    pub nodes: Vec<ImportedNode>,
    /// Materials referenced by the meshes.
    pub materials: Vec<ImportedMaterial>,
    /// Decoded images the materials refer to, once each.
    pub textures: Vec<ImportedTexture>,
    /// Things skipped, each naming what and why (non-triangle primitives, say).
    pub warnings: Vec<String>,
}

impl ImportedScene {
    /// All triangles in world space, mesh by mesh in file order.
    pub fn world_triangles(&self) -> Vec<[Vec3; 3]> {
        self.meshes
            .iter()
            .flat_map(|m| m.world_triangles())
            .collect()
    }

    /// Total triangle count.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.triangle_count()).sum()
    }
}
