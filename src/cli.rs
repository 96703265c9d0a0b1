//! Command line: `treelight [SCENE_FILE] [--screenshot PATH --frames N]`.

use clap::Parser;
use std::path::PathBuf;

/// Treelight: a Bevy scene editor with a live path-traced preview.
#[derive(Parser, Debug, Clone, Default)]
#[command(version, about)]
pub struct Cli {
    /// A glTF (.gltf or .glb) file to open instead of the built-in default scene.
    pub scene: Option<PathBuf>,
    /// Save a screenshot of the whole window to this PNG file after `--frames` frames, then exit.
    #[arg(long, value_name = "PATH")]
    pub screenshot: Option<PathBuf>,
    /// Frames to render before taking the screenshot (or before exiting, without --screenshot).
    #[arg(long, value_name = "N")]
    pub frames: Option<u32>,
    /// Window width in logical pixels.
    #[arg(long, default_value_t = 1280)]
    pub width: u32,
    /// Window height in logical pixels.
    #[arg(long, default_value_t = 800)]
    pub height: u32,
}
