//! What a path-traced camera is asked to show: the camera component, its debug views and outlines.

use crate::types::budget::FrameBudget;
use bevy::camera::{Camera, Hdr};
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponent;

/// What a path-traced camera shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum DebugView {
    /// The converged path-traced image.
    #[default]
    PathTraced,
    /// Surface base colour at the primary hit.
    Albedo,
    /// Shading normal at the primary hit.
    Normals,
    /// A colour per primary-hit triangle id.
    TriangleId,
    /// Nodes visited per primary ray: the tree's quality at a glance.
    Heatmap,
}

impl DebugView {
    /// Every view, in menu order.
    pub const ALL: [DebugView; 5] = [
        DebugView::PathTraced,
        DebugView::Albedo,
        DebugView::Normals,
        DebugView::TriangleId,
        DebugView::Heatmap,
    ];

    /// The view's index as the shader reads it.
    pub fn shader_index(self) -> u32 {
        self as u32
    }

    /// A name for menus.
    pub fn label(self) -> &'static str {
        match self {
            DebugView::PathTraced => "Path traced",
            DebugView::Albedo => "Albedo",
            DebugView::Normals => "Normals",
            DebugView::TriangleId => "Triangle id",
            DebugView::Heatmap => "Traversal heatmap",
        }
    }
}

/// Turns a Bevy 3D camera into a live path-traced view. Requires [`Hdr`] so that Bevy's tonemapping
/// applies to the traced radiance.
///
/// Each frame traces what fits its budget: a coarse preview right after anything changes (the
/// camera, an object, a material), then runs of 8×8 tiles spread over the image, each pixel
/// accumulating its own samples, so the frame rate holds while the image converges. The camera
/// rasterises no meshes (the traced image replaces them); the traced depth is written to its
/// depth buffer, so gizmos and other overlays drawn after are hidden behind traced surfaces.
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect, ExtractComponent)]
#[extract_component_filter(With<Camera>)]
#[require(Hdr)]
pub struct PathTraced {
    /// Bounces after the primary hit, at most (Russian roulette ends most paths well before; the
    /// preview shown while the camera moves takes one).
    pub max_bounces: u32,
    /// Samples a traced pixel adds at once.
    pub samples_per_frame: u32,
    /// Stop accumulating after this many samples per pixel (0: never stop).
    pub max_samples: u32,
    /// Traced pixels per viewport pixel along each axis (below 1 trades sharpness for speed on slow
    /// adapters; the image is upscaled).
    pub resolution_scale: f32,
    /// Radiance of the sky rays escape to, linear RGB in nits (scaled by the camera's exposure
    /// like every light).
    pub sky: LinearRgba,
    /// Largest luminance, in nits, that light reflected twice or more may add to a sample. Rare
    /// paths that find a light from up close after a bounce otherwise show as speckles for
    /// thousands of samples; the cap removes them at the cost of a little energy. Direct light
    /// (seen, or reflected once) is never capped, and the cap is in scene units, so the camera's
    /// exposure changes no radiance. 0 turns it off (unbiased).
    pub indirect_clamp: f32,
    /// What to show.
    pub view: DebugView,
    /// Milliseconds of GPU time a frame may always spend tracing (measured with timestamp queries
    /// where the adapter has them, else estimated from frame intervals). Zero traces the whole
    /// image every frame.
    pub frame_budget_ms: f32,
    /// Share of the rest of the frame's time the trace may take when that is more than
    /// `frame_budget_ms`: on a slow adapter the preview keeps up while the frame rate stays within
    /// `1 / (1 + share)` of what the rest of the frame allows.
    pub frame_budget_share: f32,
    /// The most `frame_budget_share` may be while new geometry is on its way into the scene's
    /// tree (an import streaming in): each frame's new triangles restart the view's samples, so a
    /// trace beyond the preview is thrown away next frame, and the cores it would take fill the
    /// tree instead.
    pub frame_budget_share_while_filling: f32,
    /// How [`Outlined`] meshes are outlined in this view.
    pub outline: OutlineStyle,
    /// Whether the path-traced image is denoised: an edge-aware filter guided by the primary
    /// hits' objects, normals, depths and albedo (the debug views never are).
    pub denoise: bool,
    /// Whether, while denoising, what the view showed is carried through camera moves: each pixel's
    /// primary hit is found where the last frame saw it and that picture mixed in until the pixel
    /// has samples enough of its own. For views that move (an editor's); a still render gains
    /// nothing.
    pub temporal: bool,
    /// The samples' seed: a pixel's n-th sample is the same for the same seed (so equal seeds give
    /// equal images), and unrelated under another (a reference image whose noise is independent
    /// of the one it measures).
    pub seed: u32,
}

