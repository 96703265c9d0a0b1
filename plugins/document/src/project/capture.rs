//! Capturing the scene as a project and saving it: what the user changed of each source's nodes
//! (those an edit touched, [`EditedObjects`], and each source's root, which an import places),
//! the ids of the others as runs, the objects added in the editor and the view; never a copy of
//! the geometry.

use crate::edit::command::MaterialValue;
use crate::edit::history::EditHistory;
use crate::project::format::*;
use crate::scene::outbox::DocumentView;
use crate::scene::spawn::{MeshSource, SourceCatalog, SourceKey};
use crate::values::light::LightValue;
use crate::values::object::{EditedObjects, SceneId, SceneObject};
use crate::values::primitive::PrimitiveShape;
use bevy::prelude::*;
use std::collections::HashMap;
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
    Option<&'static MeshMaterial3d<StandardMaterial>>,
    Has<Mesh3d>,
);

/// One saved object's row of the scene.
type SaveRow<'w, 's> = bevy::ecs::query::QueryItem<'w, 's, SaveItem>;

/// The scene as a project to be saved at `path`; also the names of objects that cannot be saved
/// (meshes made by code, with no source file and no shape).
pub fn capture_project(world: &mut World, path: &Path) -> (ProjectFile, Vec<String>) {
    let mut q = world.query_filtered::<SaveItem, With<SceneObject>>();
    let world: &World = world;
    let (nodes, rows) = listed_rows(world, q.iter(world).collect());
    let mut sources = Sources::default();
    let (mut objects, unsaved) = object_rows(world, &rows, &mut sources);
    let (mut deleted, mut source_ids) = import_nodes(world, &nodes, &mut sources);
    keep_missing(
        world.resource::<ProjectState>(),
        &mut sources,
        &mut objects,
        &mut deleted,
        &mut source_ids,
    );
    // Whatever the view became (a pan far out), it is saved as a reopen accepts it.
    let camera = world
        .get_resource::<DocumentView>()
        .and_then(|v| v.0)
        .map(crate::scene::outbox::CameraValue::clamped);
    let project = ProjectFile {
        version: PROJECT_VERSION,
        sources: sources.0.iter().map(|s| store_source(path, &s.1)).collect(),
        source_ids,
        objects,
        deleted,
        camera,
        look: world
            .get_resource::<crate::values::look::SceneLook>()
            .copied(),
        environment: world
            .get_resource::<crate::scene::environment::SceneEnvironment>()
            .filter(|e| **e != crate::scene::environment::SceneEnvironment::default())
            .map(|e| crate::scene::environment::SceneEnvironment {
                image: e.image.as_deref().map(|i| store_source(path, i)),
                ..e.clone()
            }),
    };
    (project, unsaved)
}

/// The project's sources in the order objects first name them.
#[derive(Default)]
struct Sources(Vec<(SourceOf, PathBuf)>);

impl Sources {
    /// The index of source `of` (read from `file`), added if it is new.
    fn index(&mut self, of: SourceOf, file: &Path) -> usize {
        match self.0.iter().position(|s| s.0 == of) {
            Some(i) => i,
            None => {
                self.0.push((of, file.to_owned()));
                self.0.len() - 1
            }
        }
    }

    fn contains(&self, of: SourceOf) -> bool {
        self.0.iter().any(|s| s.0 == of)
    }
}

/// Each import's nodes by key index: gone (deleted), listed, or left as they were (only their
/// ids are written, as runs); and the rows to list, by id. A source's root is always listed: an
/// import places it. Each import of a file is a source of its own.
fn listed_rows<'w, 's>(
    world: &World,
    all: Vec<SaveRow<'w, 's>>,
) -> (HashMap<u32, Vec<Node>>, Vec<SaveRow<'w, 's>>) {
    let catalog = world.resource::<SourceCatalog>();
    let edited = world.resource::<EditedObjects>();
    let mut nodes: HashMap<u32, Vec<Node>> = HashMap::new();
    let mut rows = Vec::new();
    for row in all {
        if let Some(k) = row.6 {
            let listed = k.index == 0 || edited.0.contains(row.1);
            let slots = nodes.entry(k.import).or_insert_with(|| {
                vec![Node::Gone; catalog.get(k.import).map_or(0, |i| i.keys.len())]
            });
            match slots.get_mut(k.index as usize) {
                // Not the key the catalog has at this place (an object that found its way into
                // another import): listed in full.
                Some(slot) if *slot == Node::Gone => {
                    *slot = if listed {
                        Node::Listed
                    } else {
                        Node::Unlisted(*row.1)
                    };
                    if !listed {
                        continue;
                    }
                }
                _ => {}
            }
        }
        rows.push(row);
    }
    rows.sort_by_key(|r| *r.1);
    (nodes, rows)
}

