//! glTF materials as [`ImportedMaterial`]s: the metallic-roughness factors and maps, alpha mode, and
//! the common extensions. Every value is checked: a non-finite or out-of-range factor becomes the
//! nearest valid one (or the default) with a warning naming the material, so a hostile file cannot
//! put a NaN into the renderer.

use crate::scene::imported::{ImportedAlphaMode, ImportedMaterial};
use crate::scene::texture::{ImageCache, UV_IDENTITY, uv_transform};
use crate::scene::texture::{ImportedTexture, TextureRef};
use crate::types::budget::Budget;
use crate::types::error::ImportError;
use gltf::json::Value;
use std::path::Path;

/// What reading a file's materials needs besides the material itself.
pub(crate) struct MaterialReader<'a, 'p> {
    pub path: &'a Path,
    pub buffers: &'a [Vec<u8>],
    pub images: &'a mut ImageCache,
    pub textures: &'a mut Vec<ImportedTexture>,
    pub warnings: &'a mut Vec<String>,
    pub budget: &'a mut Budget<'p>,
    /// The name of the material being read, for warnings.
    pub material: String,
}

/// `KHR_texture_transform` from the raw JSON of a texture reference the gltf crate does not parse
/// it for (normal and occlusion maps): the map and the UV set it overrides.
fn raw_transform(value: Option<&Value>) -> Option<([[f32; 2]; 3], Option<u32>)> {
    let t = value?;
    let pair = |key: &str, default: [f32; 2]| {
        t.get(key)
            .and_then(Value::as_array)
            .and_then(|a| Some([a.first()?.as_f64()? as f32, a.get(1)?.as_f64()? as f32]))
            .unwrap_or(default)
    };
    let rotation = t.get("rotation").and_then(Value::as_f64).unwrap_or(0.0) as f32;
    let tex_coord = t
        .get("texCoord")
        .and_then(Value::as_u64)
        .map(|c| u32::try_from(c).unwrap_or(u32::MAX));
    Some((
        uv_transform(pair("offset", [0.0; 2]), rotation, pair("scale", [1.0; 2])),
        tex_coord,
    ))
}

impl MaterialReader<'_, '_> {
    fn map(
        &mut self,
        texture: gltf::Texture,
        tex_coord: u32,
        map: [[f32; 2]; 3],
        role: &str,
    ) -> Result<Option<TextureRef>, ImportError> {
        let role = format!("material '{}': its {role}", self.material);
        self.images.map(
            self.path,
            self.buffers,
            texture,
            tex_coord,
            map,
            &role,
            self.textures,
            self.warnings,
            self.budget,
        )
    }

    fn info(
        &mut self,
        info: Option<gltf::texture::Info>,
        role: &str,
    ) -> Result<Option<TextureRef>, ImportError> {
        let Some(info) = info else {
            return Ok(None);
        };
        let transform = info.texture_transform();
        let tex_coord = transform
            .as_ref()
            .and_then(|t| t.tex_coord())
            .unwrap_or(info.tex_coord());
        let map = transform.map_or(UV_IDENTITY, |t| {
            uv_transform(t.offset(), t.rotation(), t.scale())
        });
        self.map(info.texture(), tex_coord, map, role)
    }

    /// A normal or occlusion map, whose `KHR_texture_transform` (`transform`) the gltf crate leaves
    /// as raw JSON: it may override the UV set `tex_coord`.
    fn raw_map(
        &mut self,
        texture: gltf::Texture,
        tex_coord: u32,
        transform: Option<&Value>,
        role: &str,
    ) -> Result<Option<TextureRef>, ImportError> {
        let (map, set) = raw_transform(transform).unwrap_or((UV_IDENTITY, None));
        self.map(texture, set.unwrap_or(tex_coord), map, role)
    }

    /// Warns that `what` of material `name` is not read.
    fn unread(&mut self, name: &str, what: &str) {
        self.warnings.push(format!(
            "material '{name}': its {what} is not read; the factor alone is used"
        ));
    }

    /// `value` if finite and within `lo..=hi`; otherwise the nearest bound (or `default` for a
    /// NaN), with a warning.
    fn factor(
        &mut self,
        name: &str,
        what: &str,
        value: f32,
        lo: f32,
        hi: f32,
        default: f32,
    ) -> f32 {
        if value.is_nan() {
            self.warnings.push(format!(
                "material '{name}': its {what} is not a number; {default} is used"
            ));
            return default;
        }
        if value < lo || value > hi {
            let v = value.clamp(lo, hi);
            self.warnings.push(format!(
                "material '{name}': its {what} {value} is outside {lo} to {hi}; {v} is used"
            ));
            return v;
        }
        value
    }

