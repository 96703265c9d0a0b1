//! Command line: `treelight [SCENE_FILE] [--screenshot PATH --frames N] [--view MODE]
//! [--frame-budget MS] [--samples N] [--trace-scale SCALE] [--commands EDITS.ron] [--state PATH]`.

use clap::Parser;
use std::path::PathBuf;

/// Treelight: a Bevy scene editor with a live path-traced preview.
#[derive(Parser, Debug, Clone, Default)]
#[command(version, about, args_conflicts_with_subcommands = true)]
pub struct Cli {
    /// Something to do instead of opening the editor.
    #[command(subcommand)]
    pub command: Option<Command>,
    /// A project (.treelight) or a scene file (.gltf, .glb, .obj or .ply) to open instead of the
    /// built-in default scene.
    pub scene: Option<PathBuf>,
    /// Save a screenshot of the whole window to this PNG file after `--frames` frames, then exit.
    #[arg(long, value_name = "PATH")]
    pub screenshot: Option<PathBuf>,
    /// Frames to render before taking the screenshot (or before exiting, without --screenshot);
    /// frames while the path tracer waits for its kernel to compile (a software adapter's first
    /// start) do not count.
    #[arg(long, value_name = "N")]
    pub frames: Option<u32>,
    /// Window width in logical pixels.
    #[arg(long, default_value_t = 1280)]
    pub width: u32,
    /// Window height in logical pixels.
    #[arg(long, default_value_t = 800)]
    pub height: u32,
    /// How the viewport starts: rasterised, path traced, or a debug view of the path tracer.
    #[arg(long, value_enum, default_value_t = ViewArg::Path)]
    pub view: ViewArg,
    /// Look through the scene's camera of this name (a glTF file's) once the scene has loaded.
    #[arg(long, value_name = "NAME")]
    pub camera: Option<String>,
    /// Milliseconds of GPU time a frame may spend path tracing (it may also take as long as the
    /// rest of the frame takes); 0 traces every pixel every frame.
    #[arg(long, value_name = "MS", default_value_t = 4.0)]
    pub frame_budget: f32,
    /// Samples per pixel the path-traced view accumulates before it stops (the toolbar's
    /// Quality menu changes it).
    #[arg(long, value_name = "N", default_value_t = 4096,
          value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub samples: u32,
    /// Traced pixels per viewport pixel along each axis (1: full resolution; 0.5 on a software
    /// adapter unless given).
    #[arg(long, value_name = "SCALE", value_parser = trace_scale)]
    pub trace_scale: Option<f32>,
    /// A RON list of edit commands to apply once the scene has loaded and its BVH is idle.
    #[arg(long, value_name = "EDITS.ron")]
    pub commands: Option<PathBuf>,
    /// Keep this RON file up to date, every frame, with the scene's objects, the selection, the
    /// history's position and the gizmo's handles on screen (for scripts and tests driving the
    /// editor).
    #[arg(long, value_name = "PATH")]
    pub state: Option<PathBuf>,
    /// Save the scene as a project (.treelight) once it has loaded and the commands are applied,
    /// then exit (after `--frames` frames, if given).
    #[arg(long, value_name = "PATH")]
    pub save: Option<PathBuf>,
    /// Hold the frame rate at or below this many frames a second (to save power, or to try the
    /// editor as a slow adapter runs it).
    #[arg(long, value_name = "FPS")]
    pub max_fps: Option<f32>,
    /// Bind at most this many KiB per GPU storage buffer, as an adapter with a smaller limit would
    /// (the path tracer then splits the scene's records across more bindings, and turns itself off
    /// for a scene that needs more than it has, and says so).
    #[arg(long, value_name = "KIB", value_parser = clap::value_parser!(u32).range(1..))]
    pub gpu_binding_limit: Option<u32>,
    /// Hand the scene's records to the GPU in rounds of at most this many KiB (16 MiB without
    /// it): a smaller round holds less memory while a large scene loads, and waits for the GPU
    /// more often.
    #[arg(long, value_name = "KIB", value_parser = clap::value_parser!(u32).range(1..))]
    pub upload_round: Option<u32>,
}

/// A resolution scale from the command line: a number from 0.05 to 4.
fn trace_scale(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if (0.05..=4.0).contains(&v) => Ok(v),
        _ => Err(format!("{text} is not a scale from 0.05 to 4")),
    }
}

/// What `treelight` can do without opening its window.
#[derive(clap::Subcommand, Debug, Clone, PartialEq)]
pub enum Command {
    /// Print what a scene file (.gltf, .glb, .obj, .ply) or project (.treelight) holds, then exit.
    Info {
        /// The file.
        file: PathBuf,
    },
    /// Path trace a scene file or project (the default scene without one) without a window, from
    /// the project's view (a file is framed from above), with its exposure and tone curve, and
    /// save the image.
    Render(RenderArgs),
    /// Print how far each image is from a reference image of the same frame (a render at many
    /// samples): relative mean squared error of linear colour, of display values and of display
    /// values over the reference's detail, and the structural similarity; then exit.
    Compare {
        /// The reference (.png).
        reference: PathBuf,
        /// The images to measure (.png, the reference's size).
        #[arg(required = true)]
        images: Vec<PathBuf>,
        /// Draw each image's difference from the reference into this folder, as
        /// `<image>-residual.png` (red: brighter than the reference, blue: darker, 8× the
        /// difference); an existing file is not replaced.
        #[arg(long, value_name = "DIR")]
        residuals: Option<PathBuf>,
    },
}