/// The listed objects, and the names of those that cannot be saved. Meshes made by code, with
/// no file or shape to rebuild them from, cannot be: their children are saved under the nearest
/// ancestor that is (so the project opens again), where they stand in the world.
fn object_rows(
    world: &World,
    rows: &[SaveRow],
    sources: &mut Sources,
) -> (Vec<ProjectObject>, Vec<String>) {
    let materials = world.resource::<Assets<StandardMaterial>>();
    let dropped: std::collections::HashSet<Entity> = rows
        .iter()
        .filter(|r| {
            r.6.is_none()
                && r.7.is_none()
                && r.8.is_none()
                && r.10
                && LightValue::of(&world.entity(r.0)).is_none()
        })
        .map(|r| r.0)
        .collect();
    // The parent an object is saved under, and its transform there (through the dropped
    // meshes between).
    let saved_place = |parent: Option<&ChildOf>, t: Transform| -> (Option<SceneId>, Transform) {
        let mut at = parent.map(ChildOf::parent);
        let mut t = t;
        while let Some(p) = at.filter(|p| dropped.contains(p)) {
            let between = world.get::<Transform>(p).copied().unwrap_or_default();
            t = between.mul_transform(t);
            at = world.get::<ChildOf>(p).map(ChildOf::parent);
        }
        (at.and_then(|p| world.get::<SceneId>(p).copied()), t)
    };
    let (mut objects, mut unsaved) = (Vec::new(), Vec::new());
    for (e, id, name, t, vis, parent, key, mesh_source, shape, mat, has_mesh) in rows {
        let name = name.map_or(String::new(), |n| n.as_str().to_owned());
        let light = LightValue::of(&world.entity(*e));
        let kind = if let Some(k) = key {
            ObjectKind::Node(SourceNode {
                source: sources.index(SourceOf::Import(k.import), &k.file),
                key: k.key.to_string(),
            })
        } else if let Some(MeshSource(k)) = mesh_source {
            ObjectKind::MeshOf(SourceNode {
                source: sources.index(SourceOf::Import(k.import), &k.file),
                key: k.key.to_string(),
            })
        } else if let Some(PrimitiveShape(s)) = shape {
            ObjectKind::Shape(*s)
        } else if let Some(l) = light {
            ObjectKind::Light(l)
        } else if *has_mesh {
            unsaved.push(name);
            continue;
        } else {
            ObjectKind::Empty
        };
        let (parent, transform) = saved_place(*parent, **t);
        objects.push(ProjectObject {
            id: **id,
            name,
            parent,
            transform: transform.into(),
            visible: *vis != Some(&Visibility::Hidden),
            material: mat.and_then(|m| materials.get(&m.0)).map(MaterialValue::of),
            // A light made in the editor has its values in its kind.
            light: light.filter(|_| !matches!(kind, ObjectKind::Light(_))),
            kind,
        });
    }
    (objects, unsaved)
}

