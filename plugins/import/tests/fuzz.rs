//! Structured fuzzing of the importer: mutations of the real files in `../shared/scenes` (JSON
//! fields removed, retyped or set to extremes, accessors and views re-pointed, binary bytes flipped
//! and truncated, OBJ lines broken) go through `load_scene_with`, which must never panic, never hang,
//! and never allocate past its memory budget (a counting global allocator measures the peak).
//!
//! `cargo test -p treelight_import --test fuzz` runs `DEFAULT_CASES` mutations from a fixed seed;
//! a longer run: `TREELIGHT_FUZZ_CASES=200000 TREELIGHT_FUZZ_SEED=7 cargo test --release -p
//! treelight_import --test fuzz -- --nocapture`. A failing case is kept as its seed and number in
//! `tests/fuzz-regressions.txt` (commit it; the case is made again from the shared scenes, which
//! are never copied here) and replayed by every later run.

mod support;

use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use treelight_import::{ImportOptions, load_scene_with};
use treelight_test_support::counting;

/// The last panic's message and place, kept by the test's hook.
static LAST_PANIC: std::sync::Mutex<String> = std::sync::Mutex::new(String::new());
/// Whether an import is running (its panics are the findings; the test's own are reported).
static IN_IMPORT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

#[global_allocator]
static ALLOCATOR: counting::Counting = counting::Counting;

/// Mutations per `cargo test` run.
const DEFAULT_CASES: usize = 3000;
/// The budget each mutated import gets, and the slack allowed over it for small bookkeeping.
const BUDGET: u64 = 64 << 20;
const SLACK: u64 = 8 << 20;
/// An import slower than this counts as a hang.
const HANG: Duration = Duration::from_secs(30);

fn shared(rel: &str) -> PathBuf {
    treelight_test_support::shared_scene(rel)
}

fn regressions() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions.txt")
}

/// Case `k` of the run seeded with `seed`.
fn case(corpus: &[Seed], seed: u64, k: usize) -> Seed {
    let mut rng = Rng(seed.wrapping_mul(1_000_003).wrapping_add(k as u64));
    mutate(&corpus[k % corpus.len()], &mut rng)
}

/// SplitMix64: small, seeded, good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// One seed: a file's name and bytes, and the files beside it that it references.
#[derive(Clone)]
struct Seed {
    name: String,
    bytes: Vec<u8>,
    beside: Vec<(String, Vec<u8>)>,
}

