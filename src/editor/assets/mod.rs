//! The Assets panel's contents: the library of folders and their thumbnails ([`library`]), the
//! palette that draws them ([`palette`]) and the sample scenes made in code ([`samples`]).

pub mod library;
pub mod palette;
pub mod samples;

use bevy::prelude::*;

/// The asset library and its thumbnails.
pub struct AssetsPlugin;

impl Plugin for AssetsPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(library::AssetLibraryPlugin)
            .init_resource::<palette::ThumbnailTextures>();
    }
}
