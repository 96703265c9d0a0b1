//! Capturing the scene as a project and saving it: what the user made of each source's nodes, the
//! objects added in the editor and the view; never a copy of the geometry.

use crate::edit::command::{LightKind, MaterialValue};
use crate::edit::history::EditHistory;
use crate::import::spawn::{MeshSource, SourceCatalog, SourceKey};
use crate::object::{SceneId, SceneObject};
use crate::outbox::DocumentView;
use crate::primitive::PrimitiveShape;
use crate::project::format::*;
use bevy::prelude::*;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

type SaveItem = (
    Entity,
    &'static SceneId,
    Option<&'static Name>,
    &'static Transform,
    Option<&'static Visibility>,
    Option<&'static ChildOf>,
    Option<&'static SourceKey>,
    Option<&'static MeshSource>,
    Option<&'static PrimitiveShape>,
    Option<&'static PointLight>,
    Option<&'static DirectionalLight>,
    Option<&'static MeshMaterial3d<StandardMaterial>>,
    Has<Mesh3d>,
);

/// The scene as a project to be saved at `path`; also the names of objects that cannot be saved
/// (meshes made by code, with no source file and no shape).
pub fn capture_project(world: &mut World, path: &Path) -> (ProjectFile, Vec<String>) {
    let mut q = world.query_filtered::<SaveItem, With<SceneObject>>();
    let mut rows: Vec<_> = q.iter(world).collect();
    rows.sort_by_key(|r| *r.1);
    let ids: HashMap<Entity, SceneId> = rows.iter().map(|r| (r.0, *r.1)).collect();
    let materials = world.resource::<Assets<StandardMaterial>>();
    let state = world.resource::<ProjectState>();
    let catalog = world.resource::<SourceCatalog>();
    let mut sources: Vec<PathBuf> = Vec::new();
    let source_of = |file: &Path, sources: &mut Vec<PathBuf>| -> usize {
        match sources.iter().position(|s| s == file) {
            Some(i) => i,
            None => {
                sources.push(file.to_owned());
                sources.len() - 1
            }
        }
    };
    let mut objects = Vec::new();
    let mut unsaved = Vec::new();
    let mut present: HashMap<PathBuf, HashSet<String>> = HashMap::new();
    for (_, id, name, t, vis, parent, key, mesh_source, shape, point, dir, mat, has_mesh) in &rows {
        let name = name.map_or(String::new(), |n| n.as_str().to_owned());
        let kind = if let Some(k) = key {
            present
                .entry(k.file.clone())
                .or_default()
                .insert(k.key.clone());
            ObjectKind::Node(SourceNode {
                source: source_of(&k.file, &mut sources),
                key: k.key.clone(),
            })
        } else if let Some(MeshSource(k)) = mesh_source {
            ObjectKind::MeshOf(SourceNode {
                source: source_of(&k.file, &mut sources),
                key: k.key.clone(),
            })
        } else if let Some(PrimitiveShape(s)) = shape {
            ObjectKind::Shape(*s)
        } else if let Some(l) = point {
            ObjectKind::Light(LightValue {
                kind: LightKind::Point,
                color: l.color.to_srgba().to_f32_array_no_alpha(),
                intensity: l.intensity,
                shadows: l.shadow_maps_enabled,
                range: Some(l.range),
            })
        } else if let Some(l) = dir {
            ObjectKind::Light(LightValue {
                kind: LightKind::Directional,
                color: l.color.to_srgba().to_f32_array_no_alpha(),
                intensity: l.illuminance,
                shadows: l.shadow_maps_enabled,
                range: None,
            })
        } else if *has_mesh {
            unsaved.push(name);
            continue;
        } else {
            ObjectKind::Empty
        };
        objects.push(ProjectObject {
            id: **id,
            name,
            parent: parent.and_then(|p| ids.get(&p.parent()).copied()),
            transform: (**t).into(),
            visible: *vis != Some(&Visibility::Hidden),
            kind,
            material: mat.and_then(|m| materials.get(&m.0)).map(MaterialValue::of),
        });
    }
    // Deleted nodes: those each file had when imported that are gone now.
    let mut deleted = Vec::new();
    let mut files: Vec<&PathBuf> = catalog.0.keys().collect();
    files.sort();
    for file in files {
        let keys = &catalog.0[file];
        let here = present.get(file);
        let gone: Vec<&String> = keys
            .iter()
            .filter(|k| here.is_none_or(|h| !h.contains(*k)))
            .collect();
        if gone.is_empty() {
            continue;
        }
        let source = source_of(file, &mut sources);
        deleted.extend(gone.into_iter().map(|k| SourceNode {
            source,
            key: k.clone(),
        }));
    }
    // What a missing source held stays as it was.
    for o in &state.missing {
        let mut o = o.clone();
        if let ObjectKind::Node(n) | ObjectKind::MeshOf(n) = &mut o.kind {
            let file = state
                .missing_sources
                .get(n.source)
                .cloned()
                .unwrap_or_default();
            n.source = source_of(&file, &mut sources);
        }
        objects.push(o);
    }
    for (file, key) in &state.missing_deleted {
        deleted.push(SourceNode {
            source: source_of(file, &mut sources),
            key: key.clone(),
        });
    }
    let camera = world.get_resource::<DocumentView>().and_then(|v| v.0);
    let project = ProjectFile {
        version: PROJECT_VERSION,
        sources: sources.iter().map(|s| store_source(path, s)).collect(),
        objects,
        deleted,
        camera,
    };
    (project, unsaved)
}

/// Saves the scene to `path` (atomically) and makes it the open project; returns the names of
/// objects that could not be saved.
pub fn save_project(world: &mut World, path: &Path) -> Result<Vec<String>, ProjectError> {
    let (project, unsaved) = capture_project(world, path);
    write_project(path, &project)?;
    world.resource_mut::<ProjectState>().path = Some(path.to_owned());
    world.resource_mut::<EditHistory>().mark_saved();
    Ok(unsaved)
}