    /// The material `m`, checked.
    pub fn read(&mut self, m: &gltf::Material) -> Result<ImportedMaterial, ImportError> {
        let name = m.name().map_or_else(
            || format!("material {}", m.index().unwrap_or(0)),
            str::to_owned,
        );
        self.material = name.clone();
        let d = ImportedMaterial::default();
        let pbr = m.pbr_metallic_roughness();
        let mut out = ImportedMaterial {
            name: name.clone(),
            ..ImportedMaterial::default()
        };
        let bc = pbr.base_color_factor();
        for (i, v) in bc.into_iter().enumerate() {
            out.base_color[i] = self.factor(&name, "base colour factor", v, 0.0, 1.0, 1.0);
        }
        out.metallic = self.factor(
            &name,
            "metallic factor",
            pbr.metallic_factor(),
            0.0,
            1.0,
            1.0,
        );
        out.roughness = self.factor(
            &name,
            "roughness factor",
            pbr.roughness_factor(),
            0.0,
            1.0,
            1.0,
        );
        // emissive_strength has no upper bound in glTF; the cap keeps sums finite in f32.
        let strength = self.factor(
            &name,
            "emissive strength",
            m.emissive_strength().unwrap_or(1.0),
            0.0,
            1e6,
            1.0,
        );
        for (i, v) in m.emissive_factor().into_iter().enumerate() {
            out.emissive[i] = self.factor(&name, "emissive factor", v, 0.0, 1.0, 0.0) * strength;
        }
        out.base_color_texture = self.info(pbr.base_color_texture(), "base colour texture")?;
        out.metallic_roughness_texture = self.info(
            pbr.metallic_roughness_texture(),
            "metallic-roughness texture",
        )?;
        out.emissive_texture = self.info(m.emissive_texture(), "emission texture")?;
        if let Some(n) = m.normal_texture() {
            out.normal_texture = self.raw_map(
                n.texture(),
                n.tex_coord(),
                n.extension_value("KHR_texture_transform"),
                "normal map",
            )?;
            out.normal_scale = self.factor(
                &name,
                "normal scale",
                n.scale(),
                -100.0,
                100.0,
                d.normal_scale,
            );
        }
        if let Some(o) = m.occlusion_texture() {
            out.occlusion_texture = self.raw_map(
                o.texture(),
                o.tex_coord(),
                o.extension_value("KHR_texture_transform"),
                "occlusion map",
            )?;
            out.occlusion_strength = self.factor(
                &name,
                "occlusion strength",
                o.strength(),
                0.0,
                1.0,
                d.occlusion_strength,
            );
        }
        out.alpha_mode = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => ImportedAlphaMode::Opaque,
            gltf::material::AlphaMode::Blend => ImportedAlphaMode::Blend,
            gltf::material::AlphaMode::Mask => ImportedAlphaMode::Mask {
                cutoff: self.factor(
                    &name,
                    "alpha cutoff",
                    m.alpha_cutoff().unwrap_or(0.5),
                    0.0,
                    1.0,
                    0.5,
                ),
            },
        };
        self.extensions(m, &name, &mut out);
        let mut transforms = out.maps().into_iter().flatten().map(|r| r.uv_transform);
        if let Some(first) = transforms.next()
            && transforms.any(|t| t != first)
        {
            self.warnings.push(format!(
                "material '{name}': its maps have different KHR_texture_transforms; the raster \
                 view draws all with the first map's (the path-traced view each with its own)"
            ));
        }
        Ok(out)
    }

    /// The extensions' values: transmission, index of refraction, specular and clear coat (their
    /// textures are not read, and said so).
    fn extensions(&mut self, m: &gltf::Material, name: &str, out: &mut ImportedMaterial) {
        let d = ImportedMaterial::default();
        if let Some(t) = m.transmission() {
            out.transmission = self.factor(
                name,
                "transmission factor",
                t.transmission_factor(),
                0.0,
                1.0,
                0.0,
            );
            if t.transmission_texture().is_some() {
                self.unread(name, "transmission texture");
            }
        }
        if let Some(ior) = m.ior() {
            // glTF allows 0 as a special case (a perfectly reflective dielectric): read as the
            // nearest ordinary value.
            out.ior = self.factor(name, "index of refraction", ior, 1.0, 5.0, d.ior);
        }
        if let Some(s) = m.specular() {
            out.specular = self.factor(name, "specular factor", s.specular_factor(), 0.0, 1.0, 1.0);
            for (i, v) in s.specular_color_factor().into_iter().enumerate() {
                // The colour factor may exceed 1 (KHR_materials_specular); the product is capped
                // when it meets the Fresnel term.
                out.specular_color[i] = self.factor(name, "specular colour", v, 0.0, 100.0, 1.0);
            }
            if s.specular_texture().is_some() || s.specular_color_texture().is_some() {
                self.unread(name, "specular texture");
            }
        }
        if let Some(c) = m.extension_value("KHR_materials_clearcoat") {
            let number = |key: &str| c.get(key).and_then(Value::as_f64).map(|v| v as f32);
            out.clearcoat = self.factor(
                name,
                "clearcoat factor",
                number("clearcoatFactor").unwrap_or(0.0),
                0.0,
                1.0,
                0.0,
            );
            out.clearcoat_roughness = self.factor(
                name,
                "clearcoat roughness",
                number("clearcoatRoughnessFactor").unwrap_or(0.0),
                0.0,
                1.0,
                0.0,
            );
            if [
                "clearcoatTexture",
                "clearcoatRoughnessTexture",
                "clearcoatNormalTexture",
            ]
            .iter()
            .any(|k| c.get(*k).is_some())
            {
                self.unread(name, "clearcoat texture");
            }
        }
    }
}
