//! The kernels' WGSL sources, each a kernel file with the files it needs appended.

// Each kernel file declares the buffers; a traversal (`traverse_wide.wgsl` or `traverse.wgsl`, with
// its record file and `traverse_common.wgsl`) and `sampling.wgsl` (random numbers, frames, offsets)
// are appended to it, as WGSL resolves module-scope names in any order.

/// WGSL: the path-tracing kernel (`path_trace`) with the traversal (the compressed 4-wide records
/// of `treelight_bvh::WideRecords`).
pub const PATHTRACE_WGSL: &str = concat!(
    include_str!("../../shaders/pathtrace.wgsl"),
    include_str!("../../shaders/traverse_wide.wgsl"),
    include_str!("../../shaders/wide_compressed.wgsl"),
    include_str!("../../shaders/traverse_common.wgsl"),
    include_str!("../../shaders/scene_whole.wgsl"),
    include_str!("../../shaders/attrs_whole.wgsl"),
    include_str!("../../shaders/sampling.wgsl"),
    include_str!("../../shaders/aux_layout.wgsl"),
    include_str!("../../shaders/guide_layout.wgsl"),
    include_str!("../../shaders/octahedral.wgsl")
);

/// WGSL: [`PATHTRACE_WGSL`] for a scene whose nodes, triangles and shading records are split across
/// bindings ([`PartLayout`](crate::types::parts::PartLayout)).
pub const PATHTRACE_SPLIT_WGSL: &str = concat!(
    include_str!("../../shaders/pathtrace.wgsl"),
    include_str!("../../shaders/traverse_wide.wgsl"),
    include_str!("../../shaders/wide_compressed.wgsl"),
    include_str!("../../shaders/traverse_common.wgsl"),
    include_str!("../../shaders/scene_parts.wgsl"),
    include_str!("../../shaders/attrs_parts.wgsl"),
    include_str!("../../shaders/sampling.wgsl"),
    include_str!("../../shaders/aux_layout.wgsl"),
    include_str!("../../shaders/guide_layout.wgsl"),
    include_str!("../../shaders/octahedral.wgsl")
);

/// WGSL: one primary ray per pixel writing the hit triangle id (`primary_hits`), and from those
/// hits shadow, diffuse-bounce and ambient-occlusion rays, through the path tracer's traversal. The
/// tests compare `primary_hits` with the engine's CPU traversal.
pub const PRIMARY_HITS_WGSL: &str = concat!(
    include_str!("../../shaders/primary_hits.wgsl"),
    include_str!("../../shaders/traverse_wide.wgsl"),
    include_str!("../../shaders/wide_compressed.wgsl"),
    include_str!("../../shaders/traverse_common.wgsl"),
    include_str!("../../shaders/scene_whole.wgsl"),
    include_str!("../../shaders/sampling.wgsl")
);

/// WGSL: the kernels of [`PRIMARY_HITS_WGSL`] over nodes, triangles and positions split across
/// bindings ([`PartLayout`](crate::types::parts::PartLayout)), as the path tracer reads a large
/// scene.
pub const PRIMARY_HITS_SPLIT_WGSL: &str = concat!(
    include_str!("../../shaders/primary_hits.wgsl"),
    include_str!("../../shaders/traverse_wide.wgsl"),
    include_str!("../../shaders/wide_compressed.wgsl"),
    include_str!("../../shaders/traverse_common.wgsl"),
    include_str!("../../shaders/scene_parts.wgsl"),
    include_str!("../../shaders/sampling.wgsl")
);

/// WGSL: the kernels of [`PRIMARY_HITS_WGSL`] over the binary records (`treelight_bvh::GpuNode`),
/// for comparing layouts.
pub const PRIMARY_HITS_BINARY_WGSL: &str = concat!(
    include_str!("../../shaders/primary_hits.wgsl"),
    include_str!("../../shaders/traverse.wgsl"),
    include_str!("../../shaders/binary_float.wgsl"),
    include_str!("../../shaders/traverse_common.wgsl"),
    include_str!("../../shaders/scene_whole.wgsl"),
    include_str!("../../shaders/sampling.wgsl")
);

/// WGSL: the kernels of [`PRIMARY_HITS_WGSL`] over the binary records with boxes in bytes
/// (`treelight_bvh::GpuCompressedBinaryNode`), for comparing layouts.
pub const PRIMARY_HITS_BINARY_COMPRESSED_WGSL: &str = concat!(
    include_str!("../../shaders/primary_hits.wgsl"),
    include_str!("../../shaders/traverse.wgsl"),
    include_str!("../../shaders/binary_compressed.wgsl"),
    include_str!("../../shaders/traverse_common.wgsl"),
    include_str!("../../shaders/scene_whole.wgsl"),
    include_str!("../../shaders/sampling.wgsl")
);

/// WGSL: the kernels of [`PRIMARY_HITS_WGSL`] over the 4-wide records with float boxes
/// (`treelight_bvh::Bvh::gpu_wide_layout`), for comparing layouts.
pub const PRIMARY_HITS_WIDE_WGSL: &str = concat!(
    include_str!("../../shaders/primary_hits.wgsl"),
    include_str!("../../shaders/traverse_wide.wgsl"),
    include_str!("../../shaders/wide_float.wgsl"),
    include_str!("../../shaders/traverse_common.wgsl"),
    include_str!("../../shaders/scene_whole.wgsl"),
    include_str!("../../shaders/sampling.wgsl")
);

/// WGSL: resamples an image into a layer of the base-colour texture array (`copy_to_layer`).
pub const TEXTURE_LAYER_WGSL: &str = include_str!("../../shaders/texture_layer.wgsl");

/// WGSL: the denoiser's pass (`denoise`), an edge-aware à-trous filter over a view's samples.
pub const DENOISE_WGSL: &str = concat!(
    include_str!("../../shaders/denoise.wgsl"),
    include_str!("../../shaders/aux_layout.wgsl"),
    include_str!("../../shaders/guide_layout.wgsl"),
    include_str!("../../shaders/octahedral.wgsl")
);

/// WGSL: the temporal pass (`temporal`): each frame's picture from its samples, its preview and
/// the last frame's picture carried through the camera's move.
pub const TEMPORAL_WGSL: &str = concat!(
    include_str!("../../shaders/temporal.wgsl"),
    include_str!("../../shaders/aux_layout.wgsl"),
    include_str!("../../shaders/guide_layout.wgsl"),
    include_str!("../../shaders/remodulate.wgsl")
);

/// WGSL: the pass that draws the accumulated average into the view target.
pub const RESOLVE_WGSL: &str = concat!(
    include_str!("../../shaders/resolve.wgsl"),
    include_str!("../../shaders/aux_layout.wgsl"),
    include_str!("../../shaders/guide_layout.wgsl"),
    include_str!("../../shaders/remodulate.wgsl")
);
