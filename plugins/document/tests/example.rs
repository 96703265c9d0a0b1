//! The document's example runs without a window: it opens a file, moves, undoes and redoes, and
//! saves a project that opens again with the move in it.

#[test]
fn headless_edit_saves_a_project_with_the_move() {
    use treelight_fence::examples::run_example;
    let scene = treelight_test_support::shared_scene("gltf/BoxTextured-glTF/BoxTextured.gltf");
    let scene = scene.to_str().unwrap();
    let dir = std::env::temp_dir().join(format!("treelight-headless-edit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("box.treelight");
    let (ok, text) = run_example(
        "treelight_document",
        "headless_edit",
        &[scene, out.to_str().unwrap()],
    );
    assert!(ok, "{text}");
    assert!(text.contains("undone") && text.contains("redone"), "{text}");
    let project = treelight_document::project::format::read_project(&out).unwrap();
    // The root was moved up by 1: the saved project lists it there.
    let root = project.objects.iter().find(|o| o.parent.is_none()).unwrap();
    assert_eq!(root.transform.translation[1], 1.0, "{root:?}");
    std::fs::remove_dir_all(&dir).ok();
}
