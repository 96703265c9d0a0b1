//! Real files from ../shared/scenes, good and broken.

use std::path::PathBuf;
use treelight_import::load_scene;

fn scene(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/scenes")
        .join(rel)
}

#[test]
fn flight_helmet_loads_all_meshes_with_transforms() {
    let s = load_scene(&scene("gltf/FlightHelmet/FlightHelmet.gltf")).unwrap();
    assert!(s.meshes.len() >= 5, "{} meshes", s.meshes.len());
    assert_eq!(s.triangle_count(), 94_722);
    assert!(s.materials.len() >= 5);
    for m in &s.meshes {
        assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()));
        assert!(m.normals.is_some(), "{} lacks normals", m.name);
    }
}

#[test]
fn separate_and_embedded_buffers_give_the_same_box() {
    let a = load_scene(&scene("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    let b = load_scene(&scene("gltf/BoxTextured-glTF-Embedded/BoxTextured.gltf")).unwrap();
    assert_eq!(a.triangle_count(), 12);
    assert_eq!(a.world_triangles(), b.world_triangles());
}

#[test]
fn skinned_glb_loads() {
    let s = load_scene(&scene("gltf/CesiumMan.glb")).unwrap();
    assert!(s.triangle_count() > 1000);
}

#[test]
fn unsupported_extensions_are_named() {
    let e = load_scene(&scene("gltf/Box_Draco.glb")).unwrap_err();
    assert!(e.to_string().contains("KHR_draco_mesh_compression"), "{e}");
    assert!(e.to_string().contains("Box_Draco.glb"), "{e}");
    let e = load_scene(&scene("gltf/pirate.glb")).unwrap_err();
    assert!(e.to_string().contains("EXT_meshopt_compression"), "{e}");
}

#[test]
fn broken_files_give_clear_errors() {
    for dir in ["MissingBin", "IndexOutOfRange"] {
        let folder = scene(&format!("broken_gltf/{dir}"));
        let file = std::fs::read_dir(&folder)
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.extension().is_some_and(|x| x == "gltf" || x == "glb"))
            .unwrap();
        let e = load_scene(&file).unwrap_err();
        eprintln!("{dir}: {e}");
        assert_eq!(e.file, file);
        assert!(!e.problem.is_empty());
    }
}

#[test]
fn obj_scenes_fan_triangulate_in_file_order() {
    assert_eq!(
        load_scene(&scene("obj/sibenik.obj"))
            .unwrap()
            .triangle_count(),
        73_564
    );
    assert_eq!(
        load_scene(&scene("obj/stanford-bunny.obj"))
            .unwrap()
            .triangle_count(),
        69_451
    );
}

#[test]
fn hostile_inputs_are_refused() {
    let dir = std::env::temp_dir().join(format!("treelight-import-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A buffer URI that climbs out of the folder must not be followed.
    let escape = dir.join("escape.gltf");
    std::fs::write(
        &escape,
        r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"../../etc/passwd","byteLength":4}],"scenes":[{"nodes":[]}],"scene":0}"#,
    )
    .unwrap();
    assert!(load_scene(&escape).unwrap_err().problem.contains("outside"));
    let absolute = dir.join("absolute.gltf");
    std::fs::write(
        &absolute,
        r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"file:///etc/passwd","byteLength":4}],"scenes":[{"nodes":[]}],"scene":0}"#,
    )
    .unwrap();
    assert!(load_scene(&absolute).is_err());
    // Garbage, an empty file, and a wrong extension.
    let garbage = dir.join("garbage.glb");
    std::fs::write(&garbage, b"glTF\x02\x00\x00\x00\xff\xff\xff\xffnonsense").unwrap();
    assert!(load_scene(&garbage).is_err());
    let empty = dir.join("empty.gltf");
    std::fs::write(&empty, b"").unwrap();
    assert!(load_scene(&empty).is_err());
    assert!(
        load_scene(&dir.join("scene.fbx"))
            .unwrap_err()
            .problem
            .contains("unsupported file type")
    );
    // A NaN position.
    let nan = dir.join("nan.obj");
    std::fs::write(&nan, "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n").unwrap();
    let e = load_scene(&nan).unwrap_err();
    assert!(e.problem.contains("NaN"), "{e}");
    // An accessor claiming more elements than its buffer holds.
    let huge = dir.join("huge.gltf");
    std::fs::write(
        &huge,
        r#"{"asset":{"version":"2.0"},
            "buffers":[{"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAA","byteLength":12}],
            "bufferViews":[{"buffer":0,"byteLength":12}],
            "accessors":[{"bufferView":0,"componentType":5126,"count":100000000,"type":"VEC3","min":[0,0,0],"max":[0,0,0]}],
            "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
            "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}"#,
    )
    .unwrap();
    assert!(
        load_scene(&huge)
            .unwrap_err()
            .problem
            .contains("past the end")
    );
    std::fs::remove_dir_all(&dir).ok();
}