/// [`PathTraced::max_bounces`] by default: enough that a converged image lacks no light a
/// reference renderer finds (Russian roulette, not the cap, ends nearly every path).
pub const DEFAULT_MAX_BOUNCES: u32 = 16;

/// [`PathTraced::indirect_clamp`] by default, in nits: ten times the white of Bevy's default
/// exposure (EV100 9.7, about 1,000 nits), as Cycles caps indirect light at ten times its white.
/// A white wall in 8,000 lux of sun is about 2,500 nits, so ordinary light bounced off it passes.
pub const DEFAULT_INDIRECT_CLAMP: f32 = 10_000.0;

/// How a path-traced view outlines [`Outlined`] meshes.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct OutlineStyle {
    /// The colour around [`Outlined::Selected`] meshes: linear HDR, as the image is before
    /// tonemapping (so the camera's tonemapping applies to it too).
    pub selected: LinearRgba,
    /// The colour around [`Outlined::Active`] meshes.
    pub active: LinearRgba,
    /// The line's width in target pixels (at most 8; 0 draws none).
    pub width: f32,
}

impl Default for OutlineStyle {
    fn default() -> Self {
        Self {
            selected: LinearRgba::rgb(0.9, 0.16, 0.0),
            active: LinearRgba::rgb(1.5, 0.36, 0.0),
            width: 2.0,
        }
    }
}

/// Marks a mesh entity that every path-traced view outlines: a line of [`OutlineStyle`]'s width
/// around its visible silhouette, drawn from the object ids of the primary hits the views trace
/// anyway, so it is complete in every frame and costs no extra rays. Meant for selections: an
/// editor puts it on the meshes of what is selected (the component is not inherited by children).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum Outlined {
    /// Part of the selection.
    #[default]
    Selected,
    /// The selection's active object, drawn in [`OutlineStyle::active`].
    Active,
}

impl Outlined {
    /// The value the resolve shader reads (1 or 2).
    pub fn shader_value(self) -> u32 {
        match self {
            Outlined::Selected => 1,
            Outlined::Active => 2,
        }
    }
}

impl PathTraced {
    /// How long a frame of this view may trace, `filling` while new geometry is on its way into
    /// the scene's tree (the share held to `frame_budget_share_while_filling`).
    pub fn frame_budget(&self, filling: bool) -> FrameBudget {
        FrameBudget {
            millis: self.frame_budget_ms,
            share: if filling {
                self.frame_budget_share
                    .min(self.frame_budget_share_while_filling)
            } else {
                self.frame_budget_share
            },
            max_samples: if filling {
                crate::types::budget::FILLING_MAX_SAMPLES
            } else {
                u64::MAX
            },
        }
    }
}