/// Deleted nodes (those each import had that are gone now) and the runs of ids of the nodes left
/// as they were, for the imports that left an object (one wholly deleted or undone is not
/// written).
fn import_nodes(
    world: &World,
    nodes: &HashMap<u32, Vec<Node>>,
    sources: &mut Sources,
) -> (Vec<SourceNode>, Vec<SourceIds>) {
    let catalog = world.resource::<SourceCatalog>();
    let (mut deleted, mut source_ids) = (Vec::new(), Vec::new());
    let mut imports: Vec<(u32, &crate::scene::spawn::SourceImport)> = catalog
        .iter()
        .filter(|(n, _)| sources.contains(SourceOf::Import(*n)))
        .collect();
    imports.sort_by_key(|i| i.0);
    for (import, source) in imports {
        let (file, keys) = (&source.file, &source.keys);
        let of = SourceOf::Import(import);
        let slots = nodes.get(&import);
        let slot = |i: usize| slots.and_then(|s| s.get(i)).copied().unwrap_or(Node::Gone);
        if slots.is_some_and(|s| s.iter().any(|n| matches!(n, Node::Unlisted(_)))) {
            source_ids.push(SourceIds {
                source: sources.index(of, file),
                keys: keys_hash(keys.iter().map(|k| &**k)),
                runs: id_runs((0..keys.len()).map(|i| match slot(i) {
                    Node::Unlisted(id) => Some(id),
                    _ => None,
                })),
            });
        }
        let gone: Vec<&std::sync::Arc<str>> = keys
            .iter()
            .enumerate()
            .filter(|(i, _)| slot(*i) == Node::Gone)
            .map(|(_, k)| k)
            .collect();
        if gone.is_empty() {
            continue;
        }
        let source = sources.index(of, file);
        deleted.extend(gone.into_iter().map(|k| SourceNode {
            source,
            key: k.to_string(),
        }));
    }
    (deleted, source_ids)
}

/// What a missing source held stays as it was, each such source apart.
fn keep_missing(
    state: &ProjectState,
    sources: &mut Sources,
    objects: &mut Vec<ProjectObject>,
    deleted: &mut Vec<SourceNode>,
    source_ids: &mut Vec<SourceIds>,
) {
    let missing_file = |i: usize| state.missing_sources.get(i).cloned().unwrap_or_default();
    for o in &state.missing {
        let mut o = o.clone();
        if let ObjectKind::Node(n) | ObjectKind::MeshOf(n) = &mut o.kind {
            let file = missing_file(n.source);
            n.source = sources.index(SourceOf::Missing(n.source), &file);
        }
        objects.push(o);
    }
    for (i, key) in &state.missing_deleted {
        deleted.push(SourceNode {
            source: sources.index(SourceOf::Missing(*i), &missing_file(*i)),
            key: key.clone(),
        });
    }
    for ids in &state.missing_ids {
        let file = missing_file(ids.source);
        source_ids.push(SourceIds {
            source: sources.index(SourceOf::Missing(ids.source), &file),
            ..ids.clone()
        });
    }
}

/// Which source of the saved project an object's node belongs to: an import in the scene (by its
/// number), or a source the open project is missing (by its index there).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SourceOf {
    Import(u32),
    Missing(usize),
}

/// What became of one of a source's nodes, for the save.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Node {
    /// Deleted (or, for a key the catalog has and the scene not, never there).
    Gone,
    /// Written as an object.
    Listed,
    /// Left as the file has it: only its id is written.
    Unlisted(SceneId),
}

/// Runs of consecutive key indices with consecutive ids, from each key's id (`None` for a key
/// not in the runs).
fn id_runs(ids: impl Iterator<Item = Option<SceneId>>) -> Vec<IdRun> {
    let mut runs: Vec<IdRun> = Vec::new();
    for (i, id) in ids.enumerate() {
        let Some(id) = id else { continue };
        match runs.last_mut() {
            Some(IdRun(start, first, count))
                if *start as usize + *count as usize == i
                    && first.0 + u64::from(*count) == id.0 =>
            {
                *count += 1;
            }
            _ => runs.push(IdRun(i as u32, id, 1)),
        }
    }
    runs
}

/// Saves the scene to `path` (atomically) and makes it the open project; returns the names of
/// objects that could not be saved.
pub fn save_project(world: &mut World, path: &Path) -> Result<Vec<String>, ProjectError> {
    let (project, unsaved) = capture_project(world, path);
    write_project(path, &project)?;
    let mut state = world.resource_mut::<ProjectState>();
    state.path = Some(path.to_owned());
    state.on_disk = crate::project::format::FileStamp::of(path);
    world.resource_mut::<EditHistory>().mark_saved();
    Ok(unsaved)
}
