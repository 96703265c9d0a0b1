//! The built-in sample meshes in `assets/samples` are what `src/editor/assets/samples.rs` makes (run with
//! `TREELIGHT_REGENERATE=1` to write them again), and they open as closed, outward-facing meshes.

use std::path::Path;

#[test]
fn sample_files_are_what_the_code_makes_and_face_outwards() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/samples");
    let regenerate = std::env::var_os("TREELIGHT_REGENERATE").is_some();
    if regenerate {
        std::fs::create_dir_all(&dir).unwrap();
    }
    for (name, text) in treelight::editor::assets::samples::samples() {
        let path = dir.join(name);
        if regenerate {
            std::fs::write(&path, &text).unwrap();
        }
        let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            on_disk == text,
            "{} differs from src/editor/assets/samples.rs: run the tests with TREELIGHT_REGENERATE=1",
            path.display()
        );
        let scene = treelight_import::load_scene(&path).unwrap();
        let tris = scene.world_triangles();
        assert!(tris.len() > 50, "{name}: {} triangles", tris.len());
        // Outward faces enclose a positive volume (the divergence theorem over the surface).
        let volume: f32 = tris.iter().map(|[a, b, c]| a.dot(b.cross(*c)) / 6.0).sum();
        assert!(volume > 0.01, "{name}: signed volume {volume}");
        // Standing on the ground, centred near the origin.
        let low = tris.iter().flatten().map(|p| p.y).fold(f32::MAX, f32::min);
        assert!(low.abs() < 1e-3, "{name}: lowest point {low}");
    }
}
