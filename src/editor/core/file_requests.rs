//! What other features ask of the File feature, and what it answers: the File menu's actions as
//! messages, the files the user chose for the Assets panel and the sky, and the recent projects.

use bevy::prelude::*;
use std::path::PathBuf;

/// The menu's entries, chosen in the menu bar or by their keys.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FileAction {
    /// File → Open Recent → a project.
    OpenRecent(PathBuf),
    /// File → New.
    New,
    /// File → Open….
    Open,
    /// File → Import….
    Import,
    /// File → Save.
    Save,
    /// File → Save As….
    SaveAs,
    /// File → Quit.
    Quit,
    /// File → Relink….
    Relink,
    /// Assets → Add folder….
    AddAssetFolder,
    /// File → Render image….
    RenderImage,
    /// The sky's Choose…: a panorama, starting in the folder of the one in use (if any).
    ChoosePanorama(Option<PathBuf>),
}

/// A File action asked for by another feature (the menu bar, the Assets panel, the sky controls).
#[derive(Message, Clone, Debug, PartialEq, Eq)]
pub struct FileRequest(pub FileAction);

/// What the user chose in a dialog another feature asked for.
#[derive(Message, Clone, Debug, PartialEq, Eq)]
pub enum FileChosen {
    /// A folder for the Assets panel.
    AssetFolder(PathBuf),
    /// A panorama for the sky.
    Panorama(PathBuf),
}

/// The projects opened or saved lately, newest first (kept in the settings file).
#[derive(Resource, Debug, Default, Clone, PartialEq)]
pub struct RecentProjects(pub Vec<PathBuf>);

impl RecentProjects {
    /// How many are kept.
    pub const MAX: usize = 10;

    /// Puts `path` first.
    pub fn add(&mut self, path: &std::path::Path) {
        let path = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
        self.0.retain(|p| *p != path);
        self.0.insert(0, path);
        self.0.truncate(Self::MAX);
    }
}
