//! The WGSL compiles and validates, and its struct layouts match the engine's records.

use naga::valid::{Capabilities, ValidationFlags, Validator};

#[test]
fn pathtrace_wgsl_is_valid_and_matches_the_record_sizes() {
    let module =
        naga::front::wgsl::parse_str(treelight_render::PATHTRACE_WGSL).unwrap_or_else(|e| {
            panic!("{}", e.emit_to_string(treelight_render::PATHTRACE_WGSL));
        });
    Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{e:?}"));
    let size_of = |name: &str| {
        let (handle, _) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap();
        module.types[handle].inner.size(module.to_ctx())
    };
    assert_eq!(
        size_of("Node") as usize,
        std::mem::size_of::<treelight_bvh::GpuNode>()
    );
    assert_eq!(
        size_of("Tri") as usize,
        std::mem::size_of::<treelight_bvh::GpuTriangle>()
    );
    assert_eq!(
        size_of("Instance") as usize,
        std::mem::size_of::<treelight_bvh::GpuInstance>()
    );
    assert!(module.entry_points.iter().any(|e| e.name == "primary_hits"));
}
