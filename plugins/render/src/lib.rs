//! # treelight_render
//!
//! [`PathTracerPlugin`] and the camera component [`PathTraced`] turn any Bevy 3D camera into a live
//! path-traced view of what `treelight_scene`'s [`SceneBvhPlugin`](treelight_scene::SceneBvhPlugin)
//! tracks. It is laid out as Bevy's own render features are: extraction takes the scene's change set
//! and turns it into record writes ([`UploadPlan`]); prepare grows and patches the GPU buffers and
//! readies each view's uniforms and bind groups; the node, a system in the camera's `Core3d`
//! schedule, only binds and dispatches the compute pass that traces the tree and accumulates
//! samples, and the small render pass that writes the average into the view target, in HDR, before
//! Bevy's tonemapping.

// Every public item says what it is for: the crate is meant to be used from other apps.
#![warn(missing_docs)]

mod budget;
mod energy;
mod environment;
mod extract;
mod gpu_memory;
mod identity;
mod kernel_warmup;
mod map_transforms;
mod node;
mod parts;
mod pipelines;
mod prepare;
mod raster_meshes;
mod raster_skip;
mod records;
mod staging;
mod texture_layers;
mod timing;
mod upload;

pub use budget::{
    CostSource, FrameBudget, MAX_PREVIEW_SCALE, TILE, TileCursor, TileOrder, TraceClock,
    preview_scale,
};
pub use energy::{ENERGY_BINDING, ENERGY_SIZE, energy_bytes, energy_table, split_sum};
pub use environment::{
    ENVIRONMENT_BINDINGS, EnvironmentTexels, MAX_DISTRIBUTION_WIDTH, PathTracedEnvironment,
    PreparedEnvironment, environment_uniform, panorama_coordinates, panorama_direction,
};
pub use kernel_warmup::KernelCompileRecord;
pub use map_transforms::{
    MAP_TRANSFORM_SET_BYTES, MAP_TRANSFORMS_BINDING, MAX_MAP_TRANSFORM_SETS, MapTransformTable,
    MapUvTransforms,
};
pub use parts::{MAX_PART_SHIFT, PartLayout, part_bindings, part_count, trace_storage_buffers};
pub use raster_meshes::HoldBackRasterMeshes;
pub use records::{
    ATTRIBUTE_BYTES, DENOISE_PASSES, GpuAoParams, GpuAttribute, GpuDenoise, GpuLight, GpuObject,
    GpuPrimaryCamera, GpuResolve, GpuTemporal, GpuView, LIGHT_BYTES, LayerTexture, MaterialMap,
    OBJECT_BYTES, ResolveParams, SceneLight, SurfaceAlpha, SurfaceMaterial, TEMPORAL_FADE_SAMPLES,
    TEMPORAL_MAX_WEIGHT, TemporalRestart, TextureWrap, TraceWork, VIEW_BYTES, ViewParams,
    attribute_bytes, attribute_record, aux_bytes, decode_normal, decode_tangents,
    denoise_pass_bytes, denoise_passes, denoise_target, encode_normal, encode_tangents,
    guide_bytes, light_bytes, object_bytes, outline_words, packed_attribute_record, set_outline,
    temporal_bytes,
};
pub use staging::{CHUNK_BYTES, UploadBelt};
pub use texture_layers::{
    MAX_TEXTURE_LAYERS, MIN_TEXTURE_LAYER_SIZE, TEXTURE_BUDGET_BYTES, TEXTURE_LAYER_SIZE,
    layer_side_for, layers_at,
};
pub use upload::{
    BufferKind, BufferWrite, UploadPlan, Writes, grown_capacity, instance_bytes, node_bytes,
    triangle_bytes,
};

use bevy::camera::{Camera, Hdr};
use bevy::prelude::*;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

// Each kernel file declares the buffers; a traversal (`traverse_wide.wgsl` or `traverse.wgsl`, with
// its record file and `traverse_common.wgsl`) and `sampling.wgsl` (random numbers, frames, offsets)
// are appended to it, as WGSL resolves module-scope names in any order.

/// WGSL: the path-tracing kernel (`path_trace`) with the traversal (the compressed 4-wide records
/// of `treelight_bvh::Bvh::gpu_wide_node`).
pub const PATHTRACE_WGSL: &str = concat!(
    include_str!("../../../shaders/pathtrace.wgsl"),
    include_str!("../../../shaders/traverse_wide.wgsl"),
    include_str!("../../../shaders/wide_compressed.wgsl"),
    include_str!("../../../shaders/traverse_common.wgsl"),
    include_str!("../../../shaders/scene_whole.wgsl"),
    include_str!("../../../shaders/attrs_whole.wgsl"),
    include_str!("../../../shaders/sampling.wgsl"),
    include_str!("../../../shaders/aux_layout.wgsl"),
    include_str!("../../../shaders/octahedral.wgsl")
);