/// `treelight render`'s arguments.
#[derive(clap::Args, Debug, Clone, PartialEq)]
pub struct RenderArgs {
    /// A project (.treelight) or a scene file (.gltf, .glb, .obj or .ply); the default scene
    /// without one.
    pub scene: Option<PathBuf>,
    /// The image to write: .png (tone-mapped, 8 bits) or .exr (the exposed radiance in linear
    /// floats, no tone curve).
    #[arg(long, value_name = "IMAGE.png|.exr")]
    pub out: PathBuf,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub spp: u32,
    /// Width in pixels.
    #[arg(long, default_value_t = 640, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Height in pixels.
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    /// Replace the image if the file exists.
    #[arg(long)]
    pub overwrite: bool,
    /// Render through the scene's camera of this name (a glTF file's) instead of the project's
    /// view.
    #[arg(long, value_name = "NAME")]
    pub camera: Option<String>,
    /// Whether the image is denoised (as the viewport is by default).
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub denoise: Switch,
    /// The samples' seed: equal seeds give equal images, another seed another draw of the same
    /// picture's noise (the viewport's is 0).
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Light the scene with this sky panorama (.hdr or .exr, equirectangular) in place of the
    /// project's sky.
    #[arg(long, value_name = "FILE.hdr|.exr")]
    pub sky: Option<PathBuf>,
    /// Turn the sky panorama this many degrees about the vertical (counter-clockwise seen from
    /// above; the project's turn without it).
    #[arg(long, value_name = "DEGREES", allow_negative_numbers = true, value_parser = sky_rotation)]
    pub sky_rotation: Option<f32>,
    /// Nits of a sky panorama value of 1 (the project's, else 1000, without it).
    #[arg(long, value_name = "NITS", value_parser = sky_intensity)]
    pub sky_intensity: Option<f32>,
    /// Whether a scene file without lights gets the editor's default sun (8,000 lux), as it does
    /// when opened in the editor; off renders the file's own light and the sky alone. A project
    /// keeps the lights it has either way.
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub default_sun: Switch,
    /// The most bounces a path takes after the primary hit (Russian roulette ends most paths
    /// before).
    #[arg(long, value_name = "N", default_value_t = treelight_render::DEFAULT_MAX_BOUNCES,
          value_parser = clap::value_parser!(u32).range(1..=256))]
    pub bounces: u32,
    /// The largest luminance, in nits, light reflected twice or more may add to a sample (it
    /// removes rare speckles at the cost of a little energy; direct light is never capped); 0
    /// turns the cap off, for an unbiased image.
    #[arg(long, value_name = "NITS", default_value_t = treelight_render::DEFAULT_INDIRECT_CLAMP,
          value_parser = indirect_clamp)]
    pub indirect_clamp: f32,
    /// Hand the scene's records to the GPU in rounds of at most this many KiB (16 MiB without
    /// it): a smaller round holds less memory while a large scene loads, and waits for the GPU
    /// more often.
    #[arg(long, value_name = "KIB", value_parser = clap::value_parser!(u32).range(1..))]
    pub upload_round: Option<u32>,
}

/// An indirect-light cap from the command line: nits, 0 for none.
fn indirect_clamp(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("{text} is not a luminance of 0 or more nits")),
    }
}

/// A panorama's turn from the command line: degrees within a full turn either way.
fn sky_rotation(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if v.is_finite() && v.abs() <= 360.0 => Ok(v),
        _ => Err(format!("{text} is not a turn from -360 to 360 degrees")),
    }
}

/// A panorama's intensity from the command line: nits from 0 to the scene's maximum.
fn sky_intensity(text: &str) -> Result<f32, String> {
    let max = treelight_document::scene::environment::MAX_ENVIRONMENT_INTENSITY;
    match text.parse::<f32>() {
        Ok(v) if (0.0..=max).contains(&v) => Ok(v),
        _ => Err(format!("{text} is not an intensity from 0 to {max} nits")),
    }
}

/// On or off, on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Switch {
    /// Enabled.
    On,
    /// Disabled.
    Off,
}

/// The viewport modes on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ViewArg {
    /// Bevy's rasteriser.
    Raster,
    /// The path tracer.
    #[default]
    Path,
    /// Base colour at the primary hit.
    Albedo,
    /// Shading normals.
    Normals,
    /// A colour per triangle.
    TriangleId,
    /// Nodes visited per primary ray.
    Heatmap,
}

impl ViewArg {
    /// The path tracer's view, or `None` for raster.
    pub fn debug_view(self) -> Option<treelight_render::DebugView> {
        use treelight_render::DebugView;
        match self {
            ViewArg::Raster => None,
            ViewArg::Path => Some(DebugView::PathTraced),
            ViewArg::Albedo => Some(DebugView::Albedo),
            ViewArg::Normals => Some(DebugView::Normals),
            ViewArg::TriangleId => Some(DebugView::TriangleId),
            ViewArg::Heatmap => Some(DebugView::Heatmap),
        }
    }
}