impl Default for PathTraced {
    fn default() -> Self {
        Self {
            max_bounces: DEFAULT_MAX_BOUNCES,
            samples_per_frame: 1,
            max_samples: 4096,
            resolution_scale: 1.0,
            sky: LinearRgba::rgb(110.0, 140.0, 200.0),
            indirect_clamp: DEFAULT_INDIRECT_CLAMP,
            view: DebugView::PathTraced,
            frame_budget_ms: 4.0,
            frame_budget_share: 1.0,
            frame_budget_share_while_filling: 0.1,
            outline: OutlineStyle::default(),
            denoise: true,
            temporal: true,
            seed: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::budget::{FILLING_MAX_SAMPLES, FIRST_GUESS_SAMPLES, TraceClock};

    #[test]
    fn while_the_tree_fills_the_trace_takes_a_smaller_share_of_the_frame() {
        let settings = PathTraced::default();
        let (calm, filling) = (settings.frame_budget(false), settings.frame_budget(true));
        assert_eq!(calm.share, settings.frame_budget_share);
        assert_eq!(filling.share, settings.frame_budget_share_while_filling);
        assert_eq!(calm.millis, filling.millis);
        // A slow frame (the rest 1 s, a sample 1 µs): the trace's samples follow the share.
        let mut clock = TraceClock::default();
        clock.observe_trace(1000, 1e6);
        for k in 0..8 {
            clock.observe_frame(600_000 + k * 10, 1.6e9);
        }
        let (a, b) = (clock.sample_budget(&calm), clock.sample_budget(&filling));
        assert!(b * 5 < a, "{a} samples as usual, {b} while filling");
        // Whatever the estimate says, a filling frame traces a preview at most.
        let mut cheap = TraceClock::default();
        for _ in 0..8 {
            cheap.observe_trace(1_000_000, 1e6);
            cheap.observe_frame(1_000_000, 1.6e9);
        }
        assert!(cheap.sample_budget(&calm) > 1_000_000);
        assert_eq!(cheap.sample_budget(&filling), FILLING_MAX_SAMPLES);
        // A share already below the cap stays.
        let low = PathTraced {
            frame_budget_share: 0.05,
            ..settings
        };
        assert_eq!(low.frame_budget(true).share, 0.05);
    }

    #[test]
    fn a_scene_of_a_new_size_is_traced_at_a_first_guess_until_it_is_timed() {
        let budget = PathTraced::default().frame_budget(false);
        let mut clock = TraceClock::default();
        clock.scene_size(1024);
        // An empty scene: the sky alone, 10 ns a sample, frames of 50 ms.
        for k in 0..16 {
            let samples = clock.sample_budget(&budget) + k * 1000;
            clock.observe_trace(samples, samples as f64 * 10.0);
            clock.observe_frame(samples, 5e7);
        }
        let cheap = clock.sample_budget(&budget);
        assert!(cheap > 1_000_000, "{cheap}");
        let epoch = clock.epoch();
        clock.scene_size(1024);
        assert_eq!(
            clock.sample_budget(&budget),
            cheap,
            "the same size keeps its figures"
        );
        // Millions of triangles arrive: the next frame traces a first guess, not a stall's worth.
        clock.scene_size(1 << 24);
        assert_ne!(clock.epoch(), epoch);
        assert_eq!(clock.sample_budget(&budget), FIRST_GUESS_SAMPLES);
        // Timed at 4 µs a sample, it traces what the budget allows at that cost.
        clock.observe_trace(4096, 4096.0 * 4000.0);
        let timed = clock.sample_budget(&budget);
        assert!(timed < cheap / 100, "{timed} against {cheap}");
    }

    #[test]
    fn a_cost_timestamps_read_low_is_corrected_even_when_the_budget_passes_a_sweep() {
        // A software adapter: a sample really costs 10 µs, its timestamps say 1 µs; the rest of
        // the frame takes 1.5 s, so the budget (the share is 1) always covers a whole sweep.
        let budget = PathTraced::default().frame_budget(false);
        let (per_tile, total) = (64, 2160);
        let mut clock = TraceClock::default();
        clock.scene_size(1 << 20);
        // While the tree filled, every frame restarted: a preview of a fixed 3,780 blocks, in
        // frames made slow by the uploads (3 s). That leaves the fit nothing to go on.
        for _ in 0..30 {
            clock.observe_trace(3780, 3780.0 * 1e3);
            clock.observe_frame(3780, 3e9);
        }
        let mut interval = 0.0;
        for _ in 0..60 {
            let tiles = clock.tiles(clock.sample_budget(&budget), per_tile, total);
            assert!((1..=total).contains(&tiles));
            let samples = tiles as u64 * per_tile;
            clock.observe_trace(samples, samples as f64 * 1e3);
            interval = 1.5e9 + samples as f64 * 1e4;
            clock.observe_frame(samples, interval);
        }
        let cost = clock.ns_per_sample().unwrap();
        assert!(cost > 8e3, "{cost} ns a sample, the timestamps' 1 µs kept");
        // An unbounded budget (`--frame-budget 0`) traces whole sweeps every frame.
        for _ in 0..2 {
            assert_eq!(clock.tiles(u64::MAX, per_tile, total), total);
            clock.observe_frame(1, 1e6);
        }
        assert!(interval < 3.0e9, "{interval}");
    }
}