/// The seed corpus: the real files (a long OBJ cut to its first lines, FlightHelmet without its
/// 2048² textures so that a case stays small), the test files with punctual lights and cameras, the
/// textured box with a material using every map and extension, and a hand-written triangle.
fn seeds() -> Vec<Seed> {
    let file = |rel: &str| std::fs::read(shared(rel)).unwrap();
    let mut helmet: Value =
        serde_json::from_slice(&file("gltf/FlightHelmet/FlightHelmet.gltf")).unwrap();
    helmet.as_object_mut().unwrap().remove("images");
    helmet.as_object_mut().unwrap().remove("textures");
    for m in helmet["materials"].as_array_mut().unwrap() {
        *m = json!({"name": m["name"].clone(), "pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 0.2, 1]}});
    }
    let data = |name: &str| {
        std::fs::read(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data")
                .join(name),
        )
        .unwrap()
    };
    // The textured box with a material using every map, alpha mode and material extension.
    let mut materials: Value =
        serde_json::from_slice(&file("gltf/BoxTextured-glTF/BoxTextured.gltf")).unwrap();
    let fixture: Value = serde_json::from_slice(&data("material-everything.json")).unwrap();
    materials["extensionsUsed"] = fixture["extensionsUsed"].clone();
    materials["materials"][0] = fixture["material"].clone();
    let bunny: Vec<u8> = String::from_utf8(file("obj/stanford-bunny.obj"))
        .unwrap()
        .lines()
        .filter(|l| l.starts_with('v') || l.starts_with("f "))
        .take(400)
        .flat_map(|l| format!("{l}\n").into_bytes())
        .collect();
    let sibenik: Vec<u8> = String::from_utf8(file("obj/sibenik.obj"))
        .unwrap()
        .lines()
        .take(600)
        .flat_map(|l| format!("{l}\n").into_bytes())
        .collect();
    vec![
        Seed {
            name: "BoxTextured.gltf".into(),
            bytes: file("gltf/BoxTextured-glTF/BoxTextured.gltf"),
            beside: vec![
                (
                    "BoxTextured0.bin".into(),
                    file("gltf/BoxTextured-glTF/BoxTextured0.bin"),
                ),
                (
                    "CesiumLogoFlat.png".into(),
                    file("gltf/BoxTextured-glTF/CesiumLogoFlat.png"),
                ),
            ],
        },
        Seed {
            name: "Embedded.gltf".into(),
            bytes: file("gltf/BoxTextured-glTF-Embedded/BoxTextured.gltf"),
            beside: vec![],
        },
        Seed {
            name: "Box_Draco.glb".into(),
            bytes: file("gltf/Box_Draco.glb"),
            beside: vec![],
        },
        Seed {
            name: "pirate.glb".into(),
            bytes: file("gltf/pirate.glb"),
            beside: vec![],
        },
        Seed {
            name: "CesiumMan.glb".into(),
            bytes: file("gltf/CesiumMan.glb"),
            beside: vec![],
        },
        Seed {
            name: "FlightHelmet.gltf".into(),
            bytes: serde_json::to_vec(&helmet).unwrap(),
            beside: vec![(
                "FlightHelmet.bin".into(),
                file("gltf/FlightHelmet/FlightHelmet.bin"),
            )],
        },
        Seed {
            name: "IndexOutOfRange.gltf".into(),
            bytes: file("broken_gltf/IndexOutOfRange/IndexOutOfRange.gltf"),
            beside: vec![(
                "IndexOutOfRange.bin".into(),
                file("broken_gltf/IndexOutOfRange/IndexOutOfRange.bin"),
            )],
        },
        Seed {
            name: "lights.gltf".into(),
            bytes: data("lights.gltf"),
            beside: vec![],
        },
        Seed {
            name: "cameras.gltf".into(),
            bytes: data("cameras.gltf"),
            beside: vec![],
        },
        Seed {
            name: "Materials.gltf".into(),
            bytes: serde_json::to_vec(&materials).unwrap(),
            beside: vec![
                (
                    "BoxTextured0.bin".into(),
                    file("gltf/BoxTextured-glTF/BoxTextured0.bin"),
                ),
                (
                    "CesiumLogoFlat.png".into(),
                    file("gltf/BoxTextured-glTF/CesiumLogoFlat.png"),
                ),
            ],
        },
        Seed {
            name: "bunny.obj".into(),
            bytes: bunny,
            beside: vec![],
        },
        Seed {
            name: "sibenik.obj".into(),
            bytes: sibenik,
            beside: vec![],
        },
        Seed {
            name: "bunny-ascii.ply".into(),
            bytes: bunny_ply(false),
            beside: vec![],
        },
        Seed {
            name: "bunny-binary.ply".into(),
            bytes: bunny_ply(true),
            beside: vec![],
        },
    ]
}

/// Part of the bunny as a PLY file with normals and a colour per vertex and an edge element,
/// ASCII or binary (little endian).
fn bunny_ply(binary: bool) -> Vec<u8> {
    let text = std::fs::read_to_string(shared("obj/stanford-bunny.obj")).unwrap();
    let vertices: Vec<[f32; 3]> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .take(300)
        .map(|l| {
            let mut n = l.split_whitespace().map(|w| w.parse::<f32>().unwrap());
            [n.next().unwrap(), n.next().unwrap(), n.next().unwrap()]
        })
        .collect();
    let faces: Vec<[u32; 3]> = (0..200u32)
        .map(|k| [k % 300, (k * 7 + 1) % 300, (k * 13 + 2) % 300])
        .collect();
    let format = if binary {
        "binary_little_endian"
    } else {
        "ascii"
    };
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment fuzz seed\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nproperty float nx\nproperty float ny\n\
         property float nz\nproperty uchar red\nelement face {}\n\
         property list uchar int vertex_indices\nelement edge 2\nproperty int vertex1\n\
         property int vertex2\nend_header\n",
        vertices.len(),
        faces.len()
    )
    .into_bytes();
    for v in &vertices {
        if binary {
            for c in v.iter().chain(&[0.0, 1.0, 0.0]) {
                out.extend(c.to_le_bytes());
            }
            out.push(200);
        } else {
            out.extend(format!("{} {} {} 0 1 0 200\n", v[0], v[1], v[2]).bytes());
        }
    }
    for f in &faces {
        if binary {
            out.push(3);
            for i in f {
                out.extend((*i as i32).to_le_bytes());
            }
        } else {
            out.extend(format!("3 {} {} {}\n", f[0], f[1], f[2]).bytes());
        }
    }
    for e in [[0i32, 1], [1, 2]] {
        if binary {
            out.extend(e[0].to_le_bytes());
            out.extend(e[1].to_le_bytes());
        } else {
            out.extend(format!("{} {}\n", e[0], e[1]).bytes());
        }
    }
    out
}

/// PLY damage: the header's counts set to extremes, its types changed, elements without
/// properties added, or the bytes damaged.
fn mutate_ply(bytes: &mut Vec<u8>, rng: &mut Rng) {
    let Some(end) = bytes.windows(11).position(|w| w == b"end_header\n") else {
        damage(bytes, rng);
        return;
    };
    let header = String::from_utf8_lossy(&bytes[..end]).into_owned();
    let mut lines: Vec<String> = header.lines().map(str::to_owned).collect();
    let k = rng.below(lines.len());
    match rng.below(5) {
        0 => {
            let counts = [
                "0",
                "1",
                "4294967295",
                "268435456",
                "50000000",
                "-1",
                "99999999999",
            ];
            let n = counts[rng.below(counts.len())];
            if lines[k].starts_with("element ") {
                let name = lines[k].split_whitespace().nth(1).unwrap_or("x").to_owned();
                lines[k] = format!("element {name} {n}");
            }
        }
        1 => {
            let types = [
                "char",
                "uchar",
                "short",
                "uint",
                "double",
                "list uint uint",
                "list uchar float",
            ];
            if lines[k].starts_with("property ") {
                let name = lines[k].rsplit(' ').next().unwrap_or("x").to_owned();
                lines[k] = format!("property {} {name}", types[rng.below(types.len())]);
            }
        }
        2 => lines.insert(
            k.max(2),
            format!("element empty{} {}", k, 1 + rng.below(40_000_000)),
        ),
        3 => lines.insert(k.max(2), "property float x".into()),
        _ => {
            let mut rest = bytes[end + 11..].to_vec();
            damage(&mut rest, rng);
            bytes.truncate(end + 11);
            bytes.extend(rest);
            return;
        }
    }
    let mut out = lines.join("\n").into_bytes();
    out.push(b'\n');
    out.extend_from_slice(&bytes[end..]);
    *bytes = out;
}

/// A GLB's JSON and BIN chunks (`None` when the bytes are not a well-formed GLB).
fn split_glb(bytes: &[u8]) -> Option<(Value, Vec<u8>)> {
    let len = u32::from_le_bytes(bytes.get(12..16)?.try_into().ok()?) as usize;
    let json = serde_json::from_slice(bytes.get(20..20 + len)?).ok()?;
    let bin = bytes.get(20 + len + 8..).unwrap_or(&[]).to_vec();
    Some((json, bin))
}

fn join_glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

/// Every value in `v`, as JSON pointers.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    out.push(at.clone());
    match v {
        Value::Object(map) => {
            for (k, x) in map {
                pointers(
                    x,
                    format!("{at}/{}", k.replace('~', "~0").replace('/', "~1")),
                    out,
                );
            }
        }
        Value::Array(items) => {
            for (i, x) in items.iter().enumerate() {
                pointers(x, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
}

const EXTREMES: &[f64] = &[
    0.0,
    -1.0,
    1.0,
    3.0,
    255.0,
    65535.0,
    2147483647.0,
    4294967295.0,
    4294967296.0,
    9007199254740991.0,
    1e300,
    -1e300,
    0.5,
];

/// Sets `v[key]` where `v` is an object (a mutation may have made it something else).
fn set(v: &mut Value, key: &str, value: Value) {
    if let Some(map) = v.as_object_mut() {
        map.insert(key.to_owned(), value);
    }
}

/// One structural mutation of a glTF document.
fn mutate_json(root: &mut Value, rng: &mut Rng) {
    if !root.is_object() {
        return;
    }
    let mut all = Vec::new();
    pointers(root, String::new(), &mut all);
    // Not the root itself: the mutations below index into it.
    all.remove(0);
    match rng.below(7) {
        // A field removed.
        0 => {
            let at = &all[rng.below(all.len())];
            if let Some((parent, key)) = at.rsplit_once('/')
                && let Some(p) = root.pointer_mut(parent)
            {
                match p {
                    Value::Object(m) => {
                        m.remove(&key.replace("~1", "/").replace("~0", "~"));
                    }
                    Value::Array(a) => {
                        if let Ok(i) = key.parse::<usize>()
                            && i < a.len()
                        {
                            a.remove(i);
                        }
                    }
                    _ => {}
                }
            }
        }
        // A value retyped.
        1 => {
            let at = &all[rng.below(all.len())];
            if let Some(v) = root.pointer_mut(at) {
                *v = match rng.below(6) {
                    0 => json!("text"),
                    1 => json!(null),
                    2 => json!([]),
                    3 => json!({}),
                    4 => json!(true),
                    _ => json!(-7),
                };
            }
        }
        // A number set to an extreme.
        2 | 3 => {
            let numbers: Vec<&String> = all
                .iter()
                .filter(|p| root.pointer(p).is_some_and(Value::is_number))
                .collect();
            if !numbers.is_empty() {
                let at = numbers[rng.below(numbers.len())].clone();
                let x = EXTREMES[rng.below(EXTREMES.len())];
                *root.pointer_mut(&at).unwrap() = if x.fract() == 0.0 && x.abs() < 1.8e19 {
                    if x < 0.0 {
                        json!(x as i64)
                    } else {
                        json!(x as u64)
                    }
                } else {
                    json!(x)
                };
            }
        }
        // An accessor re-pointed at another view, offset or type.
        4 => {
            let views = root["bufferViews"].as_array().map_or(1, Vec::len);
            if let Some(accs) = root["accessors"].as_array_mut()
                && !accs.is_empty()
            {
                let k = rng.below(accs.len());
                let a = &mut accs[k];
                match rng.below(4) {
                    0 => set(a, "bufferView", json!(rng.below(views + 1))),
                    1 => set(a, "byteOffset", json!(rng.below(4096))),
                    2 => set(
                        a,
                        "componentType",
                        json!([5120, 5121, 5122, 5123, 5125, 5126][rng.below(6)]),
                    ),
                    _ => set(
                        a,
                        "type",
                        json!(
                            ["SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4"]
                                [rng.below(7)]
                        ),
                    ),
                }
            }
        }
        // A primitive's attribute or indices re-pointed, or a node's children rewired.
        5 => {
            let accessors = root["accessors"].as_array().map_or(1, Vec::len);
            let nodes = root["nodes"].as_array().map_or(1, Vec::len);
            if rng.below(2) == 0 {
                if let Some(meshes) = root["meshes"].as_array_mut()
                    && !meshes.is_empty()
                {
                    let m = rng.below(meshes.len());
                    if let Some(prims) = meshes[m]
                        .get_mut("primitives")
                        .and_then(Value::as_array_mut)
                        && !prims.is_empty()
                    {
                        let p = rng.below(prims.len());
                        let field = ["POSITION", "NORMAL", "TEXCOORD_0", "indices"][rng.below(4)];
                        let value = json!(rng.below(accessors + 1));
                        if field == "indices" {
                            set(&mut prims[p], "indices", value);
                        } else if let Some(attributes) = prims[p].get_mut("attributes") {
                            set(attributes, field, value);
                        }
                    }
                }
            } else if let Some(list) = root["nodes"].as_array_mut()
                && !list.is_empty()
            {
                let n = rng.below(list.len());
                set(
                    &mut list[n],
                    "children",
                    json!([rng.below(nodes), rng.below(nodes)]),
                );
            }
        }
        // A buffer or view's length or offset changed.
        _ => {
            let field = ["byteLength", "byteOffset", "byteStride"][rng.below(3)];
            let which = ["buffers", "bufferViews"][rng.below(2)];
            if let Some(list) = root[which].as_array_mut()
                && !list.is_empty()
            {
                let k = rng.below(list.len());
                let value = json!(match rng.below(4) {
                    0 => 0,
                    1 => 4,
                    2 => rng.below(1 << 20) as u64,
                    _ => u32::MAX as u64,
                });
                set(&mut list[k], field, value);
            }
        }
    }
}

/// Binary damage: bytes flipped, or the data cut short.
fn damage(bytes: &mut Vec<u8>, rng: &mut Rng) {
    if bytes.is_empty() {
        return;
    }
    match rng.below(3) {
        0 => {
            for _ in 0..1 + rng.below(16) {
                let i = rng.below(bytes.len());
                bytes[i] ^= 1 << rng.below(8);
            }
        }
        1 => {
            let at = rng.below(bytes.len());
            let len = (1 + rng.below(64)).min(bytes.len() - at);
            for b in &mut bytes[at..at + len] {
                *b = rng.next() as u8;
            }
        }
        _ => {
            let keep = rng.below(bytes.len());
            bytes.truncate(keep);
        }
    }
}

/// OBJ damage: lines with huge or negative indices, NaNs, garbage, or truncation.
fn mutate_obj(bytes: &mut Vec<u8>, rng: &mut Rng) {
    let text = String::from_utf8_lossy(bytes).into_owned();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let at = rng.below(lines.len() + 1);
    let line = match rng.below(6) {
        0 => "f 4294967295 1 2".to_owned(),
        1 => "f -100000 1 2".to_owned(),
        2 => "v nan inf -inf".to_owned(),
        3 => "f 1".to_owned(),
        4 => "f 1/99999/99999 2/1/1 3".to_owned(),
        _ => {
            damage(bytes, rng);
            return;
        }
    };
    lines.insert(at, line);
    *bytes = lines.join("\n").into_bytes();
}

/// The files of one case: the scene file's name and bytes, and the files beside it.
fn mutate(seed: &Seed, rng: &mut Rng) -> Seed {
    let mut case = seed.clone();
    let rounds = 1 + rng.below(3);
    for _ in 0..rounds {
        if case.name.ends_with(".obj") {
            mutate_obj(&mut case.bytes, rng);
        } else if case.name.ends_with(".ply") {
            mutate_ply(&mut case.bytes, rng);
        } else if case.name.ends_with(".glb") {
            match (split_glb(&case.bytes), rng.below(4)) {
                (Some((mut json, bin)), 0 | 1) => {
                    mutate_json(&mut json, rng);
                    case.bytes = join_glb(&json, &bin);
                }
                (Some((json, mut bin)), 2) => {
                    damage(&mut bin, rng);
                    case.bytes = join_glb(&json, &bin);
                }
                _ => damage(&mut case.bytes, rng),
            }
        } else if !case.beside.is_empty() && rng.below(4) == 0 {
            let k = rng.below(case.beside.len());
            damage(&mut case.beside[k].1, rng);
        } else if let Ok(mut json) = serde_json::from_slice::<Value>(&case.bytes) {
            if rng.below(8) == 0 {
                damage(&mut case.bytes, rng);
            } else {
                mutate_json(&mut json, rng);
                case.bytes = serde_json::to_vec(&json).unwrap();
            }
        } else {
            damage(&mut case.bytes, rng);
        }
    }
    case
}

fn write_case(dir: &Path, case: &Seed) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    for (name, bytes) in &case.beside {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let path = dir.join(&case.name);
    std::fs::write(&path, &case.bytes).unwrap();
    path
}

/// What went wrong with one case, if anything.
fn run(path: &Path) -> Option<String> {
    let options = ImportOptions {
        memory_budget: BUDGET,
    };
    let start = Instant::now();
    IN_IMPORT.store(true, Ordering::Relaxed);
    let (result, peak) =
        counting::peak_during(|| std::panic::catch_unwind(|| load_scene_with(path, &options)));
    IN_IMPORT.store(false, Ordering::Relaxed);
    let took = start.elapsed();
    match result {
        Err(_) => Some(format!("panicked: {}", LAST_PANIC.lock().unwrap())),
        Ok(_) if peak > BUDGET + SLACK => Some(format!(
            "allocated {peak} bytes at its peak, over the budget of {BUDGET}"
        )),
        Ok(_) if took > HANG => Some(format!("took {took:?}")),
        Ok(Err(e)) if e.file != path => Some(format!("its error names another file: {e}")),
        Ok(_) => None,
    }
}

/// A GLB of one triangle whose binary chunk also carries `extra` bytes no accessor reads.
fn big_glb(extra: usize) -> Vec<u8> {
    let mut bin = support::triangle_bin();
    bin.resize(44 + extra, 7);
    let json = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 8},
            {"buffer": 0, "byteOffset": 44, "byteLength": extra}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    join_glb(&json, &bin)
}

/// The peak bytes allocated while importing `path` (the memory budget generous).
fn peak_of(path: &Path) -> u64 {
    let options = ImportOptions {
        memory_budget: 1 << 30,
    };
    let (result, peak) = counting::peak_during(|| load_scene_with(path, &options));
    assert!(result.is_ok());
    peak
}

#[test]
fn mutations_of_the_real_files_never_panic_hang_or_pass_the_budget() {
    // First, while nothing else allocates in this binary: a GLB's bytes are held once (its binary
    // chunk is taken from the file's bytes, not copied), so importing a 64 MiB GLB peaks near
    // 64 MiB, not at twice or three times that.
    let glb_dir = std::env::temp_dir().join(format!("treelight-glb-once-{}", std::process::id()));
    std::fs::create_dir_all(&glb_dir).unwrap();
    let glb = glb_dir.join("big.glb");
    std::fs::write(&glb, big_glb(64 << 20)).unwrap();
    let peak = peak_of(&glb);
    assert!(
        peak < (64 << 20) + (16 << 20),
        "importing a 64 MiB GLB allocated {peak} bytes at its peak"
    );
    std::fs::remove_dir_all(&glb_dir).ok();
    let corpus = seeds();
    // Panics are caught and reported below; the default hook would print each one.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if IN_IMPORT.load(Ordering::Relaxed) {
            *LAST_PANIC.lock().unwrap() = info.to_string();
        } else {
            default_hook(info);
        }
    }));
    let mut failures = Vec::new();
    let work = std::env::temp_dir().join(format!("treelight-fuzz-{}", std::process::id()));
    // Every kept regression first: lines of `seed case`.
    let kept = std::fs::read_to_string(regressions()).unwrap_or_default();
    for line in kept
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
    {
        let mut words = line.split_whitespace().map(|w| w.parse::<u64>().unwrap());
        let (seed, k) = (words.next().unwrap(), words.next().unwrap() as usize);
        let c = case(&corpus, seed, k);
        let path = write_case(&work.join(format!("kept-{seed}-{k}")), &c);
        if let Some(why) = run(&path) {
            failures.push(format!("kept case {seed} {k} ({}): {why}", c.name));
        }
    }
    let cases: usize = std::env::var("TREELIGHT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES);
    let seed: u64 = std::env::var("TREELIGHT_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let mut refused = 0usize;
    let mut new = String::new();
    for k in 0..cases {
        let c = case(&corpus, seed, k);
        let dir = work.join(format!("{k}"));
        let path = write_case(&dir, &c);
        match run(&path) {
            Some(why) => {
                new.push_str(&format!("{seed} {k}\n"));
                failures.push(format!("case {seed} {k} ({}): {why}", c.name));
            }
            None => {
                refused += usize::from(
                    load_scene_with(
                        &path,
                        &ImportOptions {
                            memory_budget: BUDGET,
                        },
                    )
                    .is_err(),
                );
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }
    if !new.is_empty() {
        use std::io::Write;
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(regressions())
            .unwrap();
        file.write_all(new.as_bytes()).unwrap();
    }
    std::fs::remove_dir_all(&work).ok();
    let _ = std::panic::take_hook();
    eprintln!(
        "{cases} mutations, {refused} refused with an error, {} failures",
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // The mutations reach the readers: some files still import, many are refused.
    assert!(
        refused > cases / 10 && refused < cases,
        "{refused} of {cases} refused"
    );
}
