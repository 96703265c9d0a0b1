//! # treelight_render
//!
//! [`PathTracerPlugin`] and the camera component [`PathTraced`] turn any Bevy 3D camera into a live
//! path-traced view of what `treelight_scene`'s [`SceneBvhPlugin`](treelight_scene::SceneBvhPlugin)
//! tracks. It is laid out as Bevy's own render features are: extraction takes the scene's change set
//! and turns it into record writes ([`UploadPlan`]), handing a large frame's to the GPU a round at
//! a time as it makes them ([`UploadRound`]); prepare grows and patches the GPU buffers and
//! readies each view's uniforms and bind groups; the node, a system in the camera's `Core3d`
//! schedule, only binds and dispatches the compute pass that traces the tree and accumulates
//! samples, and the small render pass that writes the average into the view target, in HDR, before
//! Bevy's tonemapping.
//!
//! The crate's layers, each a folder, each importing only those listed before it: `types` (GPU
//! record layouts, buffer kinds and parts, the frame budget's tiles, the camera component and the
//! figures reported back), `sky` (the panorama), `kernels` (WGSL sources, pipelines), `scene`
//! (extract, staging, texture layers, the scene's buffers), `trace` (kernel warm-ups, the views,
//! the node) and `raster` (what the rasteriser is spared while every camera is traced).

// Every public item says what it is for: the crate is meant to be used from other apps.
#![warn(missing_docs)]

mod kernels;
mod raster;
mod scene;
mod sky;
mod trace;
mod types;

pub use kernels::sources::*;
pub use raster::raster_meshes::HoldBackRasterMeshes;
pub use scene::staging::{CHUNK_BYTES, ROUND_BYTES, UploadBelt, UploadRound};
pub use scene::texture_layers::{
    MAX_TEXTURE_LAYERS, MIN_TEXTURE_LAYER_SIZE, TEXTURE_BUDGET_BYTES, TEXTURE_LAYER_SIZE,
    layer_side_for, layers_at,
};
pub use sky::environment::{
    ENVIRONMENT_BINDINGS, EnvironmentTexels, MAX_DISTRIBUTION_WIDTH, PathTracedEnvironment,
    PreparedEnvironment, environment_uniform, panorama_coordinates, panorama_direction,
};
pub use trace::kernel_warmup::KernelCompileRecord;
pub use types::budget::{
    CostSource, FrameBudget, MAX_PREVIEW_SCALE, TILE, TileCursor, TileOrder, TraceClock,
    preview_scale,
};
pub use types::emitters::{
    EMITTER_GROUP_KIND, EMITTER_KIND, EmitterList, MAX_EMITTERS, placed_triangles,
};
pub use types::energy::{ENERGY_BINDING, ENERGY_SIZE, energy_bytes, energy_table, split_sum};
pub use types::figures::{PathTracerFigures, PathTracerStats, PreparingKernel, TraceFigures};
pub use types::map_transforms::{
    MAP_TRANSFORM_SET_BYTES, MAP_TRANSFORMS_BINDING, MAX_MAP_TRANSFORM_SETS, MapTransformTable,
    MapUvTransforms,
};
pub use types::parts::{
    MAX_PART_SHIFT, PartLayout, part_bindings, part_count, trace_storage_buffers,
};
pub use types::records::{
    CLAMP_FROM_IMAGE, CLAMP_FROM_PREVIEW, DENOISE_IMAGES, DENOISE_PASSES, DENOISE_SIGMA_LUMINANCE,
    DENOISE_TAP_WORDS, GUIDE_WORDS, GpuAoParams, GpuDenoise, GpuLight, GpuObject, GpuPrimaryCamera,
    GpuResolve, GpuTemporal, GpuView, LIGHT_BYTES, LayerTexture, MaterialMap, OBJECT_BYTES,
    ResolveParams, SceneLight, SurfaceAlpha, SurfaceMaterial, TEMPORAL_FADE_SAMPLES,
    TEMPORAL_MAX_WEIGHT, TemporalRestart, TextureWrap, TraceWork, VIEW_BYTES, ViewParams,
    aux_bytes, decode_normal, decode_tangents, denoise_pass_bytes, denoise_passes, denoise_source,
    denoise_tap_bytes, denoise_target, encode_normal, encode_tangents, guide_bytes, light_bytes,
    object_bytes, outline_words, set_outline, temporal_bytes,
};
pub use types::shading::{
    ATTRIBUTE_BYTES, CornerShading, GpuAttribute, GpuShadingVertex, MAX_SHADING_VERTEX_RECORDS,
    SHADING_VERTEX_BYTES, ShadingBuffers, VertexLayout, attribute_record, shading_record,
    vertex_records,
};
pub use types::upload::{
    BufferKind, BufferWrite, Layouts, POSITION_BYTES, TRIANGLE_BYTES, UploadPlan, Writes,
    grown_capacity, instance_bytes, node_bytes, triangle_bytes,
};
pub use types::view::{
    DEFAULT_INDIRECT_CLAMP, DEFAULT_MAX_BOUNCES, DebugView, OutlineStyle, Outlined, PathTraced,
};

use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponentPlugin;

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
            kernels::pipelines::PathTracerShaders {
                trace: assets.add(kernels::pipelines::whole_trace_shader()),
                trace_split: assets.add(kernels::pipelines::split_trace_shader()),
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
        raster::raster_skip::build(app);
        raster::raster_meshes::build(app);
        raster::shadow_maps::build(app);
        sky::environment::build(app);
        let Some(render_app) = app.get_sub_app_mut(bevy::render::RenderApp) else {
            return;
        };
        render_app.insert_resource(stats).insert_resource(shaders);
        // Bevy's render phases, one module each: extract, then prepare (the texture layers, the
        // scene's buffers, the views), then the node that binds and dispatches.
        kernels::pipelines::build(render_app);
        trace::kernel_warmup::build(render_app);
        scene::extract::build(render_app);
        scene::texture_layers::build(render_app);
        scene::gpu_scene::build(render_app);
        trace::views::build(render_app);
        trace::gpu_memory::build(render_app);
        trace::node::build(render_app);
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
