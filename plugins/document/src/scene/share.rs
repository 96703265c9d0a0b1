//! One asset per content: a mesh or image an import makes that equals one already in the scene
//! (the same file imported again, a palette item placed twice, two files with the same texture)
//! is that one. The scene BVH then holds its triangles once, each placement an instance, and the
//! path tracer's texture array holds one layer.

use crate::scene::convert::ImageRole;
use bevy::prelude::*;
use std::collections::HashMap;
use std::hash::{BuildHasher, Hasher, RandomState};
use std::sync::OnceLock;
use treelight_import::{MeshGeometry, WrapMode};

/// The hashes' key, drawn once per process: a file cannot be made to collide with another's
/// content, so two contents share an asset only by a 1 in 2^64 chance per pair.
fn keys() -> &'static RandomState {
    static KEYS: OnceLock<RandomState> = OnceLock::new();
    KEYS.get_or_init(RandomState::new)
}

/// The content of a Bevy mesh made from `geometry` (with tangents or not).
pub fn mesh_hash(geometry: &MeshGeometry, tangents: bool) -> u64 {
    let mut h = keys().build_hasher();
    h.write_u8(u8::from(tangents));
    h.write_usize(geometry.positions.len());
    h.write(bytemuck::cast_slice(&geometry.positions));
    h.write_usize(geometry.indices.len());
    h.write(bytemuck::cast_slice(&geometry.indices));
    write_optional(&mut h, geometry.normals.as_deref());
    write_optional(&mut h, geometry.uvs.as_deref());
    write_optional(&mut h, geometry.uvs1.as_deref());
    write_optional(&mut h, geometry.tangents.as_deref());
    h.finish()
}

/// An optional attribute: whether it is there, then its bytes.
fn write_optional<T: bytemuck::Pod>(h: &mut impl Hasher, values: Option<&[T]>) {
    match values {
        Some(v) => {
            h.write_u8(1);
            h.write(bytemuck::cast_slice(v));
        }
        None => h.write_u8(0),
    }
}

/// The content of a decoded texture.
pub fn texture_hash(t: &treelight_import::ImportedTexture) -> u64 {
    let mut h = keys().build_hasher();
    h.write_u32(t.width);
    h.write_u32(t.height);
    h.write(&t.rgba8);
    h.finish()
}

/// The content of a Bevy image made from a texture whose content is `texture`, with `wrap` and
/// stored as `role`.
pub fn image_hash(texture: u64, wrap: [WrapMode; 2], role: ImageRole) -> u64 {
    let mut h = keys().build_hasher();
    h.write_u64(texture);
    std::hash::Hash::hash(&wrap, &mut h);
    std::hash::Hash::hash(&role, &mut h);
    h.finish()
}

/// The meshes and images imports made, by content: weak ids, so an asset nothing uses any more
/// goes as usual and a later import makes it again.
#[derive(Resource, Default, Debug)]
pub struct SharedAssets {
    meshes: HashMap<u64, AssetId<Mesh>>,
    images: HashMap<u64, AssetId<Image>>,
}

impl SharedAssets {
    /// The mesh with content `hash`: the one already in `assets`, else `make`'s, added.
    pub fn mesh(
        &mut self,
        hash: u64,
        assets: &mut Assets<Mesh>,
        make: impl FnOnce() -> Mesh,
    ) -> Handle<Mesh> {
        shared(&mut self.meshes, hash, assets, make)
    }

    /// The image with content `hash`: the one already in `assets`, else `make`'s, added.
    pub fn image(
        &mut self,
        hash: u64,
        assets: &mut Assets<Image>,
        make: impl FnOnce() -> Image,
    ) -> Handle<Image> {
        shared(&mut self.images, hash, assets, make)
    }
}

fn shared<A: Asset>(
    table: &mut HashMap<u64, AssetId<A>>,
    hash: u64,
    assets: &mut Assets<A>,
    make: impl FnOnce() -> A,
) -> Handle<A> {
    if let Some(h) = table
        .get(&hash)
        .and_then(|&id| assets.get_strong_handle(id))
    {
        return h;
    }
    // Ids of assets gone since are dropped now and then, so the table stays the size of the scene.
    if table.len() >= 1024 && table.len().is_power_of_two() {
        table.retain(|_, id| assets.contains(*id));
    }
    let h = assets.add(make());
    table.insert(hash, h.id());
    h
}
