//! Small hostile files, written by the tests themselves: each is refused (or imported) within
//! bounded time and memory, with an error naming the file and what is wrong.

mod support;

use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use support::triangle_bin;
use treelight_import::{ImportOptions, load_scene, load_scene_with};

/// A fresh folder for one test.
fn folder(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("treelight-hostile-{tag}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A glTF of one triangle mesh named "tri" at one node, its buffer in `tri.bin`.
fn triangle_gltf() -> Value {
    json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "tri.bin", "byteLength": 44}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 8}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "meshes": [{"name": "tri", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"name": "only", "mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    })
}

/// Writes `gltf` (and the triangle's buffer, unless `tri.bin` is there already) into `dir`.
fn write(dir: &Path, name: &str, gltf: &Value) -> PathBuf {
    let bin = dir.join("tri.bin");
    if std::fs::symlink_metadata(&bin).is_err() {
        std::fs::write(&bin, triangle_bin()).unwrap();
    }
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(gltf).unwrap()).unwrap();
    path
}

#[test]
fn index_accessors_of_floats_or_signed_bytes_are_refused_with_the_mesh_named() {
    let dir = folder("index-types");
    // The unedited triangle reads.
    let good = write(&dir, "good.gltf", &triangle_gltf());
    assert_eq!(load_scene(&good).unwrap().triangle_count(), 1);
    for (file, component, kind, what) in [
        ("float.gltf", 5126, "SCALAR", "Scalar F32"),
        ("signed.gltf", 5120, "SCALAR", "Scalar I8"),
        ("vector.gltf", 5123, "VEC2", "Vec2 U16"),
    ] {
        let mut g = triangle_gltf();
        g["accessors"][1]["componentType"] = json!(component);
        g["accessors"][1]["type"] = json!(kind);
        if component == 5126 {
            // Room for three floats.
            g["bufferViews"][1]["byteOffset"] = json!(0);
            g["bufferViews"][1]["byteLength"] = json!(12);
        }
        if kind == "VEC2" {
            g["bufferViews"][1]["byteOffset"] = json!(0);
            g["bufferViews"][1]["byteLength"] = json!(12);
        }
        let path = write(&dir, file, &g);
        let e = load_scene(&path).expect_err(file);
        assert_eq!(e.file, path);
        assert!(
            e.problem
                .contains(&format!("mesh 'only': its index accessor 1 holds {what}")),
            "{file}: {e}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn attribute_accessors_of_the_wrong_shape_or_type_are_refused() {
    let dir = folder("attribute-types");
    type Case = (&'static str, fn(&mut Value), &'static str);
    let cases: [Case; 4] = [
        (
            "uvs-vec3.gltf",
            |g| {
                g["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(0);
            },
            "its TEXCOORD_0 accessor 0 holds Vec3 F32",
        ),
        (
            "positions-u32.gltf",
            |g| {
                g["accessors"][0]["componentType"] = json!(5125);
            },
            "its POSITION accessor 0 holds Vec3 U32",
        ),
        (
            "normals-u8.gltf",
            |g| {
                g["accessors"].as_array_mut().unwrap().push(
                    json!({"bufferView": 0, "componentType": 5121, "count": 3, "type": "VEC3"}),
                );
                g["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(2);
            },
            "its NORMAL accessor 2 holds Vec3 U8",
        ),
        (
            "tangents-vec3.gltf",
            |g| {
                g["meshes"][0]["primitives"][0]["attributes"]["TANGENT"] = json!(0);
            },
            "its TANGENT accessor 0 holds Vec3 F32",
        ),
    ];
    for (file, edit, expected) in cases {
        let mut g = triangle_gltf();
        edit(&mut g);
        let path = write(&dir, file, &g);
        let e = load_scene(&path).expect_err(file);
        assert_eq!(e.file, path);
        assert!(e.problem.contains(expected), "{file}: {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_node_reached_twice_is_refused_naming_it() {
    let dir = folder("dag");
    // Two parents.
    let mut g = triangle_gltf();
    g["nodes"] = json!([
        {"name": "a", "children": [2]},
        {"name": "b", "children": [2]},
        {"name": "shared", "mesh": 0}
    ]);
    g["scenes"][0]["nodes"] = json!([0, 1]);
    let path = write(&dir, "two-parents.gltf", &g);
    let e = load_scene(&path).unwrap_err();
    assert_eq!(e.file, path);
    assert!(
        e.problem.contains("node 2 ('shared') is reached twice"),
        "{e}"
    );
    // A cycle.
    g["nodes"] = json!([
        {"name": "a", "children": [1]},
        {"name": "b", "children": [0], "mesh": 0}
    ]);
    g["scenes"][0]["nodes"] = json!([0]);
    let path = write(&dir, "cycle.gltf", &g);
    let e = load_scene(&path).unwrap_err();
    assert!(e.problem.contains("node 0 ('a') is reached twice"), "{e}");
    // A root listed twice.
    g["nodes"] = json!([{"name": "a", "mesh": 0}]);
    g["scenes"][0]["nodes"] = json!([0, 0]);
    let path = write(&dir, "root-twice.gltf", &g);
    assert!(
        load_scene(&path)
            .unwrap_err()
            .problem
            .contains("node 0 ('a') is reached twice")
    );
    // A DAG 48 levels deep, each level's two nodes both children of the level above's two: 2^48
    // paths if it were expanded path by path.
    let levels = 48;
    let mut nodes = Vec::new();
    for level in 0..levels {
        for _ in 0..2 {
            let next = 2 * (level + 1);
            nodes.push(if level + 1 < levels {
                json!({"children": [next, next + 1], "mesh": 0})
            } else {
                json!({"mesh": 0})
            });
        }
    }
    g["nodes"] = Value::Array(nodes);
    g["scenes"][0]["nodes"] = json!([0, 1]);
    let path = write(&dir, "dag.gltf", &g);
    let e = load_scene(&path).unwrap_err();
    assert!(e.problem.contains("is reached twice"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_mesh_placed_at_many_nodes_is_decoded_once_and_shared() {
    let dir = folder("shared-mesh");
    let mut g = triangle_gltf();
    let nodes: Vec<Value> = (0..1000)
        .map(|k| json!({"mesh": 0, "translation": [k as f32, 0, 0]}))
        .collect();
    g["nodes"] = Value::Array(nodes);
    g["scenes"][0]["nodes"] = json!((0..1000).collect::<Vec<_>>());
    let path = write(&dir, "many.gltf", &g);
    let s = load_scene(&path).unwrap();
    assert_eq!(s.meshes.len(), 1000);
    for m in &s.meshes[1..] {
        assert!(Arc::ptr_eq(&m.geometry, &s.meshes[0].geometry));
        assert_eq!(m.same_as, Some(0));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[cfg(unix)]
#[test]
fn buffers_that_are_devices_pipes_folders_or_links_out_are_refused() {
    let dir = folder("special-files");
    let g = triangle_gltf();
    type Case<'a> = (&'a str, &'a dyn Fn(&Path), &'a str);
    let cases: [Case; 4] = [
        (
            "zero.gltf",
            &|bin| std::os::unix::fs::symlink("/dev/zero", bin).unwrap(),
            "buffer '",
        ),
        (
            "pipe.gltf",
            &|bin| {
                let ok = std::process::Command::new("mkfifo")
                    .arg(bin)
                    .status()
                    .unwrap();
                assert!(ok.success());
            },
            "is a pipe, not a regular file",
        ),
        (
            "folder.gltf",
            &|bin| std::fs::create_dir(bin).unwrap(),
            "is a folder, not a regular file",
        ),
        (
            "outside.gltf",
            &|bin| {
                let outside = std::env::temp_dir()
                    .join(format!("treelight-hostile-outside-{}", std::process::id()));
                std::fs::write(&outside, triangle_bin()).unwrap();
                std::os::unix::fs::symlink(&outside, bin).unwrap();
            },
            "is a link that points outside the file's folder",
        ),
    ];
    for (file, make, expected) in cases {
        let sub = dir.join(file.trim_end_matches(".gltf"));
        std::fs::create_dir_all(&sub).unwrap();
        make(&sub.join("tri.bin"));
        let path = write(&sub, file, &g);
        let e = load_scene(&path).expect_err(file);
        assert_eq!(e.file, path);
        assert!(e.problem.contains(expected), "{file}: {e}");
        if file == "zero.gltf" {
            // /dev/zero is in /dev, so it is refused as a link out before its kind is asked.
            assert!(e.problem.contains("outside"), "{e}");
        }
    }
    std::fs::remove_file(
        std::env::temp_dir().join(format!("treelight-hostile-outside-{}", std::process::id())),
    )
    .ok();
    std::fs::remove_dir_all(&dir).ok();
}

#[cfg(unix)]
#[test]
fn a_scene_file_that_is_a_device_or_pipe_is_refused() {
    let dir = folder("special-scenes");
    for (name, target) in [
        ("zero.glb", "/dev/zero"),
        ("random.obj", "/dev/urandom"),
        ("null.ply", "/dev/null"),
    ] {
        let path = dir.join(name);
        std::os::unix::fs::symlink(target, &path).unwrap();
        let e = load_scene(&path).expect_err(name);
        assert_eq!(e.file, path);
        assert!(
            e.problem.contains("is a device, not a regular file"),
            "{name}: {e}"
        );
    }
    let pipe = dir.join("pipe.gltf");
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&pipe)
            .status()
            .unwrap()
            .success()
    );
    let e = load_scene(&pipe).unwrap_err();
    assert!(e.problem.contains("is a pipe"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_buffer_is_read_up_to_its_declared_length_and_no_further() {
    let dir = folder("long-buffer");
    // The triangle's 44 bytes, then a gigabyte the file does not declare (sparse on disk).
    let bin = std::fs::File::create(dir.join("tri.bin")).unwrap();
    use std::io::Write;
    (&bin).write_all(&triangle_bin()).unwrap();
    bin.set_len(1 << 30).unwrap();
    let path = write(&dir, "long.gltf", &triangle_gltf());
    let small = ImportOptions {
        memory_budget: 8 << 20,
    };
    let s = load_scene_with(&path, &small).unwrap();
    assert_eq!(s.triangle_count(), 1);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_file_over_the_memory_budget_is_refused_with_its_name_and_the_figure() {
    let helmet = treelight_test_support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let tight = ImportOptions {
        memory_budget: 4 << 20,
    };
    let e = load_scene_with(&helmet, &tight).unwrap_err();
    assert_eq!(e.file, helmet);
    assert!(
        e.problem
            .contains("needs more memory than the import may use")
            && e.problem.contains("of the budget of 4.0 MiB"),
        "{e}"
    );
    // The same file within a budget that holds it.
    let roomy = ImportOptions {
        memory_budget: 1 << 30,
    };
    assert_eq!(
        load_scene_with(&helmet, &roomy).unwrap().triangle_count(),
        94_722
    );
}

#[test]
fn what_the_gltf_crate_would_panic_on_is_refused() {
    let dir = folder("gltf-panics");
    // A primitive naming an accessor past the list (the crate's validation indexed it).
    let mut g = triangle_gltf();
    g["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9);
    let path = write(&dir, "accessor.gltf", &g);
    let e = load_scene(&path).unwrap_err();
    assert!(
        e.problem
            .contains("mesh 0, primitive 0 names accessor 9, and the file has 2"),
        "{e}"
    );
    // An image in a buffer view without its MIME type (the crate unwrapped it).
    let mut g = triangle_gltf();
    g["images"] = json!([{"bufferView": 1}]);
    g["textures"] = json!([{"source": 0}]);
    g["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    g["meshes"][0]["primitives"][0]["material"] = json!(0);
    let path = write(&dir, "image.gltf", &g);
    let e = load_scene(&path).unwrap_err();
    assert!(
        e.problem
            .contains("image 0 has neither a URI nor a buffer view with a MIME type"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_decoded_image_is_charged_to_the_budget_before_it_is_decoded() {
    let dir = folder("image-budget");
    // A 2048 × 2048 PNG of one colour: a few kilobytes on disk, 16 MiB decoded.
    let png = dir.join("flat.png");
    image::RgbaImage::from_pixel(2048, 2048, image::Rgba([200, 100, 50, 255]))
        .save(&png)
        .unwrap();
    assert!(std::fs::metadata(&png).unwrap().len() < 1 << 20);
    let mut g = triangle_gltf();
    g["images"] = json!([{"uri": "flat.png"}]);
    g["textures"] = json!([{"source": 0}]);
    g["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    g["meshes"][0]["primitives"][0]["material"] = json!(0);
    let path = write(&dir, "textured.gltf", &g);
    let e = load_scene_with(
        &path,
        &ImportOptions {
            memory_budget: 24 << 20,
        },
    )
    .unwrap_err();
    assert!(
        e.problem.contains("image 'flat.png' (2048×2048)")
            && e.problem.contains("of the budget of 24.0 MiB"),
        "{e}"
    );
    let s = load_scene_with(
        &path,
        &ImportOptions {
            memory_budget: 256 << 20,
        },
    )
    .unwrap();
    assert_eq!((s.textures[0].width, s.textures[0].height), (2048, 2048));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn primitives_over_the_same_accessors_are_read_once() {
    // 256 meshes, each a primitive over the one triangle's accessors: a small file must not make
    // the importer decode the same bytes 256 times.
    let dir = folder("same-accessors");
    let mut g = triangle_gltf();
    let meshes: Vec<Value> = (0..256)
        .map(|_| json!({"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}))
        .collect();
    g["meshes"] = Value::Array(meshes);
    g["nodes"] = json!((0..256).map(|k| json!({"mesh": k})).collect::<Vec<_>>());
    g["scenes"][0]["nodes"] = json!((0..256).collect::<Vec<_>>());
    let path = write(&dir, "shared.gltf", &g);
    let s = load_scene(&path).unwrap();
    assert_eq!(s.meshes.len(), 256);
    for m in &s.meshes[1..] {
        assert!(Arc::ptr_eq(&m.geometry, &s.meshes[0].geometry));
    }
    std::fs::remove_dir_all(&dir).ok();
}