/// WGSL: [`PATHTRACE_WGSL`] for a scene whose nodes, triangles and shading records are split across
/// bindings ([`PartLayout`]).
pub const PATHTRACE_SPLIT_WGSL: &str = concat!(
    include_str!("../../../shaders/pathtrace.wgsl"),
    include_str!("../../../shaders/traverse_wide.wgsl"),
    include_str!("../../../shaders/wide_compressed.wgsl"),
    include_str!("../../../shaders/traverse_common.wgsl"),
    include_str!("../../../shaders/scene_parts.wgsl"),
    include_str!("../../../shaders/attrs_parts.wgsl"),
    include_str!("../../../shaders/sampling.wgsl"),
    include_str!("../../../shaders/aux_layout.wgsl"),
    include_str!("../../../shaders/octahedral.wgsl")
);

/// WGSL: one primary ray per pixel writing the hit triangle id (`primary_hits`), and from those
/// hits shadow, diffuse-bounce and ambient-occlusion rays, through the path tracer's traversal. The
/// tests compare `primary_hits` with the engine's CPU traversal.
pub const PRIMARY_HITS_WGSL: &str = concat!(
    include_str!("../../../shaders/primary_hits.wgsl"),
    include_str!("../../../shaders/traverse_wide.wgsl"),
    include_str!("../../../shaders/wide_compressed.wgsl"),
    include_str!("../../../shaders/traverse_common.wgsl"),
    include_str!("../../../shaders/scene_whole.wgsl"),
    include_str!("../../../shaders/sampling.wgsl")
);

/// WGSL: the kernels of [`PRIMARY_HITS_WGSL`] over nodes and triangles split across bindings
/// ([`PartLayout`]), as the path tracer reads a large scene.
pub const PRIMARY_HITS_SPLIT_WGSL: &str = concat!(
    include_str!("../../../shaders/primary_hits.wgsl"),
    include_str!("../../../shaders/traverse_wide.wgsl"),
    include_str!("../../../shaders/wide_compressed.wgsl"),
    include_str!("../../../shaders/traverse_common.wgsl"),
    include_str!("../../../shaders/scene_parts.wgsl"),
    include_str!("../../../shaders/sampling.wgsl")
);

/// WGSL: the kernels of [`PRIMARY_HITS_WGSL`] over the binary records (`treelight_bvh::GpuNode`),
/// for comparing layouts.
pub const PRIMARY_HITS_BINARY_WGSL: &str = concat!(
    include_str!("../../../shaders/primary_hits.wgsl"),
    include_str!("../../../shaders/traverse.wgsl"),
    include_str!("../../../shaders/binary_float.wgsl"),
    include_str!("../../../shaders/traverse_common.wgsl"),
    include_str!("../../../shaders/scene_whole.wgsl"),
    include_str!("../../../shaders/sampling.wgsl")
);

/// WGSL: the kernels of [`PRIMARY_HITS_WGSL`] over the binary records with boxes in bytes
/// (`treelight_bvh::GpuCompressedBinaryNode`), for comparing layouts.
pub const PRIMARY_HITS_BINARY_COMPRESSED_WGSL: &str = concat!(
    include_str!("../../../shaders/primary_hits.wgsl"),
    include_str!("../../../shaders/traverse.wgsl"),
    include_str!("../../../shaders/binary_compressed.wgsl"),
    include_str!("../../../shaders/traverse_common.wgsl"),
    include_str!("../../../shaders/scene_whole.wgsl"),
    include_str!("../../../shaders/sampling.wgsl")
);

/// WGSL: the kernels of [`PRIMARY_HITS_WGSL`] over the 4-wide records with float boxes
/// (`treelight_bvh::Bvh::gpu_wide_layout`), for comparing layouts.
pub const PRIMARY_HITS_WIDE_WGSL: &str = concat!(
    include_str!("../../../shaders/primary_hits.wgsl"),
    include_str!("../../../shaders/traverse_wide.wgsl"),
    include_str!("../../../shaders/wide_float.wgsl"),
    include_str!("../../../shaders/traverse_common.wgsl"),
    include_str!("../../../shaders/scene_whole.wgsl"),
    include_str!("../../../shaders/sampling.wgsl")
);

