//! PLY in ASCII and binary, and broken or hostile PLY files.

use std::path::PathBuf;
use treelight_import::load_scene;

/// A scratch folder of one test: the tests run in parallel and each removes its own at the end.
fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("treelight-ply-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const HEADER: &str = "element vertex 5
property float x
property float y
property float z
property float nx
property float ny
property float nz
property float u
property float v
element face 2
property list uchar int vertex_indices
end_header
";

/// A unit quad (one 4-gon) and a triangle above it, with normals and UVs.
const VERTICES: [[f32; 8]; 5] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
    [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
    [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0],
    [0.5, 0.5, 1.0, 0.0, 1.0, 0.0, 0.5, 0.5],
];
const FACES: [&[i32]; 2] = [&[0, 1, 2, 3], &[0, 1, 4]];

fn ascii() -> String {
    let mut s = format!("ply\nformat ascii 1.0\ncomment made by a test\n{HEADER}");
    for v in VERTICES {
        s += &v.map(|x| x.to_string()).join(" ");
        s += "\n";
    }
    for f in FACES {
        s += &format!(
            "{} {}\n",
            f.len(),
            f.iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    s
}

fn binary() -> Vec<u8> {
    let mut b = format!("ply\nformat binary_little_endian 1.0\n{HEADER}").into_bytes();
    for v in VERTICES {
        for x in v {
            b.extend(x.to_le_bytes());
        }
    }
    for f in FACES {
        b.push(f.len() as u8);
        for i in f {
            b.extend(i.to_le_bytes());
        }
    }
    b
}

#[test]
fn ascii_and_binary_give_the_same_fan_triangulated_mesh() {
    let d = dir("ascii_and_binary_give_the_same_fan_triangulated_mesh");
    std::fs::write(d.join("a.ply"), ascii()).unwrap();
    std::fs::write(d.join("b.ply"), binary()).unwrap();
    let a = load_scene(&d.join("a.ply")).unwrap();
    let b = load_scene(&d.join("b.ply")).unwrap();
    assert_eq!(a.meshes.len(), 1);
    let m = &a.meshes[0];
    assert_eq!(m.name, "a");
    // The 4-gon becomes (0,1,2) and (0,2,3), in file order, then the triangle.
    assert_eq!(m.geometry.indices, vec![0, 1, 2, 0, 2, 3, 0, 1, 4]);
    assert_eq!(m.geometry.normals.as_ref().unwrap()[4], [0.0, 1.0, 0.0]);
    assert_eq!(m.geometry.uvs.as_ref().unwrap()[2], [1.0, 1.0]);
    assert_eq!(a.triangle_count(), 3);
    assert_eq!(a.world_triangles(), b.world_triangles());
    assert_eq!(m.geometry.normals, b.meshes[0].geometry.normals);
    std::fs::remove_dir_all(&d).ok();
}

/// The binary file with vertex 4's x made NaN.
fn nan_binary(full: &[u8]) -> Vec<u8> {
    let mut b = full.to_vec();
    let header = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let at = header + 4 * 8 * 4;
    b[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    b
}

#[test]
fn broken_and_hostile_ply_files_are_refused_with_the_reason() {
    let d = dir("broken_and_hostile_ply_files_are_refused_with_the_reason");
    let text = ascii();
    let full = binary();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "huge.ply",
            text.replace("element vertex 5", "element vertex 4000000000").into_bytes(),
            "more than the file can hold",
        ),
        ("nan.ply", nan_binary(&full), "NaN"),
        // The ASCII reader refuses the word itself, naming the line.
        ("nan-text.ply", text.replacen("0.5 0.5 1", "nan 0.5 1", 1).into_bytes(), "Line 20"),
        ("range.ply", text.replace("3 0 1 4", "3 0 1 9").into_bytes(), "past its 5 vertices"),
        ("negative.ply", text.replace("3 0 1 4", "3 0 -1 4").into_bytes(), "negative"),
        ("truncated.ply", full[..full.len() - 6].to_vec(), "cannot read its face elements"),
        ("garbage.ply", b"not a ply file at all".to_vec(), "PLY header"),
        (
            "points.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n"
                .as_bytes()
                .to_vec(),
            "no faces",
        ),
        (
            "flat.ply",
            text.replace("property float z\n", "").into_bytes(),
            "lack an x, y or z",
        ),
    ];
    for (name, bytes, expected) in cases {
        let path = d.join(name);
        std::fs::write(&path, bytes).unwrap();
        let e = load_scene(&path).expect_err(name);
        assert_eq!(e.file, path);
        assert!(e.problem.contains(expected), "{name}: {e}");
    }
    std::fs::remove_dir_all(&d).ok();
}
