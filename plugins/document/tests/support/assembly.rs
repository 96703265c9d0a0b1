//! A generated glTF assembly for the import tests and benchmarks: many separate meshes on a grid,
//! so that streaming order and throughput show.

use std::path::{Path, PathBuf};

/// A glTF file of `parts` separate meshes of `rows × rows × 2` triangles each (bumpy tiles), on a
/// grid receding from the origin, written beside a `.bin` in `dir`. Returns the file and the
/// number of triangles.
#[allow(dead_code)]
pub fn generated_assembly(dir: &Path, parts: usize, rows: usize) -> (PathBuf, usize) {
    let mut bin: Vec<u8> = Vec::new();
    let (mut meshes, mut accessors, mut views, mut nodes) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let side = (parts as f32).sqrt().ceil() as usize;
    for p in 0..parts {
        let start = bin.len();
        let n = rows + 1;
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for j in 0..n {
            for i in 0..n {
                let (x, z) = (i as f32 / rows as f32, j as f32 / rows as f32);
                let y = 0.05 * ((x * 17.0 + p as f32).sin() * (z * 13.0).cos());
                for (k, v) in [x, y, z].into_iter().enumerate() {
                    lo[k] = lo[k].min(v);
                    hi[k] = hi[k].max(v);
                    bin.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        let positions_len = bin.len() - start;
        let index_start = bin.len();
        for j in 0..rows {
            for i in 0..rows {
                let a = (j * n + i) as u32;
                for v in [
                    a,
                    a + 1,
                    a + n as u32,
                    a + 1,
                    a + n as u32 + 1,
                    a + n as u32,
                ] {
                    bin.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        let index_len = bin.len() - index_start;
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{start},"byteLength":{positions_len}}}"#
        ));
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{index_start},"byteLength":{index_len}}}"#
        ));
        accessors.push(format!(
            r#"{{"bufferView":{},"componentType":5126,"count":{},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}"#,
            2 * p,
            n * n,
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2]
        ));
        accessors.push(format!(
            r#"{{"bufferView":{},"componentType":5125,"count":{},"type":"SCALAR"}}"#,
            2 * p + 1,
            rows * rows * 6
        ));
        meshes.push(format!(
            r#"{{"primitives":[{{"attributes":{{"POSITION":{}}},"indices":{}}}]}}"#,
            2 * p,
            2 * p + 1
        ));
        let (gx, gz) = ((p % side) as f32 * 1.2, (p / side) as f32 * 1.2);
        nodes.push(format!(
            r#"{{"name":"part {p}","mesh":{p},"translation":[{gx},0,{}]}}"#,
            -gz
        ));
    }
    let bin_path = dir.join("assembly.bin");
    std::fs::write(&bin_path, &bin).unwrap();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],"meshes":[{}],"accessors":[{}],"bufferViews":[{}],"buffers":[{{"uri":"assembly.bin","byteLength":{}}}]}}"#,
        (0..parts)
            .map(|p| p.to_string())
            .collect::<Vec<_>>()
            .join(","),
        nodes.join(","),
        meshes.join(","),
        accessors.join(","),
        views.join(","),
        bin.len()
    );
    let path = dir.join("assembly.gltf");
    std::fs::write(&path, json).unwrap();
    (path, parts * rows * rows * 2)
}

/// A glTF file of one small mesh (a 12-triangle box) placed by `copies` top-level nodes on a grid,
/// written beside a `.bin` in `dir`: an assembly of many nodes and little geometry. Returns the
/// file.
#[allow(dead_code)]
pub fn placed_assembly(dir: &Path, copies: usize) -> PathBuf {
    let corners: Vec<[f32; 3]> = (0..8)
        .map(|k| {
            [
                (k & 1) as f32 * 0.4,
                ((k >> 1) & 1) as f32 * 0.4,
                ((k >> 2) & 1) as f32 * 0.4,
            ]
        })
        .collect();
    let faces: [[u32; 3]; 12] = [
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    let mut bin: Vec<u8> = Vec::new();
    for c in &corners {
        for v in c {
            bin.extend_from_slice(&v.to_le_bytes());
        }
    }
    for f in &faces {
        for i in f {
            bin.extend_from_slice(&i.to_le_bytes());
        }
    }
    std::fs::write(dir.join("placed.bin"), &bin).unwrap();
    let side = (copies as f32).sqrt().ceil() as usize;
    let mut json = String::with_capacity(copies * 64 + 1024);
    json.push_str(r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":["#);
    for i in 0..copies {
        if i > 0 {
            json.push(',');
        }
        json.push_str(&i.to_string());
    }
    json.push_str(r#"]}],"nodes":["#);
    for i in 0..copies {
        if i > 0 {
            json.push(',');
        }
        let (x, z) = ((i % side) as f32, (i / side) as f32);
        json.push_str(&format!(
            r#"{{"name":"box {i}","mesh":0,"translation":[{x},0,{z}]}}"#
        ));
    }
    json.push_str(&format!(
        r#"],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],"accessors":[{{"bufferView":0,"componentType":5126,"count":8,"type":"VEC3","min":[0,0,0],"max":[0.4,0.4,0.4]}},{{"bufferView":1,"componentType":5125,"count":36,"type":"SCALAR"}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":96}},{{"buffer":0,"byteOffset":96,"byteLength":144}}],"buffers":[{{"uri":"placed.bin","byteLength":{}}}]}}"#,
        bin.len()
    ));
    let path = dir.join("placed.gltf");
    std::fs::write(&path, json).unwrap();
    path
}
