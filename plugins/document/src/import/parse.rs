//! Files parsed on a thread of their own by `treelight_import`, with their Bevy meshes and images
//! made there too, each import its own job carrying where it was dropped.

use crate::files::job::Job;
use bevy::math::Ray3d;
use bevy::prelude::*;
use std::path::PathBuf;
use treelight_import::ImportError;

pub use crate::scene::parsed::{ContentHashes, ParsedImports, ParsedScene, Prebuilt, scene_bounds};
/// One file being parsed: its own job, so two drops of one file are two imports, each landing
/// where it was dropped.
pub struct PendingImport {
    /// The file.
    pub path: PathBuf,
    /// The ray through where it was dropped, from the view it was dropped on: `None` for a file
    /// opened otherwise (framed, kept in its own coordinates).
    pub dropped_at: Option<Ray3d>,
    pub(crate) job: Job<Result<ParsedScene, ImportError>>,
}

/// Files being parsed.
#[derive(Resource, Default)]
pub struct PendingImports(pub Vec<PendingImport>);

impl PendingImports {
    /// Starts parsing `path` (and making its Bevy meshes) in the background.
    pub fn start(&mut self, path: PathBuf) {
        self.start_at(path, None);
    }

    /// Starts parsing `path`, dropped at `dropped_at` (see [`PendingImport::dropped_at`]).
    pub fn start_at(&mut self, path: PathBuf, dropped_at: Option<Ray3d>) {
        let p = path.clone();
        let job = Job::spawn(format!("importing {}", p.display()), move || {
            treelight_import::load_scene(&p).map(ParsedScene::from)
        });
        self.0.push(PendingImport {
            path,
            dropped_at,
            job,
        });
    }
}
