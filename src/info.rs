//! `treelight info FILE`: what a scene file or a project holds, as text, without a window.

use crate::project::{ObjectKind, read_project, resolve_source};
use std::fmt::Write;
use std::path::Path;

/// A description of the scene file (.gltf, .glb, .obj, .ply) or project (.treelight) at `path`:
/// meshes, triangles, materials, textures, bounds and warnings, or for a project its sources (and
/// whether each is there), objects by kind, deleted nodes and camera. The error names the file.
pub fn describe(path: &Path) -> Result<String, String> {
    let is_project = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("treelight"));
    let mut out = String::new();
    if is_project {
        let p = read_project(path).map_err(|e| e.to_string())?;
        let _ = writeln!(
            out,
            "{}: Treelight project, version {}",
            path.display(),
            p.version
        );
        let _ = writeln!(out, "sources: {}", p.sources.len());
        for (i, s) in p.sources.iter().enumerate() {
            let file = resolve_source(path, s);
            let state = if file.is_file() { "present" } else { "missing" };
            let _ = writeln!(out, "  {i}: {} ({state})", s.display());
        }
        let count =
            |f: &dyn Fn(&ObjectKind) -> bool| p.objects.iter().filter(|o| f(&o.kind)).count();
        let _ = writeln!(
            out,
            "objects: {} ({} source nodes, {} copies of source meshes, {} shapes, {} lights, {} groups)",
            p.objects.len(),
            count(&|k| matches!(k, ObjectKind::Node(_))),
            count(&|k| matches!(k, ObjectKind::MeshOf(_))),
            count(&|k| matches!(k, ObjectKind::Shape(_))),
            count(&|k| matches!(k, ObjectKind::Light(_))),
            count(&|k| matches!(k, ObjectKind::Empty)),
        );
        let _ = writeln!(out, "deleted source nodes: {}", p.deleted.len());
        if let Some(c) = p.camera {
            let _ = writeln!(
                out,
                "camera: focus ({:.3}, {:.3}, {:.3}), distance {:.3}",
                c.focus[0], c.focus[1], c.focus[2], c.radius
            );
        }
        return Ok(out);
    }
    let scene = treelight_import::load_scene(path).map_err(|e| e.to_string())?;
    let _ = writeln!(out, "{}", path.display());
    let _ = writeln!(out, "meshes: {}", scene.meshes.len());
    let _ = writeln!(out, "triangles: {}", scene.triangle_count());
    let _ = writeln!(out, "nodes: {}", scene.nodes.len());
    let _ = writeln!(out, "materials: {}", scene.materials.len());
    let _ = writeln!(out, "textures: {}", scene.textures.len());
    match crate::import::scene_bounds(&scene) {
        Some((min, max)) => {
            let _ = writeln!(
                out,
                "bounds: ({:.4}, {:.4}, {:.4}) to ({:.4}, {:.4}, {:.4})",
                min.x, min.y, min.z, max.x, max.y, max.z
            );
        }
        None => {
            let _ = writeln!(out, "bounds: none (no triangles)");
        }
    }
    let _ = writeln!(out, "warnings: {}", scene.warnings.len());
    for w in &scene.warnings {
        let _ = writeln!(out, "  {w}");
    }
    Ok(out)
}
