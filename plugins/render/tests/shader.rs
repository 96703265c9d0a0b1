//! The WGSL compiles and validates, and every GPU record the crates write has the layout naga gives
//! its WGSL struct: the same size, and each field at the offset of the member of the same name.

use naga::valid::{Capabilities, ValidationFlags, Validator};
use std::mem::{offset_of, size_of};
use treelight_bvh::{
    GpuCompressedBinaryNode, GpuCompressedNode, GpuIndexedTriangle, GpuInstance, GpuNode,
    GpuWideNode,
};
use treelight_render::{
    GpuAoParams, GpuAttribute, GpuLight, GpuObject, GpuPrimaryCamera, GpuResolve, GpuShadingVertex,
    GpuView, PATHTRACE_SPLIT_WGSL, PATHTRACE_WGSL, PRIMARY_HITS_BINARY_COMPRESSED_WGSL,
    PRIMARY_HITS_BINARY_WGSL, PRIMARY_HITS_SPLIT_WGSL, PRIMARY_HITS_WGSL, PRIMARY_HITS_WIDE_WGSL,
    RESOLVE_WGSL,
};

fn module(source: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source).unwrap_or_else(|e| {
        panic!("{}", e.emit_to_string(source));
    });
    // Half floats packed in 32-bit words (the temporal pass's pictures): every Vulkan, Metal, DX12
    // and WebGPU adapter has it (wgpu's `DownlevelFlags::SHADER_F16_IN_F32`).
    Validator::new(
        ValidationFlags::all(),
        Capabilities::default() | Capabilities::SHADER_FLOAT16_IN_FLOAT32,
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{e:?}"));
    module
}

/// A struct's layout: each member's name and byte offset, in order, and its size.
type Layout = (Vec<(String, u32)>, u32);

/// The layout naga gives WGSL struct `name` (host-shareable structs follow WGSL's layout rules).
fn wgsl_layout(module: &naga::Module, name: &str) -> Layout {
    let ty = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name}"))
        .1;
    let naga::TypeInner::Struct { members, span } = &ty.inner else {
        panic!("{name} is not a struct");
    };
    let fields = members
        .iter()
        .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
        .collect();
    (fields, *span)
}

/// The layout of Rust record `$t`, whose fields are listed in order.
macro_rules! rust_layout {
    ($t:ty, [$($field:ident),* $(,)?]) => {
        (
            vec![$((stringify!($field).to_owned(), offset_of!($t, $field) as u32)),*],
            size_of::<$t>() as u32,
        )
    };
}

fn has_entry(module: &naga::Module, name: &str) -> bool {
    module.entry_points.iter().any(|e| e.name == name)
}

/// The measuring kernels every traversal's `primary_hits.wgsl` module has.
fn assert_ray_kernels(m: &naga::Module) {
    for entry in [
        "primary_hits",
        "ambient_occlusion",
        "diffuse_bounces",
        "shadow_rays",
    ] {
        assert!(has_entry(m, entry), "{entry}");
    }
}

#[test]
fn traversal_records_have_the_engine_s_layout() {
    for source in [
        PATHTRACE_WGSL,
        PATHTRACE_SPLIT_WGSL,
        PRIMARY_HITS_WGSL,
        PRIMARY_HITS_SPLIT_WGSL,
    ] {
        let m = module(source);
        assert_eq!(
            wgsl_layout(&m, "Node"),
            rust_layout!(
                GpuCompressedNode,
                [
                    origin,
                    exponents,
                    quantized_x,
                    quantized_y,
                    quantized_z,
                    pad,
                    refs
                ]
            )
        );
        assert_eq!(
            wgsl_layout(&m, "TriRecord"),
            rust_layout!(GpuIndexedTriangle, [corners])
        );
        assert_eq!(
            wgsl_layout(&m, "Instance"),
            rust_layout!(
                GpuInstance,
                [world_to_object, object_to_world, root, group, pad1, pad2]
            )
        );
    }
}

#[test]
fn wide_traversal_records_have_the_engine_s_layout() {
    let m = module(PRIMARY_HITS_WIDE_WGSL);
    assert_eq!(
        wgsl_layout(&m, "Node"),
        rust_layout!(
            GpuWideNode,
            [min_x, max_x, min_y, max_y, min_z, max_z, refs]
        )
    );
    assert_eq!(
        wgsl_layout(&m, "Instance"),
        rust_layout!(
            GpuInstance,
            [world_to_object, object_to_world, root, group, pad1, pad2]
        )
    );
    assert_ray_kernels(&m);
}

#[test]
fn binary_compressed_traversal_records_have_the_engine_s_layout() {
    let m = module(PRIMARY_HITS_BINARY_COMPRESSED_WGSL);
    assert_eq!(
        wgsl_layout(&m, "Node"),
        rust_layout!(
            GpuCompressedBinaryNode,
            [origin, exponents, quantized, a_ref, b_ref, pad]
        )
    );
    assert_ray_kernels(&m);
}

#[test]
fn binary_traversal_records_have_the_engine_s_layout() {
    let m = module(PRIMARY_HITS_BINARY_WGSL);
    assert_eq!(
        wgsl_layout(&m, "Node"),
        rust_layout!(
            GpuNode,
            [a_min, a_ref, a_max, b_ref, b_min, pad0, b_max, pad1]
        )
    );
    assert_ray_kernels(&m);
}