/// WGSL: resamples an image into a layer of the base-colour texture array (`copy_to_layer`).
pub const TEXTURE_LAYER_WGSL: &str = include_str!("../../../shaders/texture_layer.wgsl");

/// WGSL: the denoiser's pass (`denoise`), an edge-aware à-trous filter over a view's samples.
pub const DENOISE_WGSL: &str = concat!(
    include_str!("../../../shaders/denoise.wgsl"),
    include_str!("../../../shaders/octahedral.wgsl")
);

/// WGSL: the temporal pass (`temporal`): each frame's picture from its samples, its preview and
/// the last frame's picture carried through the camera's move.
pub const TEMPORAL_WGSL: &str = concat!(
    include_str!("../../../shaders/temporal.wgsl"),
    include_str!("../../../shaders/aux_layout.wgsl")
);

/// WGSL: the pass that draws the accumulated average into the view target.
pub const RESOLVE_WGSL: &str = concat!(
    include_str!("../../../shaders/resolve.wgsl"),
    include_str!("../../../shaders/aux_layout.wgsl")
);

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
    /// Bounces after the primary hit.
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
    /// Largest luminance (after exposure, where 1 is white) one indirect bounce may add to a sample.
    /// Rare paths that find a light from up close otherwise show as speckles for thousands of
    /// samples; the cap removes them at the cost of a little energy. 0 turns it off (unbiased).
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
                crate::budget::FILLING_MAX_SAMPLES
            } else {
                u64::MAX
            },
        }
    }
}

