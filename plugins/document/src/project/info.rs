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

/// The triangles of the objects an open of the project holds, its sources read as an open reads
/// them (a missing or unreadable source's objects count none): every node of each read source
/// (its unchanged nodes are runs of ids, not listed) and every listed object, less what the
/// deleted nodes take with them in the hierarchy the open makes.
fn project_triangles(p: &ProjectFile, path: &Path) -> Result<u64, String> {
    let sources =
        crate::project::restore::parse_sources(p, path, None).map_err(|e| e.to_string())?;
    let parsed = sources.scenes();
    let plan =
        crate::project::plan::plan(p, parsed).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut objects = ObjectForest::default();
    // Each read source's objects, in key order, and their keys' indices.
    let mut keys: Vec<Option<(usize, HashMap<&str, usize>)>> = Vec::with_capacity(parsed.len());
    for (scene, source) in parsed.iter().zip(&plan.sources) {
        let (Some(scene), Some(source)) = (scene, source) else {
            keys.push(None);
            continue;
        };
        let base = objects.triangles.len();
        let index: HashMap<&str, usize> = source
            .tree
            .keys
            .iter()
            .enumerate()
            .map(|(i, k)| (k.as_ref(), i))
            .collect();
        let mut triangles = vec![0u64; source.tree.keys.len()];
        for (key, mesh) in crate::scene::spawn::mesh_object_keys(scene)
            .iter()
            .zip(&scene.meshes)
        {
            if let Some(&i) = index.get(key.as_str()) {
                triangles[i] += mesh.triangle_count() as u64;
            }
        }
        for (i, parent) in source.tree.parents.iter().enumerate() {
            objects.add(triangles[i], parent.map(|q| base + q as usize));
            if source.ids[i] != crate::values::object::SceneId::NEW {
                objects.by_id.insert(source.ids[i], base + i);
            }
        }
        keys.push(Some((base, index)));
    }
    let slot = |source: usize, key: &str| -> Option<usize> {
        let (base, index) = keys.get(source)?.as_ref()?;
        index.get(key).map(|i| base + i)
    };
    let mut shapes: HashMap<crate::values::primitive::Primitive, u64> = HashMap::new();
    let mut listed = Vec::with_capacity(p.objects.len());
    for o in &p.objects {
        let at = match &o.kind {
            ObjectKind::Node(n) => slot(n.source, &n.key),
            ObjectKind::MeshOf(n) => slot(n.source, &n.key).map(|origin| {
                let t = objects.triangles[origin];
                objects.add(t, None)
            }),
            ObjectKind::Shape(s) => {
                let t = *shapes.entry(*s).or_insert_with(|| {
                    let mesh = s.mesh();
                    (mesh.indices().map_or(mesh.count_vertices(), |i| i.len()) / 3) as u64
                });
                Some(objects.add(t, None))
            }
            ObjectKind::Light(_) | ObjectKind::Empty => Some(objects.add(0, None)),
        };
        if let Some(at) = at {
            objects.by_id.insert(o.id, at);
            listed.push((at, o.parent));
        }
    }
    // Listed parents, as the open links them, then the deleted nodes with all beneath them.
    for (at, parent) in listed {
        objects.parents[at] = parent
            .and_then(|id| objects.by_id.get(&id).copied())
            .filter(|&q| q != at);
    }
    for d in &p.deleted {
        if let Some(at) = slot(d.source, &d.key) {
            objects.deleted[at] = true;
        }
    }
    Ok(objects.triangles_left())
}

/// Objects as an open makes them: triangles, parents and deletions by slot.
#[derive(Default)]
struct ObjectForest {
    triangles: Vec<u64>,
    parents: Vec<Option<usize>>,
    deleted: Vec<bool>,
    by_id: HashMap<crate::values::object::SceneId, usize>,
}

impl ObjectForest {
    fn add(&mut self, triangles: u64, parent: Option<usize>) -> usize {
        self.triangles.push(triangles);
        self.parents.push(parent);
        self.deleted.push(false);
        self.triangles.len() - 1
    }

    /// The triangles of the objects neither deleted nor beneath a deleted one (a walk up each
    /// chain once, without recursion: hierarchies may be deep).
    fn triangles_left(&self) -> u64 {
        // 0 unknown, 1 kept, 2 gone, 3 on the walk now (a ring: the plan refuses those).
        let mut state = vec![0u8; self.triangles.len()];
        let mut walk = Vec::new();
        for start in 0..state.len() {
            let mut at = Some(start);
            while let Some(a) = at {
                if state[a] != 0 {
                    break;
                }
                if self.deleted[a] {
                    state[a] = 2;
                    break;
                }
                state[a] = 3;
                walk.push(a);
                at = self.parents[a];
            }
            let end = at.map_or(1, |a| if state[a] == 3 { 2 } else { state[a] });
            for a in walk.drain(..) {
                state[a] = end;
            }
        }
        (0..state.len())
            .filter(|&a| state[a] == 1)
            .map(|a| self.triangles[a])
            .sum()
    }
}
