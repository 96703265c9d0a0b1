//! The WGSL compiles and validates, and its struct layouts match the records the crate writes.

use naga::valid::{Capabilities, ValidationFlags, Validator};
use treelight_render::{
    ATTRIBUTE_BYTES, LIGHT_BYTES, OBJECT_BYTES, PATHTRACE_WGSL, PRIMARY_HITS_WGSL, RESOLVE_WGSL,
    VIEW_BYTES,
};

fn module(source: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(source).unwrap_or_else(|e| {
        panic!("{}", e.emit_to_string(source));
    });
    Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{e:?}"));
    module
}

fn size_of(module: &naga::Module, name: &str) -> u64 {
    let (handle, _) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no struct {name}"));
    module.types[handle].inner.size(module.to_ctx()) as u64
}

fn has_entry(module: &naga::Module, name: &str) -> bool {
    module.entry_points.iter().any(|e| e.name == name)
}

#[test]
fn traversal_records_match_the_engine() {
    for source in [PATHTRACE_WGSL, PRIMARY_HITS_WGSL] {
        let m = module(source);
        assert_eq!(
            size_of(&m, "Node") as usize,
            std::mem::size_of::<treelight_bvh::GpuNode>()
        );
        assert_eq!(
            size_of(&m, "Tri") as usize,
            std::mem::size_of::<treelight_bvh::GpuTriangle>()
        );
        assert_eq!(
            size_of(&m, "Instance") as usize,
            std::mem::size_of::<treelight_bvh::GpuInstance>()
        );
    }
}

#[test]
fn path_tracer_records_match_the_crate() {
    let m = module(PATHTRACE_WGSL);
    assert!(has_entry(&m, "path_trace"));
    assert_eq!(size_of(&m, "Attr"), ATTRIBUTE_BYTES);
    assert_eq!(size_of(&m, "Object"), OBJECT_BYTES);
    assert_eq!(size_of(&m, "Light"), LIGHT_BYTES);
    assert_eq!(size_of(&m, "View"), VIEW_BYTES);
}

#[test]
fn primary_hits_and_resolve_are_valid() {
    assert!(has_entry(&module(PRIMARY_HITS_WGSL), "primary_hits"));
    let r = module(RESOLVE_WGSL);
    assert!(has_entry(&r, "vertex") && has_entry(&r, "fragment"));
    assert_eq!(size_of(&r, "Resolve"), 32);
}
