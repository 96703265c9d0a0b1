//! Each map's own UV transform. glTF gives every texture reference its own `KHR_texture_transform`;
//! Bevy's `StandardMaterial` has one `uv_transform` for all its maps. A material whose maps differ is
//! given here ([`MapUvTransforms`]); its object record then names a set of five transforms in a
//! table the kernel reads ([`MapTransformTable`], bound at [`MAP_TRANSFORMS_BINDING`]).

use std::collections::HashMap;

use bevy::math::Affine2;
use bevy::pbr::StandardMaterial;
use bevy::prelude::*;

/// Where the kernel reads the table of transform sets.
pub const MAP_TRANSFORMS_BINDING: u32 = 33;

/// The most transform sets the table holds; materials past it read every map through their
/// `uv_transform` (a warning says so once).
pub const MAX_MAP_TRANSFORM_SETS: u32 = 1 << 16;

/// Bytes of one set in the table: five maps, each its linear part's columns (a `vec4`) and its
/// translation (a `vec4`, zw unused).
pub const MAP_TRANSFORM_SET_BYTES: u64 = 5 * 32;

/// Each map's UV transform, in `MaterialMap` order, for the materials whose
/// maps do not share one: the path tracer reads those maps through these instead of the material's
/// `uv_transform` (which the raster view keeps using). Materials not named here are unaffected.
#[derive(Resource, Default, Clone, Debug, PartialEq)]
pub struct MapUvTransforms(pub HashMap<AssetId<StandardMaterial>, [Affine2; 5]>);

/// The distinct sets of per-map transforms the object records name, in the order first seen: an
/// index, once given, keeps its set, so a record written earlier stays right.
#[derive(Default, Debug)]
pub struct MapTransformTable {
    sets: Vec<[Affine2; 5]>,
    index: HashMap<[u32; 30], u32>,
    warned: bool,
}

impl MapTransformTable {
    /// The index of `transforms` in the table, added if new; `None` once the table is full.
    pub fn set_of(&mut self, transforms: &[Affine2; 5]) -> Option<u32> {
        let key = key(transforms);
        if let Some(&i) = self.index.get(&key) {
            return Some(i);
        }
        let i = self.sets.len() as u32;
        if i >= MAX_MAP_TRANSFORM_SETS {
            if !std::mem::replace(&mut self.warned, true) {
                warn!(
                    "treelight: more than {MAX_MAP_TRANSFORM_SETS} materials with a UV transform \
                     per map; the rest are traced with one transform for all their maps"
                );
            }
            return None;
        }
        self.sets.push(*transforms);
        self.index.insert(key, i);
        Some(i)
    }

    /// Sets the table holds.
    pub fn len(&self) -> usize {
        self.sets.len()
    }

    /// Whether it holds no set.
    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }

    /// The table as the kernel reads it; one identity set when empty, as a binding may not be.
    pub fn bytes(&self) -> Vec<u8> {
        let identity = [[Affine2::IDENTITY; 5]];
        let sets = if self.sets.is_empty() {
            &identity[..]
        } else {
            &self.sets[..]
        };
        let mut out = Vec::with_capacity(sets.len() * MAP_TRANSFORM_SET_BYTES as usize);
        for t in sets.iter().flatten() {
            let m = t.matrix2;
            let words = [
                m.x_axis.x,
                m.x_axis.y,
                m.y_axis.x,
                m.y_axis.y,
                t.translation.x,
                t.translation.y,
                0.0,
                0.0,
            ];
            out.extend_from_slice(bytemuck::cast_slice(&words));
        }
        out
    }
}

/// A set's identity for the table: its floats' bits (equal transforms, equal keys).
fn key(transforms: &[Affine2; 5]) -> [u32; 30] {
    let mut out = [0u32; 30];
    for (k, t) in transforms.iter().enumerate() {
        let f = t.to_cols_array();
        for (j, v) in f.iter().enumerate() {
            out[k * 6 + j] = v.to_bits();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Vec2;

    fn scaled(s: f32) -> Affine2 {
        Affine2::from_scale_angle_translation(Vec2::splat(s), 0.3, Vec2::new(s, -s))
    }

    #[test]
    fn equal_sets_share_an_index_and_the_bytes_hold_each_map_in_order() {
        let mut table = MapTransformTable::default();
        assert_eq!(table.bytes(), MapTransformTable::default().bytes());
        assert_eq!(table.bytes().len() as u64, MAP_TRANSFORM_SET_BYTES);
        let a = [
            scaled(1.0),
            scaled(2.0),
            scaled(3.0),
            scaled(4.0),
            scaled(5.0),
        ];
        let mut b = a;
        b[4] = scaled(6.0);
        assert_eq!(table.set_of(&a), Some(0));
        assert_eq!(table.set_of(&b), Some(1));
        assert_eq!(table.set_of(&a), Some(0));
        assert_eq!(table.len(), 2);
        let bytes = table.bytes();
        assert_eq!(bytes.len() as u64, 2 * MAP_TRANSFORM_SET_BYTES);
        let words: &[f32] = bytemuck::cast_slice(&bytes);
        // Set 1, map 4: the sixth transform's columns and translation.
        let at = (5 + 4) * 8;
        let t = scaled(6.0);
        assert_eq!(words[at..at + 4], t.matrix2.to_cols_array());
        assert_eq!(words[at + 4..at + 6], t.translation.to_array());
    }

    #[test]
    fn a_full_table_names_no_further_set() {
        let mut table = MapTransformTable::default();
        for i in 0..MAX_MAP_TRANSFORM_SETS {
            let t = Affine2::from_translation(Vec2::new(i as f32, 0.0));
            assert_eq!(table.set_of(&[t; 5]), Some(i));
        }
        let past = Affine2::from_translation(Vec2::new(-1.0, 0.0));
        assert_eq!(table.set_of(&[past; 5]), None);
        assert_eq!(
            table.set_of(&[Affine2::from_translation(Vec2::ZERO); 5]),
            Some(0)
        );
    }
}