#[test]
fn path_tracer_records_have_the_crate_s_layout() {
    let m = module(PATHTRACE_WGSL);
    assert!(has_entry(&m, "path_trace"));
    assert_eq!(
        wgsl_layout(&m, "ShadingRecord"),
        rust_layout!(GpuAttribute, [corners])
    );
    assert_eq!(
        wgsl_layout(&m, "ShadingVertex"),
        rust_layout!(GpuShadingVertex, [normal, tangent, uv])
    );
    assert_eq!(
        wgsl_layout(&m, "Object"),
        rust_layout!(
            GpuObject,
            [
                normal_rows,
                base_color,
                emissive,
                params,
                uv_matrix,
                uv_offset,
                texture,
                wrap,
                maps,
                coat,
                map_transforms,
                specular,
                identity
            ]
        )
    );
    assert_eq!(
        wgsl_layout(&m, "Light"),
        rust_layout!(
            GpuLight,
            [
                position,
                kind,
                radiance,
                radius,
                direction,
                inv_range2,
                spot_scale,
                spot_offset,
                ids
            ]
        )
    );
    assert_eq!(
        wgsl_layout(&m, "View"),
        rust_layout!(
            GpuView,
            [
                world_from_clip,
                clip_from_world,
                sky,
                width,
                height,
                root,
                max_bounces,
                samples,
                mode,
                light_count,
                indirect_clamp,
                preview_scale,
                preview_seed,
                tile_start,
                tile_count,
                tiles_x,
                tile_total,
                tile_stride,
                part_shift,
                sample_seed,
                clamp_from,
                emitter_groups,
                emitter_weight,
                environment,
                origin
            ]
        )
    );
}

#[test]
fn primary_hits_and_resolve_records_have_the_crate_s_layout() {
    let p = module(PRIMARY_HITS_WGSL);
    assert!(has_entry(&p, "primary_hits") && has_entry(&p, "ambient_occlusion"));
    assert_eq!(
        wgsl_layout(&p, "PrimaryCamera"),
        rust_layout!(
            GpuPrimaryCamera,
            [
                origin, width, lower_left, height, horizontal, root, vertical, part_shift
            ]
        )
    );
    assert_eq!(
        wgsl_layout(&p, "AoParams"),
        rust_layout!(GpuAoParams, [rays, length, pad0, pad1])
    );
    let r = module(RESOLVE_WGSL);
    assert!(
        has_entry(&r, "vertex") && has_entry(&r, "fragment") && has_entry(&r, "fragment_depth")
    );
    assert_eq!(
        wgsl_layout(&r, "Resolve"),
        rust_layout!(
            GpuResolve,
            [
                origin,
                viewport,
                size,
                preview_scale,
                outline_slots,
                outline_colours,
                outline_width,
                denoised,
                outline_min,
                outline_max,
                temporal,
                pad2
            ]
        )
    );
}

#[test]
fn denoiser_records_have_the_crate_s_layout() {
    let m = module(treelight_render::DENOISE_WGSL);
    assert!(has_entry(&m, "denoise"));
    assert_eq!(
        wgsl_layout(&m, "Denoise"),
        rust_layout!(
            treelight_render::GpuDenoise,
            [
                width,
                height,
                step,
                first,
                sigma_luminance,
                sigma_normal,
                sigma_depth,
                pad
            ]
        )
    );
}

#[test]
fn temporal_records_have_the_crate_s_layout() {
    let m = module(treelight_render::TEMPORAL_WGSL);
    assert!(has_entry(&m, "temporal"));
    assert_eq!(
        wgsl_layout(&m, "Temporal"),
        rust_layout!(
            treelight_render::GpuTemporal,
            [
                reproject,
                width,
                height,
                preview_scale,
                denoised,
                restart,
                max_weight,
                fade_samples,
                pad
            ]
        )
    );
}

#[test]
fn a_moved_field_would_fail_the_comparison() {
    // The comparison sees order and offsets, not only sizes: the same fields listed in another
    // order give another layout.
    let m = module(PATHTRACE_WGSL);
    assert_ne!(
        wgsl_layout(&m, "Light"),
        rust_layout!(GpuLight, [kind, position, radiance, radius])
    );
}

/// The passes bound every frame (denoise, temporal, resolve) read their parameters from storage
/// buffers: Mesa 22's lavapipe compiles a new variant of a shader whose branches test uniform
/// values at every bind and never frees it, so a uniform here grows the editor's heap by
/// megabytes a frame on a software adapter.
#[test]
fn the_per_frame_passes_bind_no_uniform_buffer() {
    for (name, source) in [
        ("denoise", treelight_render::DENOISE_WGSL),
        ("temporal", treelight_render::TEMPORAL_WGSL),
        ("resolve", RESOLVE_WGSL),
    ] {
        let m = module(source);
        let uniforms: Vec<_> = m
            .global_variables
            .iter()
            .filter(|(_, v)| v.space == naga::AddressSpace::Uniform)
            .map(|(_, v)| v.name.clone().unwrap_or_default())
            .collect();
        assert!(uniforms.is_empty(), "{name} binds uniforms {uniforms:?}");
    }
}