impl Default for PathTraced {
    fn default() -> Self {
        Self {
            max_bounces: 4,
            samples_per_frame: 1,
            max_samples: 4096,
            resolution_scale: 1.0,
            sky: LinearRgba::rgb(110.0, 140.0, 200.0),
            indirect_clamp: 4.0,
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

/// Figures the render world reports back for the UI.
#[derive(Clone, Debug, Default)]
pub struct PathTracerFigures {
    /// Bytes written to the scene buffers in the last frame that uploaded anything.
    pub last_upload_bytes: u64,
    /// Bytes written to the scene buffers since start.
    pub total_upload_bytes: u64,
    /// Frames that uploaded anything.
    pub uploads: u64,
    /// Samples every pixel has accumulated so far, per path-traced camera.
    pub samples: HashMap<Entity, u32>,
    /// The frame budget's latest figures, per path-traced camera.
    pub traces: HashMap<Entity, TraceFigures>,
    /// Whether the GPU copy has caught up with the scene at least once.
    pub scene_ready: bool,
    /// The scene tree's version ([`treelight_scene::SceneBvh::version`]) the GPU copy holds: the
    /// copy is current when it equals the tree's.
    pub uploaded_version: u64,
    /// Why nothing is traced, when the scene or a view needs a buffer larger than the adapter can
    /// bind: the path tracer stops (the scene itself is untouched) and an app shows another view.
    pub trace_off: Option<String>,
    /// The trace kernel the scene's views wait for while it is compiled away from their queue,
    /// on a software adapter: at the start, when a scene first outgrows one binding, when a
    /// texture of another kind is bound (with a cold shader cache most of a minute for the
    /// whole-scene kernel and minutes for the split one; about a second once the driver's cache
    /// holds it).
    pub preparing_kernel: Option<PreparingKernel>,
    /// Bytes of the scene's GPU buffers (on a software adapter, in the process's own memory).
    pub scene_buffer_bytes: u64,
    /// The side, in texels, every texture is traced at: [`TEXTURE_LAYER_SIZE`] until more
    /// textures are in use than its budget holds, then smaller (0 before any texture).
    pub texture_side: u32,
    /// Bytes of the device allocator's memory blocks, used or not: every buffer and texture of
    /// the app and the uploads' staging (read about once a second); `None` where the backend keeps
    /// no such report.
    pub gpu_reserved_bytes: Option<u64>,
    /// Mesh assets kept out of the render world while every active 3D camera is path traced
    /// ([`HoldBackRasterMeshes`]).
    pub meshes_held_back: usize,
}

/// A trace kernel the views wait for ([`PathTracerFigures::preparing_kernel`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparingKernel {
    /// Whether it is the kernel over records split across bindings (a large scene), not the
    /// whole-scene one.
    pub split: bool,
    /// Seconds the views have waited for it so far.
    pub waited_s: f32,
}

impl PreparingKernel {
    /// Whether the wait has lasted long enough to tell the user of it: with a warm shader cache
    /// it is over in about a second, unnoticed.
    pub fn noticeable(&self) -> bool {
        self.waited_s >= 1.5
    }
}

/// One path-traced camera's latest frame under its budget.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceFigures {
    /// Pixel samples the frame traced.
    pub traced_per_frame: u64,
    /// What a pixel sample costs, nanoseconds, and how that was measured, once it was.
    pub cost: Option<(f64, CostSource)>,
    /// Whether the frame traced the coarse preview (the view had just changed).
    pub previewing: bool,
    /// Whether the frame traced triangles: it traced samples and the scene's tree was not empty.
    pub geometry: bool,
    /// Whether the camera's samples were traced under a sky panorama (not the flat sky colour):
    /// read with [`PathTracerFigures::samples`], it tells which sky those samples show.
    pub panorama: bool,
}

/// Figures about the path tracer (bytes uploaded, samples per camera), readable from the main world.
#[derive(Resource, Clone, Default)]
pub struct PathTracerStats(Arc<Mutex<PathTracerFigures>>);

impl PathTracerStats {
    /// A copy of the current figures.
    pub fn figures(&self) -> PathTracerFigures {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Samples per pixel the camera has accumulated.
    pub fn samples(&self, camera: Entity) -> u32 {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .samples
            .get(&camera)
            .copied()
            .unwrap_or(0)
    }

    /// Why nothing is traced, once the path tracer stopped ([`PathTracerFigures::trace_off`]).
    pub fn trace_off(&self) -> Option<String> {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .trace_off
            .clone()
    }

    /// The trace kernel the views wait for ([`PathTracerFigures::preparing_kernel`]).
    pub fn preparing_kernel(&self) -> Option<PreparingKernel> {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .preparing_kernel
    }

    /// The side every texture is traced at ([`PathTracerFigures::texture_side`]).
    pub fn texture_side(&self) -> u32 {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .texture_side
    }

    pub(crate) fn update(&self, f: impl FnOnce(&mut PathTracerFigures)) {
        f(&mut self.0.lock().unwrap_or_else(|p| p.into_inner()));
    }
}

/// Path-traces every camera with [`PathTraced`], over the scene BVH kept by
/// [`SceneBvhPlugin`](treelight_scene::SceneBvhPlugin) (add that plugin too).
#[derive(Default)]
pub struct PathTracerPlugin;

impl Plugin for PathTracerPlugin {
    fn build(&self, app: &mut App) {
        let stats = PathTracerStats::default();
        app.register_type::<PathTraced>()
            .register_type::<Outlined>()
            .insert_resource(stats.clone())
            .init_resource::<MapUvTransforms>()
            .add_plugins(ExtractComponentPlugin::<PathTraced>::default());
        let shaders = {
            let mut assets = app.world_mut().resource_mut::<Assets<Shader>>();
            pipelines::PathTracerShaders {
                trace: assets.add(pipelines::whole_trace_shader()),
                trace_split: assets.add(pipelines::split_trace_shader()),
                resolve: assets.add(Shader::from_wgsl(RESOLVE_WGSL, "treelight/resolve.wgsl")),
                denoise: assets.add(Shader::from_wgsl(DENOISE_WGSL, "treelight/denoise.wgsl")),
                temporal: assets.add(Shader::from_wgsl(TEMPORAL_WGSL, "treelight/temporal.wgsl")),
                texture_layer: assets.add(Shader::from_wgsl(
                    TEXTURE_LAYER_WGSL,
                    "treelight/texture_layer.wgsl",
                )),
            }
        };
        // The strong handles live in the main world so the shaders stay loaded.
        app.insert_resource(shaders.clone());
        raster_skip::build(app);
        raster_meshes::build(app);
        environment::build(app);
        let Some(render_app) = app.get_sub_app_mut(bevy::render::RenderApp) else {
            return;
        };
        render_app.insert_resource(stats).insert_resource(shaders);
        // Bevy's render phases, one module each: extract, then prepare (the texture layers, the
        // scene's buffers, the views), then the node that binds and dispatches.
        pipelines::build(render_app);
        kernel_warmup::build(render_app);
        extract::build(render_app);
        texture_layers::build(render_app);
        prepare::build(render_app);
        gpu_memory::build(render_app);
        node::build(render_app);
    }

    fn finish(&self, app: &mut App) {
        // The app's record of kernel warm-ups, read by the render world at its startup.
        let record = app.world().get_resource::<KernelCompileRecord>().cloned();
        if let (Some(record), Some(render_app)) =
            (record, app.get_sub_app_mut(bevy::render::RenderApp))
        {
            render_app.insert_resource(record);
        }
    }
}
