//! Reads a scene file as Treelight does and says what it holds: meshes and their triangles,
//! materials and the maps they use, textures, lights, cameras and every warning. A file that
//! cannot be read gives its error, naming the file and the problem.
//!
//! `cargo run -p treelight_import --example describe -- SCENE [--max-bytes N]` (`--max-bytes`: the
//! most memory the import may take; a file that needs more is refused, saying so).

use std::path::Path;
use treelight_import::{ImportOptions, load_scene_with};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: describe SCENE [--max-bytes N]");
        std::process::exit(2);
    };
    let mut options = ImportOptions::default();
    if let Some(n) = args
        .iter()
        .position(|a| a == "--max-bytes")
        .and_then(|i| args.get(i + 1))
    {
        match n.parse() {
            Ok(bytes) => options.memory_budget = bytes,
            Err(_) => {
                eprintln!("--max-bytes takes a number of bytes, not '{n}'");
                std::process::exit(2);
            }
        }
    }
    let scene = match load_scene_with(Path::new(path), &options) {
        Ok(scene) => scene,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    println!(
        "{path}: {} meshes, {} triangles, {} nodes, {} materials, {} textures",
        scene.meshes.len(),
        scene.triangle_count(),
        scene.nodes.len(),
        scene.materials.len(),
        scene.textures.len()
    );
    for m in &scene.meshes {
        let material = m
            .material
            .and_then(|i| scene.materials.get(i))
            .map_or("none", |m| m.name.as_str());
        let shared = m
            .same_as
            .map_or(String::new(), |i| format!(", shares mesh {i}'s geometry"));
        println!(
            "  mesh '{}': {} triangles, material '{material}'{shared}",
            m.name,
            m.geometry.indices.len() / 3
        );
    }
    for m in &scene.materials {
        let maps = m.maps().into_iter().flatten().count();
        println!(
            "  material '{}': base colour {:?}, metallic {}, roughness {}, {maps} maps",
            m.name, m.base_color, m.metallic, m.roughness
        );
    }
    for n in scene
        .nodes
        .iter()
        .filter(|n| n.light.is_some() || n.camera.is_some())
    {
        let what = if n.light.is_some() { "light" } else { "camera" };
        println!("  node '{}': a {what}", n.name);
    }
    for w in &scene.warnings {
        println!("  warning: {w}");
    }
}
