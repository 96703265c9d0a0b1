//! `treelight info FILE`: what a scene file or a project holds, as text, without a window.

use crate::project::format::{ObjectKind, ProjectFile, read_project, resolve_source};
use std::collections::HashMap;
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
        let _ = writeln!(out, "triangles: {}", project_triangles(&p, path)?);
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
    match crate::import::parse::scene_bounds(&scene) {
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

/// The triangles the project's objects show, its sources read as an open reads them (a missing or
/// unreadable source's objects count none).
fn project_triangles(p: &ProjectFile, path: &Path) -> Result<usize, String> {
    let sources =
        crate::project::restore::parse_sources(p, path, None).map_err(|e| e.to_string())?;
    // Per source, the triangles of the mesh each object key shows.
    let by_key: Vec<HashMap<String, usize>> = sources
        .scenes()
        .iter()
        .map(|scene| match scene {
            Some(scene) => crate::import::spawn::mesh_object_keys(scene)
                .into_iter()
                .zip(&scene.meshes)
                .map(|(k, m)| (k, m.triangle_count()))
                .collect(),
            None => HashMap::new(),
        })
        .collect();
    let mut shapes: HashMap<crate::primitive::Primitive, usize> = HashMap::new();
    let mut total = 0;
    for o in &p.objects {
        total += match &o.kind {
            ObjectKind::Node(n) | ObjectKind::MeshOf(n) => by_key
                .get(n.source)
                .and_then(|m| m.get(&n.key))
                .copied()
                .unwrap_or(0),
            ObjectKind::Shape(s) => *shapes.entry(*s).or_insert_with(|| {
                let mesh = s.mesh();
                mesh.indices().map_or(mesh.count_vertices(), |i| i.len()) / 3
            }),
            ObjectKind::Light(_) | ObjectKind::Empty => 0,
        };
    }
    Ok(total)
}
