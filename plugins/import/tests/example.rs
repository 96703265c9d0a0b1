//! The importer's example says what a real file holds, and names a file it cannot read.

#[test]
fn describe_lists_a_scene_and_names_a_missing_file() {
    use treelight_fence::examples::run_example;
    let helmet = treelight_test_support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let helmet = helmet.to_str().unwrap();
    let (ok, text) = run_example("treelight_import", "describe", &[helmet]);
    assert!(ok, "{text}");
    assert!(text.contains("94722 triangles"), "{text}");
    assert!(text.contains("material 'LeatherPartsMat'"), "{text}");
    let (ok, text) = run_example("treelight_import", "describe", &["/nonexistent/x.glb"]);
    assert!(!ok && text.contains("/nonexistent/x.glb"), "{text}");
}
