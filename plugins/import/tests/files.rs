//! Real files from ../shared/scenes, good and broken.

use std::path::{Path, PathBuf};
use treelight_import::{ImportedLight, ImportedLightKind, WrapMode, load_scene};

fn scene(rel: &str) -> PathBuf {
    treelight_test_support::shared_scene(rel)
}

#[test]
fn flight_helmet_loads_all_meshes_with_transforms() {
    let s = load_scene(&scene("gltf/FlightHelmet/FlightHelmet.gltf")).unwrap();
    assert!(s.meshes.len() >= 5, "{} meshes", s.meshes.len());
    assert_eq!(s.triangle_count(), 94_722);
    assert!(s.materials.len() >= 5);
    for m in &s.meshes {
        assert!(
            m.geometry
                .indices
                .iter()
                .all(|&i| (i as usize) < m.geometry.positions.len())
        );
        assert!(m.geometry.normals.is_some(), "{} lacks normals", m.name);
        // Every mesh has the file's tangents: unit length, with the bitangent's sign.
        let tangents = m.geometry.tangents.as_ref().expect("the file's tangents");
        assert_eq!(tangents.len(), m.geometry.positions.len());
        assert!(tangents.iter().all(|t| {
            let l = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            (l - 1.0).abs() < 1e-5 && (t[3] == 1.0 || t[3] == -1.0)
        }));
    }
    // A file without them has none.
    let boxed = load_scene(&scene("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    assert!(boxed.meshes.iter().all(|m| m.geometry.tangents.is_none()));
}

#[test]
fn separate_and_embedded_buffers_give_the_same_box() {
    let a = load_scene(&scene("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    let b = load_scene(&scene("gltf/BoxTextured-glTF-Embedded/BoxTextured.gltf")).unwrap();
    assert_eq!(a.triangle_count(), 12);
    assert_eq!(a.world_triangles(), b.world_triangles());
}

#[test]
fn base_colour_textures_are_decoded_once_with_their_wrap_modes() {
    // BoxTextured: one 256×256 PNG (the Cesium logo), as a file and as a data URI.
    let a = load_scene(&scene("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    let b = load_scene(&scene("gltf/BoxTextured-glTF-Embedded/BoxTextured.gltf")).unwrap();
    assert!(a.warnings.is_empty(), "{:?}", a.warnings);
    assert_eq!(a.textures.len(), 1);
    let t = &a.textures[0];
    assert_eq!(t.rgba8.len(), (t.width * t.height * 4) as usize);
    assert!(t.width >= 64 && t.height >= 64, "{t:?}");
    assert_eq!(a.textures[0].rgba8, b.textures[0].rgba8);
    let r = a.materials[0]
        .base_color_texture
        .expect("the box is textured");
    assert_eq!(r.texture, 0);
    // The file's sampler: wrapS MIRRORED_REPEAT (33648), wrapT CLAMP_TO_EDGE (33071).
    assert_eq!(r.wrap, [WrapMode::MirroredRepeat, WrapMode::ClampToEdge]);
    // FlightHelmet's sampler names no wrap modes: glTF's default, REPEAT.
    // More than one colour: the logo, not a flat fill.
    let mut colours: Vec<&[u8]> = t.rgba8.chunks_exact(4).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 10, "{} colours", colours.len());
    // FlightHelmet: fifteen PNGs beside the file, three per look (base colour, normal, and
    // occlusion-roughness-metal packed in one image, used by two maps), decoded once each.
    let h = load_scene(&scene("gltf/FlightHelmet/FlightHelmet.gltf")).unwrap();
    assert!(h.warnings.is_empty(), "{:?}", h.warnings);
    assert_eq!(h.textures.len(), 15);
    let name = |r: Option<treelight_import::TextureRef>| {
        h.textures[r.expect("every helmet material has every map").texture]
            .name
            .clone()
    };
    for m in &h.materials {
        let r = m.base_color_texture.unwrap();
        assert_eq!(r.wrap, [WrapMode::Repeat; 2]);
        assert!(
            name(m.base_color_texture).contains("BaseColor"),
            "{}",
            m.name
        );
        assert!(name(m.normal_texture).contains("Normal"), "{}", m.name);
        assert!(name(m.metallic_roughness_texture).contains("OcclusionRoughMetal"));
        assert_eq!(
            m.occlusion_texture.unwrap().texture,
            m.metallic_roughness_texture.unwrap().texture,
            "{}: one packed image serves both maps",
            m.name
        );
        assert!(m.emissive_texture.is_none());
        let blend = m.alpha_mode == treelight_import::ImportedAlphaMode::Blend;
        assert_eq!(blend, m.name == "LensesMat", "{}", m.name);
    }
}

#[test]
fn every_material_map_alpha_mode_and_extension_is_read() {
    let (dir, path, mut json) = copy_box_textured("material-ext");
    // A material using every map (all on texture 0), alpha mode and material extension.
    let fixture: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/material-everything.json"),
        )
        .unwrap(),
    )
    .unwrap();
    json["extensionsUsed"] = fixture["extensionsUsed"].clone();
    json["materials"][0] = fixture["material"].clone();
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let s = load_scene(&path).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.materials[0];
    assert_eq!(m.base_color, [1.0, 0.5, 0.25, 0.8]);
    assert_eq!((m.metallic, m.roughness), (0.3, 0.7));
    assert_eq!(m.emissive, [4.0, 2.0, 0.0]);
    assert_eq!(m.normal_scale, 0.5);
    assert_eq!(m.occlusion_strength, 0.25);
    assert_eq!(
        m.alpha_mode,
        treelight_import::ImportedAlphaMode::Mask { cutoff: 0.3 }
    );
    assert_eq!(m.transmission, 0.6);
    assert_eq!(m.ior, 1.33);
    assert_eq!((m.specular, m.specular_color), (0.5, [1.0, 0.9, 0.8]));
    assert_eq!((m.clearcoat, m.clearcoat_roughness), (0.75, 0.2));
    for map in [
        m.base_color_texture,
        m.metallic_roughness_texture,
        m.normal_texture,
        m.occlusion_texture,
        m.emissive_texture,
    ] {
        assert_eq!(map.expect("every map is read").texture, 0);
    }
    // One image, decoded once for all five maps.
    assert_eq!(s.textures.len(), 1);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn hostile_material_values_are_clamped_with_a_warning() {
    let (dir, path, mut json) = copy_box_textured("material-hostile");
    json["extensionsUsed"] = serde_json::json!([
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_clearcoat",
        "KHR_materials_emissive_strength",
        "KHR_texture_transform"
    ]);
    json["materials"][0] = serde_json::json!({
        "name": "hostile",
        "pbrMetallicRoughness": {
            "baseColorFactor": [7.0, -1.0, 0.5, 1.0],
            "roughnessFactor": 1e30,
            "metallicFactor": -3.0
        },
        "normalTexture": {"index": 0, "scale": 1e9, "texCoord": 2},
        "occlusionTexture": {
            "index": 0,
            "extensions": {"KHR_texture_transform": {"scale": [1e39, 1.0]}}
        },
        "emissiveFactor": [1.0, 1.0, 1.0],
        "alphaMode": "MASK",
        "alphaCutoff": 40.0,
        "extensions": {
            "KHR_materials_transmission": {"transmissionFactor": 9.0},
            "KHR_materials_ior": {"ior": 1000.0},
            "KHR_materials_clearcoat": {"clearcoatFactor": "lots", "clearcoatRoughnessFactor": -1},
            "KHR_materials_emissive_strength": {"emissiveStrength": 1e38}
        }
    });
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let s = match load_scene(&path) {
        Ok(s) => s,
        // The gltf crate's own validation may refuse some values outright: then the error names
        // the file.
        Err(e) => {
            assert_eq!(e.file, path);
            std::fs::remove_dir_all(&dir).ok();
            return;
        }
    };
    let m = &s.materials[0];
    let all = [
        m.base_color[0],
        m.base_color[1],
        m.metallic,
        m.roughness,
        m.transmission,
        m.ior,
        m.clearcoat,
        m.clearcoat_roughness,
        m.normal_scale,
    ];
    assert!(all.iter().all(|v| v.is_finite()), "{m:?}");
    assert_eq!(m.base_color[..2], [1.0, 0.0]);
    assert_eq!((m.metallic, m.roughness, m.transmission), (0.0, 1.0, 1.0));
    assert_eq!(m.ior, 5.0);
    assert_eq!(m.clearcoat_roughness, 0.0);
    assert!(m.emissive.iter().all(|e| e.is_finite() && *e <= 1e6));
    assert_eq!(
        m.alpha_mode,
        treelight_import::ImportedAlphaMode::Mask { cutoff: 1.0 }
    );
    // A third UV set and an infinite transform: those maps are left out, each with a warning.
    assert!(m.normal_texture.is_none() && m.occlusion_texture.is_none());
    let text = s.warnings.join("\n");
    for part in [
        "texture coordinate set 2",
        "non-finite KHR_texture_transform",
        "roughness factor",
        "index of refraction",
        "emissive strength",
        "alpha cutoff",
    ] {
        assert!(text.contains(part), "no warning about {part}: {text}");
    }
    assert!(
        s.warnings
            .iter()
            .all(|w| w.contains("'hostile'") || w.contains("BoxTextured")),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_textures_become_warnings_and_keep_the_geometry() {
    let dir = std::env::temp_dir().join(format!("treelight-textures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let original =
        std::fs::read_to_string(scene("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    std::fs::copy(
        scene("gltf/BoxTextured-glTF/BoxTextured0.bin"),
        dir.join("BoxTextured0.bin"),
    )
    .unwrap();
    let cases = [
        ("missing.gltf", "gone.png", None, "cannot read image"),
        ("escape.gltf", "../../etc/passwd", None, "outside"),
        (
            "garbage.gltf",
            "garbage.png",
            Some(b"\x89PNG\r\n\x1a\nnot really".to_vec()),
            "cannot read its header",
        ),
        (
            "text.gltf",
            "text.png",
            Some(b"hello".to_vec()),
            "not a PNG or JPEG",
        ),
        // A valid PNG header claiming 100000 × 100000 pixels: refused by the side limit, from
        // the header, before the decoder is asked.
        (
            "huge.gltf",
            "huge.png",
            Some(huge_png_header()),
            "declares 100000×100000 pixels, over the limit of 16384 a side",
        ),
    ];
    for (file, uri, contents, expected) in cases {
        if let Some(bytes) = contents {
            std::fs::write(dir.join(uri), bytes).unwrap();
        }
        let text = original.replace("CesiumLogoFlat.png", uri);
        assert_ne!(text, original);
        std::fs::write(dir.join(file), text).unwrap();
        let s = load_scene(&dir.join(file)).unwrap();
        assert_eq!(s.triangle_count(), 12, "{file}: the geometry stays");
        assert!(s.textures.is_empty(), "{file}");
        assert!(s.materials[0].base_color_texture.is_none(), "{file}");
        assert_eq!(s.warnings.len(), 1, "{file}: {:?}", s.warnings);
        let w = &s.warnings[0];
        assert!(w.contains(uri) && w.contains(expected), "{file}: {w}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The first bytes of a PNG whose IHDR claims 100000 × 100000 RGBA pixels (40 GB decoded).
fn huge_png_header() -> Vec<u8> {
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(100_000u32.to_be_bytes());
    ihdr.extend(100_000u32.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    let crc = crc32(&ihdr);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc.to_be_bytes());
    // An empty IDAT and the end, so that the header reads as a whole image's.
    for chunk in [&b"IDAT"[..], b"IEND"] {
        png.extend(0u32.to_be_bytes());
        png.extend(chunk);
        png.extend(crc32(chunk).to_be_bytes());
    }
    png
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

#[test]
fn skinned_glb_loads() {
    let s = load_scene(&scene("gltf/CesiumMan.glb")).unwrap();
    assert!(s.triangle_count() > 1000);
}

#[test]
fn unsupported_extensions_are_named() {
    let original = std::fs::read(scene("gltf/Box_Draco.glb")).unwrap();
    let dir = std::env::temp_dir().join(format!("treelight-ext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("Box_Future.glb");
    let bytes = glb_with_json(&original, |j| {
        j["extensionsUsed"] = serde_json::json!(["KHR_draco_mesh_compression", "EXT_future_mesh"]);
        j["extensionsRequired"] =
            serde_json::json!(["KHR_draco_mesh_compression", "EXT_future_mesh"]);
    });
    std::fs::write(&path, bytes).unwrap();
    let e = load_scene(&path).unwrap_err().to_string();
    assert!(e.contains("EXT_future_mesh"), "{e}");
    assert!(
        !e.contains("KHR_draco"),
        "a supported extension is not named: {e}"
    );
    assert!(e.contains("Box_Future.glb"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn draco_box_decodes_to_the_uncompressed_box() {
    let draco = load_scene(&scene("gltf/Box_Draco.glb")).unwrap();
    let plain = load_scene(&scene("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    let tris =
        |s: &treelight_import::ImportedScene| -> Vec<[glam::Vec3; 3]> { s.world_triangles() };
    let (a, b) = (tris(&draco), tris(&plain));
    assert_eq!(a.len(), 12);
    assert_eq!(a.len(), b.len());
    // Each decoded triangle is one of the box's, up to the order of its corners (Draco reorders
    // points and quantizes positions to 1/2^14 of the box).
    let same = |x: &[glam::Vec3; 3], y: &[glam::Vec3; 3]| {
        (0..3).any(|r| (0..3).all(|k| x[k].abs_diff_eq(y[(k + r) % 3], 1e-3)))
    };
    for t in &a {
        assert!(
            b.iter().any(|u| same(t, u)),
            "{t:?} is not a face of the box"
        );
    }
    for u in &b {
        assert!(a.iter().any(|t| same(t, u)), "{u:?} is missing");
    }
    let normals = draco.meshes[0]
        .geometry
        .normals
        .as_ref()
        .expect("normals decoded");
    assert!(
        normals
            .iter()
            .all(|n| (glam::Vec3::from(*n).length() - 1.0).abs() < 1e-4)
    );
}

#[test]
fn broken_draco_streams_are_refused_with_the_mesh_named() {
    let original = std::fs::read(scene("gltf/Box_Draco.glb")).unwrap();
    let len = u32::from_le_bytes(original[12..16].try_into().unwrap()) as usize;
    let bin = 20 + len + 8;
    let dir = std::env::temp_dir().join(format!("treelight-draco-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, flip) in [("zeroed.glb", 0u8), ("flipped.glb", 0x5a)] {
        let mut bytes = original.clone();
        for b in &mut bytes[bin + 8..] {
            *b = if flip == 0 { 0 } else { *b ^ flip };
        }
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let e = load_scene(&path).expect_err(name);
        assert_eq!(e.file, path);
        assert!(
            e.problem
                .starts_with("mesh 'mesh 0' (KHR_draco_mesh_compression): "),
            "{e}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
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
        assert_eq!(e.file, file);
        let expected = match dir {
            "MissingBin" => "cannot read buffer",
            _ => "past its",
        };
        assert!(e.problem.contains(expected), "{dir}: {e}");
    }
}

#[test]
fn obj_scenes_fan_triangulate_in_file_order() {
    // A quad, a triangle and a pentagon: each polygon fanned from its first corner, in file order.
    let dir = std::env::temp_dir().join(format!("treelight-obj-order-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("fans.obj");
    std::fs::write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 2 0\n\
         f 1 2 3 4\nf 2 5 3\nf 6 4 1 2 5\n",
    )
    .unwrap();
    let v = |i: usize| {
        glam::Vec3::from(
            [
                [0., 0., 0.],
                [1., 0., 0.],
                [1., 1., 0.],
                [0., 1., 0.],
                [2., 0., 0.],
                [2., 2., 0.],
            ][i - 1],
        )
    };
    let expected: Vec<[glam::Vec3; 3]> = [
        [1, 2, 3],
        [1, 3, 4],
        [2, 5, 3],
        [6, 4, 1],
        [6, 1, 2],
        [6, 2, 5],
    ]
    .iter()
    .map(|t| t.map(v))
    .collect();
    assert_eq!(load_scene(&path).unwrap().world_triangles(), expected);
    std::fs::remove_dir_all(&dir).ok();
    // The real scenes: every face of the file, fanned in file order, and nothing else.
    for file in ["obj/sibenik.obj", "obj/stanford-bunny.obj"] {
        let text = std::fs::read_to_string(scene(file)).unwrap();
        let mut positions = Vec::new();
        let mut fanned = Vec::new();
        for line in text.lines() {
            let mut words = line.split_whitespace();
            match words.next() {
                Some("v") => {
                    let c: Vec<f32> = words.take(3).map(|w| w.parse().unwrap()).collect();
                    positions.push(glam::Vec3::new(c[0], c[1], c[2]));
                }
                Some("f") => {
                    let corners: Vec<usize> = words
                        .map(|w| w.split('/').next().unwrap().parse::<usize>().unwrap() - 1)
                        .collect();
                    for k in 1..corners.len() - 1 {
                        fanned.push([corners[0], corners[k], corners[k + 1]].map(|i| positions[i]));
                    }
                }
                _ => {}
            }
        }
        let imported = load_scene(&scene(file)).unwrap().world_triangles();
        assert_eq!(imported.len(), fanned.len(), "{file}");
        assert!(
            imported == fanned,
            "{file}: triangles differ from the file's faces in order"
        );
    }
    assert_eq!(
        load_scene(&scene("obj/sibenik.obj"))
            .unwrap()
            .triangle_count(),
        73_564
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

#[test]
fn gltf_node_hierarchies_are_kept_with_local_transforms_and_keys() {
    for file in ["gltf/CesiumMan.glb", "gltf/FlightHelmet/FlightHelmet.gltf"] {
        let s = load_scene(&scene(file)).unwrap();
        assert!(!s.nodes.is_empty(), "{file}");
        for (i, n) in s.nodes.iter().enumerate() {
            // Parents come first, and keys extend the parent's key.
            if let Some(p) = n.parent {
                assert!(p < i, "{file}: node {i} before its parent {p}");
                assert!(
                    n.key.starts_with(&format!("{}/", s.nodes[p].key)),
                    "{}",
                    n.key
                );
            } else {
                assert!(!n.key.contains('/'), "{}", n.key);
            }
        }
        let keys: std::collections::HashSet<&str> =
            s.nodes.iter().map(|n| n.key.as_str()).collect();
        // Every mesh hangs under a node whose chain of local transforms gives its world transform.
        for m in &s.meshes {
            let mut world = glam::Mat4::IDENTITY;
            let mut at = m.node;
            while let Some(i) = at {
                world = s.nodes[i].local * world;
                at = s.nodes[i].parent;
            }
            assert!(
                world.abs_diff_eq(m.transform, 1e-5),
                "{file}: '{}' {world} vs {}",
                m.name,
                m.transform
            );
        }
        assert_eq!(keys.len(), s.nodes.len(), "{file}: keys repeat");
    }
    // CesiumMan nests its mesh several levels down.
    let s = load_scene(&scene("gltf/CesiumMan.glb")).unwrap();
    let node = s.meshes[0].node.unwrap();
    assert!(s.nodes[node].parent.is_some(), "{:?}", s.nodes);
}

/// Appends `uvs` to the .bin beside `json`'s BoxTextured copy in `dir` as an accessor of its own,
/// and returns its index.
fn add_uv_accessor(dir: &Path, json: &mut serde_json::Value, uvs: &[[f32; 2]]) -> usize {
    let bin = dir.join("BoxTextured0.bin");
    let mut bytes = std::fs::read(&bin).unwrap();
    let offset = bytes.len();
    bytes.extend(uvs.iter().flatten().flat_map(|v| v.to_le_bytes()));
    std::fs::write(&bin, &bytes).unwrap();
    json["buffers"][0]["byteLength"] = serde_json::json!(bytes.len());
    let views = json["bufferViews"].as_array_mut().unwrap();
    views.push(serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": uvs.len() * 8}));
    let view = views.len() - 1;
    let accessors = json["accessors"].as_array_mut().unwrap();
    accessors.push(serde_json::json!({
        "bufferView": view, "componentType": 5126, "count": uvs.len(), "type": "VEC2"
    }));
    accessors.len() - 1
}

/// A material that reads every map it traces through `TEXCOORD_1` has its mesh's two sets
/// exchanged, and its maps' sets with them: set 0 (what the path tracer reads) holds what its maps
/// read, and the raster view's occlusion map still reads the file's set 0, now set 1.
#[test]
fn a_material_on_the_second_uv_set_reads_it_as_the_first() {
    let (dir, path, mut json) = copy_box_textured("uv-set-1");
    let set1: Vec<[f32; 2]> = (0..24).map(|i| [i as f32 / 24.0, 0.25]).collect();
    let accessor = add_uv_accessor(&dir, &mut json, &set1);
    json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = serde_json::json!(accessor);
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] =
        serde_json::json!(1);
    json["materials"][0]["occlusionTexture"] = serde_json::json!({"index": 0});
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let plain = load_scene(&scene("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    assert!(plain.meshes.iter().all(|m| m.geometry.uvs1.is_none()));
    let s = load_scene(&path).unwrap();
    let g = &s.meshes[0].geometry;
    assert_eq!(g.uvs.as_ref(), Some(&set1));
    assert_eq!(g.uvs1, plain.meshes[0].geometry.uvs);
    let m = &s.materials[0];
    assert_eq!(m.base_color_texture.map(|t| t.tex_coord), Some(0));
    assert_eq!(m.occlusion_texture.map(|t| t.tex_coord), Some(1));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    std::fs::remove_dir_all(&dir).ok();
}

/// A material whose maps read both sets keeps the file's sets, both traced (no warning); an
/// occlusion map on set 1 alone needs no exchange; a second set no map reads is dropped.
#[test]
fn a_material_on_both_uv_sets_keeps_both() {
    let (dir, path, mut json) = copy_box_textured("uv-sets-both");
    let set1: Vec<[f32; 2]> = (0..24).map(|i| [0.5, i as f32 / 24.0]).collect();
    let accessor = add_uv_accessor(&dir, &mut json, &set1);
    json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = serde_json::json!(accessor);
    json["materials"][0]["normalTexture"] = serde_json::json!({"index": 0, "texCoord": 1});
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let s = load_scene(&path).unwrap();
    assert_eq!(s.meshes[0].geometry.uvs1.as_ref(), Some(&set1));
    let m = &s.materials[0];
    assert_eq!(m.base_color_texture.map(|t| t.tex_coord), Some(0));
    assert_eq!(m.normal_texture.map(|t| t.tex_coord), Some(1));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // Occlusion baked through set 1 asks for no exchange.
    json["materials"][0]
        .as_object_mut()
        .unwrap()
        .remove("normalTexture");
    json["materials"][0]["occlusionTexture"] = serde_json::json!({"index": 0, "texCoord": 1});
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let s = load_scene(&path).unwrap();
    assert_eq!(s.meshes[0].geometry.uvs1.as_ref(), Some(&set1));
    assert_eq!(
        s.materials[0].occlusion_texture.map(|t| t.tex_coord),
        Some(1)
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // With no map on set 1, the mesh keeps set 0 alone.
    json["materials"][0]
        .as_object_mut()
        .unwrap()
        .remove("occlusionTexture");
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let s = load_scene(&path).unwrap();
    assert!(s.meshes[0].geometry.uvs.is_some());
    assert_eq!(s.meshes[0].geometry.uvs1, None);
    std::fs::remove_dir_all(&dir).ok();
}

/// A copy of BoxTextured (its .gltf, .bin and image) in a fresh folder named after `tag`: the folder,
/// the .gltf's path and its JSON, to edit and write back.
fn copy_box_textured(tag: &str) -> (PathBuf, PathBuf, serde_json::Value) {
    let dir = std::env::temp_dir().join(format!("treelight-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for f in std::fs::read_dir(scene("gltf/BoxTextured-glTF")).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, dir.join(f.file_name().unwrap())).unwrap();
    }
    let path = dir.join("BoxTextured.gltf");
    let json = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    (dir, path, json)
}

#[test]
fn siblings_of_one_name_get_keys_of_their_own() {
    // BoxTextured with four more top-level nodes: three named "part", one named "part[1]".
    let (dir, path, mut json) = copy_box_textured("same-names");
    let nodes = json["nodes"].as_array_mut().unwrap();
    let first = nodes.len();
    for name in ["part", "part[1]", "part", "part"] {
        nodes.push(serde_json::json!({ "name": name }));
    }
    let roots = json["scenes"][0]["nodes"].as_array_mut().unwrap();
    roots.extend((first..first + 4).map(|i| serde_json::json!(i)));
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let s = load_scene(&path).unwrap();
    let mut parts: Vec<&str> = s
        .nodes
        .iter()
        .filter(|n| n.name.starts_with("part"))
        .map(|n| n.key.as_str())
        .collect();
    parts.sort_unstable();
    parts.dedup();
    // Four keys, however the repeats and the literal "part[1]" meet in the walk.
    assert_eq!(parts.len(), 4, "{parts:?}");
    assert!(
        parts.contains(&"part") && parts.contains(&"part[1]"),
        "{parts:?}"
    );
    // And the same file gives the same keys again.
    let again = load_scene(&path).unwrap();
    let keys = |s: &treelight_import::ImportedScene| {
        s.nodes.iter().map(|n| n.key.clone()).collect::<Vec<_>>()
    };
    assert_eq!(keys(&s), keys(&again));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_mesh_placed_by_several_nodes_is_read_once_and_marked_the_same() {
    // BoxTextured with a second node placing the same mesh elsewhere.
    let (dir, path, mut json) = copy_box_textured("reuse");
    let nodes = json["nodes"].as_array_mut().unwrap();
    let mesh_node = nodes.iter().position(|n| n.get("mesh").is_some()).unwrap();
    nodes.push(serde_json::json!({"name": "copy", "mesh": nodes[mesh_node]["mesh"], "translation": [3.0, 0.0, 0.0]}));
    let copy = nodes.len() - 1;
    json["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!(copy));
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();

    let s = load_scene(&path).unwrap();
    assert_eq!(s.meshes.len(), 2);
    let (a, b) = (&s.meshes[0], &s.meshes[1]);
    assert_eq!(a.same_as, None);
    assert_eq!(b.same_as, Some(0));
    assert_eq!(
        (&a.geometry.positions, &a.geometry.indices),
        (&b.geometry.positions, &b.geometry.indices)
    );
    assert_eq!(a.material, b.material);
    let copy = s.meshes.iter().find(|m| m.name == "copy").unwrap();
    let other = s.meshes.iter().find(|m| m.name != "copy").unwrap();
    assert!(
        (copy.transform.w_axis - other.transform.w_axis).abs_diff_eq(glam::Vec4::X * 3.0, 1e-6),
        "{} vs {}",
        copy.transform,
        other.transform
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn texture_transforms_are_read_as_one_affine_map() {
    let (dir, path, mut json) = copy_box_textured("uvxf");
    json["extensionsUsed"] = serde_json::json!(["KHR_texture_transform"]);
    json["extensionsRequired"] = serde_json::json!(["KHR_texture_transform"]);
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = serde_json::json!({
        "KHR_texture_transform": {"offset": [0.25, 0.5], "rotation": 0.5, "scale": [2.0, 3.0]}
    });
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();

    let s = load_scene(&path).unwrap();
    let t = s.materials[0].base_color_texture.unwrap();
    let [x, y, o] = t.uv_transform;
    // translation × rotation × scale, rotating UVs counter-clockwise (as Bevy's own glTF loader).
    let (sin, cos) = 0.5f32.sin_cos();
    let uv = glam::Vec2::new(0.3, 0.7);
    let got = glam::Vec2::from(x) * uv.x + glam::Vec2::from(y) * uv.y + glam::Vec2::from(o);
    let scaled = uv * glam::Vec2::new(2.0, 3.0);
    let want = glam::Vec2::new(
        cos * scaled.x + sin * scaled.y,
        -sin * scaled.x + cos * scaled.y,
    ) + glam::Vec2::new(0.25, 0.5);
    assert!(got.abs_diff_eq(want, 1e-6), "{got} vs {want}");
    // Without the extension the map is the identity.
    let plain = load_scene(&scene("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    assert_eq!(
        plain.materials[0].base_color_texture.unwrap().uv_transform,
        treelight_import::UV_IDENTITY
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn meshopt_compressed_quantized_glb_decodes_to_the_bounds_it_declares() {
    // pirate.glb: EXT_meshopt_compression (attributes, octahedral normals, triangle indices) over
    // KHR_mesh_quantization (16-bit integer positions, 8-bit normalized normals).
    let s = load_scene(&scene("gltf/pirate.glb")).unwrap();
    assert_eq!(s.meshes.len(), 1);
    let m = &s.meshes[0];
    assert_eq!(m.geometry.positions.len(), 2887);
    assert_eq!(m.triangle_count(), 15030 / 3);
    // The file's accessor declares the integer positions' bounds: decoding must meet them exactly.
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for p in &m.geometry.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    assert_eq!(lo, [0.0, 0.0, 0.0]);
    assert_eq!(hi, [13081.0, 16383.0, 3915.0]);
    let normals = m
        .geometry
        .normals
        .as_ref()
        .expect("octahedral normals decoded");
    assert!(
        normals
            .iter()
            .all(|n| (glam::Vec3::from(*n).length() - 1.0).abs() < 1e-4)
    );
    // Every triangle uses three distinct in-range vertices and the mesh is one connected surface's
    // worth of area, not noise: neighbouring triangles share vertices.
    let mut used = vec![0u32; m.geometry.positions.len()];
    for f in m.geometry.indices.chunks_exact(3) {
        assert!(f[0] != f[1] && f[1] != f[2] && f[0] != f[2], "{f:?}");
        for &i in f {
            used[i as usize] += 1;
        }
    }
    assert!(used.iter().filter(|&&u| u >= 3).count() > m.geometry.positions.len() / 2);
    // The node's scale brings it to about 1.9 units tall.
    let world: Vec<_> = m.world_triangles().collect();
    let top = world.iter().flatten().map(|p| p.y).fold(f32::MIN, f32::max);
    let bottom = world.iter().flatten().map(|p| p.y).fold(f32::MAX, f32::min);
    assert!(((top - bottom) - 16383.0 * 0.000_116_282_18).abs() < 1e-4);
}

/// A .glb with its JSON chunk replaced (the binary chunk kept).
fn glb_with_json(bytes: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + len]).unwrap();
    edit(&mut json);
    let mut text = serde_json::to_vec(&json).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let rest = &bytes[20 + len..];
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + text.len() + rest.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(rest);
    out
}

#[test]
fn hostile_meshopt_streams_give_errors_not_crashes() {
    let original = std::fs::read(scene("gltf/pirate.glb")).unwrap();
    let dir = std::env::temp_dir().join(format!("treelight-meshopt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            // meshoptimizer asserts (aborts) on such a stride: it must never see it.
            "odd_stride.glb",
            glb_with_json(&original, |j| {
                j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["byteStride"] =
                    serde_json::json!(6);
            }),
            "6-byte elements",
        ),
        (
            "past_end.glb",
            glb_with_json(&original, |j| {
                j["bufferViews"][2]["extensions"]["EXT_meshopt_compression"]["byteOffset"] =
                    serde_json::json!(1_000_000);
            }),
            "past the end",
        ),
        (
            "unknown_filter.glb",
            glb_with_json(&original, |j| {
                j["bufferViews"][1]["extensions"]["EXT_meshopt_compression"]["filter"] =
                    serde_json::json!("SPIRAL");
            }),
            "filter 'SPIRAL'",
        ),
        (
            "huge_count.glb",
            glb_with_json(&original, |j| {
                j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] =
                    serde_json::json!(u64::MAX / 2);
            }),
            "elements",
        ),
    ];
    for (name, bytes, expected) in cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let e = load_scene(&path).expect_err(name).to_string();
        assert!(e.contains(name) && e.contains(expected), "{name}: {e}");
    }
    // Scrambled compressed bytes: an error or a checked mesh, never a crash.
    let mut scrambled = original.clone();
    let len = u32::from_le_bytes(original[12..16].try_into().unwrap()) as usize;
    let bin = 20 + len + 8;
    for (k, b) in scrambled[bin..].iter_mut().enumerate() {
        *b ^= (k as u8).wrapping_mul(37) | 1;
    }
    let path = dir.join("scrambled.glb");
    std::fs::write(&path, scrambled).unwrap();
    if let Ok(s) = load_scene(&path) {
        for m in &s.meshes {
            assert!(
                m.geometry
                    .indices
                    .iter()
                    .all(|&i| (i as usize) < m.geometry.positions.len())
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_file_with_one_bad_mesh_imports_the_others_and_names_it() {
    let dir = std::env::temp_dir().join(format!("treelight-onebad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let src = scene("gltf/FlightHelmet");
    // The geometry only: the textures' absence is a warning of its own.
    for f in std::fs::read_dir(&src).unwrap() {
        let f = f.unwrap().path();
        if f.extension().is_some_and(|e| e == "bin") {
            std::fs::copy(&f, dir.join(f.file_name().unwrap())).unwrap();
        }
    }
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(src.join("FlightHelmet.gltf")).unwrap())
            .unwrap();
    let bad_mesh = json["meshes"][2]["name"].as_str().unwrap().to_owned();
    let acc = json["meshes"][2]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap() as usize;
    json["accessors"][acc]["count"] = serde_json::json!(50_000_000);
    let path = dir.join("FlightHelmet.gltf");
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let s = load_scene(&path).unwrap();
    let whole = load_scene(&scene("gltf/FlightHelmet/FlightHelmet.gltf")).unwrap();
    assert_eq!(s.meshes.len(), whole.meshes.len() - 1);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("skipped") && w.contains(&bad_mesh)),
        "{:?}",
        s.warnings
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn gltf_punctual_lights_come_with_their_nodes_and_bad_ones_are_named() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/lights.gltf");
    let s = load_scene(&path).unwrap();
    let light = |name: &str| {
        s.nodes
            .iter()
            .find(|n| n.name == name)
            .unwrap_or_else(|| panic!("no node {name}"))
            .light
    };
    assert_eq!(
        light("Lamp"),
        Some(ImportedLight {
            kind: ImportedLightKind::Point,
            color: [1.0, 0.5, 0.25],
            intensity: 10.0,
            range: Some(5.0),
        })
    );
    assert_eq!(
        light("Spot").map(|l| l.kind),
        Some(ImportedLightKind::Spot {
            inner_angle: 0.2,
            outer_angle: 0.5
        })
    );
    let sun = light("Sun").unwrap();
    assert_eq!(
        (sun.kind, sun.color, sun.intensity, sun.range),
        (ImportedLightKind::Directional, [1.0; 3], 3.0, None)
    );
    assert_eq!(light("Tri"), None);
    assert_eq!(light("Bad"), None, "a negative intensity is no light");
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("'Bad'") && w.contains("intensity")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn hostile_punctual_lights_are_refused_or_skipped_never_a_panic() {
    let good = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/lights.gltf"),
    )
    .unwrap();
    let dir = std::env::temp_dir().join(format!("treelight-hostile-lights-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Each: the change, and whether the file must still open (with the light skipped).
    let cases: [(&str, &str, bool); 7] = [
        ("\"intensity\": 10.0", "\"intensity\": \"bright\"", false),
        ("\"intensity\": 10.0", "\"intensity\": 1e39", true),
        ("\"range\": 5.0", "\"range\": -1e39", true),
        (
            "\"spot\": {\"innerConeAngle\": 0.2, \"outerConeAngle\": 0.5}",
            "\"spot\": {\"innerConeAngle\": 9.0, \"outerConeAngle\": -1e39}",
            true,
        ),
        (
            ", \"spot\": {\"innerConeAngle\": 0.2, \"outerConeAngle\": 0.5}",
            "",
            false,
        ),
        ("{\"light\": 3}", "{\"light\": 99}", false),
        ("\"type\": \"directional\"", "\"type\": \"area\"", false),
    ];
    for (i, (from, to, opens)) in cases.into_iter().enumerate() {
        assert!(good.contains(from), "case {i}");
        let path = dir.join(format!("case{i}.gltf"));
        std::fs::write(&path, good.replacen(from, to, 1)).unwrap();
        match load_scene(&path) {
            Ok(s) => {
                assert!(opens, "case {i} opened");
                for n in &s.nodes {
                    if let Some(l) = n.light {
                        assert!(l.intensity.is_finite() && l.intensity >= 0.0, "case {i}");
                        assert!(l.range.is_none_or(|r| r.is_finite() && r > 0.0));
                        if let ImportedLightKind::Spot {
                            inner_angle,
                            outer_angle,
                        } = l.kind
                        {
                            assert!(0.0 <= inner_angle && inner_angle <= outer_angle);
                            assert!(outer_angle <= std::f32::consts::FRAC_PI_2);
                        }
                    }
                }
                assert!(!s.warnings.is_empty(), "case {i}: {:?}", s.warnings);
            }
            Err(e) => {
                assert!(!opens, "case {i}: {e}");
                assert!(e.to_string().contains(&format!("case{i}.gltf")), "{e}");
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn gltf_cameras_come_with_their_nodes_and_bad_ones_are_named() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/cameras.gltf");
    let s = load_scene(&path).unwrap();
    let camera = |name: &str| {
        s.nodes
            .iter()
            .find(|n| n.name == name)
            .unwrap_or_else(|| panic!("no node {name}"))
            .camera
    };
    assert_eq!(
        camera("Front"),
        Some(treelight_import::ImportedCamera::Perspective {
            yfov: 0.6,
            near: 0.1,
            far: None,
            aspect: Some(1.6)
        })
    );
    assert_eq!(camera("Side"), camera("Front"));
    assert_eq!(
        camera("Top"),
        Some(treelight_import::ImportedCamera::Orthographic {
            ymag: 3.0,
            xmag: 3.0,
            near: 0.1,
            far: 20.0
        })
    );
    assert_eq!(camera("Card"), None);
    assert_eq!(camera("Bad"), None);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("'Bad'") && w.contains("camera")),
        "{:?}",
        s.warnings
    );
}
