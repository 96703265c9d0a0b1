//! Each map's own UV transform, for the materials whose maps do not share one: glTF gives every
//! texture reference its own `KHR_texture_transform`, Bevy's `StandardMaterial` one `uv_transform`
//! (the first map's, which the raster view draws every map with). The shell hands these to the
//! path tracer, which reads each map through its own.

use std::collections::HashMap;

use bevy::math::Affine2;
use bevy::pbr::StandardMaterial;
use bevy::prelude::*;
use treelight_import::ImportedMaterial;

/// Each map's UV transform (base colour, metallic-roughness, normal, occlusion, emission) by
/// material, for the materials whose maps have different ones.
#[derive(Resource, Default, Clone, Debug, PartialEq)]
pub struct MaterialMapTransforms(pub HashMap<AssetId<StandardMaterial>, [Affine2; 5]>);

impl MaterialMapTransforms {
    /// Gives the material `copy` the transforms of `original`, if it has any (a copy made to edit
    /// one object's material alone keeps its maps where they were).
    pub fn copy(&mut self, original: AssetId<StandardMaterial>, copy: AssetId<StandardMaterial>) {
        if let Some(&t) = self.0.get(&original) {
            self.0.insert(copy, t);
        }
    }
}

/// An imported material's maps' transforms, where the maps it has do not all share one.
pub fn of_material(m: &ImportedMaterial) -> Option<[Affine2; 5]> {
    let maps = m.maps();
    let each = maps.map(|r| r.map_or(Affine2::IDENTITY, |r| affine(r.uv_transform)));
    let mut used = maps.iter().zip(each).filter(|(r, _)| r.is_some());
    let first = used.next()?.1;
    used.any(|(_, t)| t != first).then_some(each)
}

/// An imported UV transform (the columns of `TextureRef::uv_transform`) as Bevy's.
pub fn affine([x, y, t]: [[f32; 2]; 3]) -> Affine2 {
    Affine2::from_cols(x.into(), y.into(), t.into())
}

/// Forgets the transforms of materials that are gone.
pub fn forget_removed(
    mut events: MessageReader<AssetEvent<StandardMaterial>>,
    mut transforms: ResMut<MaterialMapTransforms>,
) {
    for e in events.read() {
        if let AssetEvent::Removed { id } = e {
            transforms.0.remove(id);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use treelight_import::{TextureRef, UV_IDENTITY, WrapMode, uv_transform};

    fn map(uv_transform: [[f32; 2]; 3]) -> Option<TextureRef> {
        Some(TextureRef {
            texture: 0,
            wrap: [WrapMode::Repeat; 2],
            uv_transform,
            tex_coord: 0,
        })
    }

    #[test]
    fn only_maps_that_differ_get_transforms_of_their_own() {
        let scaled = uv_transform([0.5, 0.25], 0.0, [2.0, 3.0]);
        let m = ImportedMaterial {
            base_color_texture: map(UV_IDENTITY),
            emissive_texture: map(scaled),
            ..Default::default()
        };
        let each = of_material(&m).expect("the maps differ");
        assert_eq!(each[0], Affine2::IDENTITY);
        assert_eq!(
            each[4],
            Affine2::from_scale_angle_translation(
                bevy::math::Vec2::new(2.0, 3.0),
                0.0,
                bevy::math::Vec2::new(0.5, 0.25)
            )
        );
        // Agreeing maps, one map, or none: the material's one transform serves.
        let agreeing = ImportedMaterial {
            base_color_texture: map(scaled),
            occlusion_texture: map(scaled),
            ..Default::default()
        };
        assert_eq!(of_material(&agreeing), None);
        let one = ImportedMaterial {
            normal_texture: map(scaled),
            ..Default::default()
        };
        assert_eq!(of_material(&one), None);
        assert_eq!(of_material(&ImportedMaterial::default()), None);
    }
}
