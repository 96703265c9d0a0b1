//! The engine's example runs as its documentation says: it builds, moves a part and finds every
//! hit as brute force does.

#[test]
fn build_and_trace_checks_every_hit_before_and_after_a_move() {
    let scene = treelight_test_support::shared_scene("gltf/CesiumMan.glb");
    let scene = scene.to_str().unwrap();
    let (ok, text) =
        treelight_fence::examples::run_example("treelight_bvh", "build_and_trace", &[scene, "512"]);
    assert!(ok, "{text}");
    for preset in ["fast", "balanced", "best"] {
        assert!(text.contains(&format!("{preset}: built in")), "{text}");
    }
    assert!(
        text.contains("before the move:") && text.contains("after the move:"),
        "{text}"
    );
    assert!(!text.contains(" 0 of 512 rays hit"), "no ray hit: {text}");
}
