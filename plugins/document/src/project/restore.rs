//! Opening a project in place of the scene: its sources imported again (read in the background,
//! with progress), then what the user made of them applied; relinking a missing source.

use crate::edit::command::MaterialValue;
use crate::edit::history::EditHistory;
use crate::project::capture::capture_project;
use crate::project::format::*;
use crate::project::plan::OpenPlan;
use crate::scene::outbox::{CameraValue, DocumentEvent, DocumentView};
use crate::scene::spawn::{MeshSource, SourceCatalog};
use crate::values::map_transforms::MaterialMapTransforms;
use crate::values::object::{EditedObjects, SceneId, SceneIndex, SceneObject};
use crate::values::primitive::Primitive;
use crate::values::primitive::PrimitiveShape;
use bevy::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The sources the open project is missing: files that held objects or deletions still kept.
pub fn missing_sources(state: &ProjectState) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = Vec::new();
    let mut add = |p: &Path| {
        if !out.iter().any(|q| q == p) {
            out.push(p.to_owned());
        }
    };
    for o in &state.missing {
        if let ObjectKind::Node(n) | ObjectKind::MeshOf(n) = &o.kind
            && let Some(p) = state.missing_sources.get(n.source)
        {
            add(p);
        }
    }
    for (i, _) in &state.missing_deleted {
        if let Some(p) = state.missing_sources.get(*i) {
            add(p);
        }
    }
    // Objects whose nodes are gone from a file that is there are not a missing source.
    out.retain(|p| !p.is_file());
    out
}

/// Points the project's source `from` at the file `to` and opens the scene again with it, so its
/// kept objects find their nodes; the scene then has unsaved changes (and a fresh history).
pub fn relink_source(
    world: &mut World,
    from: &Path,
    to: &Path,
) -> Result<OpenReport, ProjectError> {
    let (owner, on_disk) = {
        let state = world.resource::<ProjectState>();
        (state.path.clone(), state.on_disk)
    };
    // Relative sources resolve against the project's folder, or the working folder for a scene
    // never saved.
    let base = owner.clone().unwrap_or_else(|| {
        std::env::current_dir()
            .unwrap_or_default()
            .join("untitled.treelight")
    });
    let (mut project, _) = capture_project(world, &base);
    for s in &mut project.sources {
        if resolve_source(&base, s) == from {
            *s = store_source(&base, to);
        }
    }
    project
        .validate()
        .map_err(|e| ProjectError::Format(base.clone(), e))?;
    let report = open_project_value(world, project, &base)?;
    let mut state = world.resource_mut::<ProjectState>();
    state.path = owner;
    state.on_disk = on_disk;
    world.resource_mut::<EditHistory>().mark_unsaved();
    Ok(report)
}

/// Gives a source node's material the saved values. A material the file shares between nodes is
/// only changed for all of them when they agree; a node whose values differ gets its own copy (as
/// "make unique" gave it).
fn apply_node_material(world: &mut World, e: Entity, value: &MaterialValue) {
    let Some(handle) = world
        .get::<MeshMaterial3d<StandardMaterial>>(e)
        .map(|m| m.0.clone())
    else {
        return;
    };
    let materials = world.resource::<Assets<StandardMaterial>>();
    let Some(current) = materials.get(&handle) else {
        return;
    };
    if MaterialValue::of(current) == *value {
        return;
    }
    let mut users = world.query::<&MeshMaterial3d<StandardMaterial>>();
    let shared = users
        .iter(world)
        .filter(|m| m.0.id() == handle.id())
        .count()
        > 1;
    let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
    if shared {
        let mut copy = materials.get(&handle).cloned().unwrap_or_default();
        value.write(&mut copy);
        let unique = materials.add(copy);
        if let Some(mut t) = world.get_resource_mut::<MaterialMapTransforms>() {
            t.copy(handle.id(), unique.id());
        }
        world.entity_mut(e).insert(MeshMaterial3d(unique));
    } else if let Some(mut m) = materials.get_mut(&handle) {
        value.write(&mut m);
    }
}

/// Opens the project at `path` in place of the scene. Everything that can fail is read and checked
/// first: on an error the scene is untouched. Missing or unreadable sources do not fail the open;
/// the report lists them and their objects stay in the project.
pub fn open_project(world: &mut World, path: &Path) -> Result<OpenReport, ProjectError> {
    let stamp = crate::project::format::FileStamp::of(path);
    let project = read_project(path)?;
    let report = open_project_value(world, project, path)?;
    world.resource_mut::<ProjectState>().on_disk = stamp;
    Ok(report)
}

/// How far the parsing of a project's sources has got, shared with the thread doing it, and a way
/// to stop it between sources.
#[derive(Debug, Default)]
pub struct OpenProgress {
    /// Sources read so far.
    pub done: std::sync::atomic::AtomicUsize,
    /// Sources to read.
    pub total: std::sync::atomic::AtomicUsize,
    /// Set to stop before the next source.
    pub cancelled: std::sync::atomic::AtomicBool,
}

/// A project's sources, read: what [`open_project_parsed`] puts in the scene.
pub struct ParsedSources {
    resolved: Vec<PathBuf>,
    parsed: Vec<Option<Arc<treelight_import::ImportedScene>>>,
    /// Each source's Bevy meshes, images and the tree's copies of the meshes, made on the job
    /// that parsed it (`None` for a file read for an earlier source, whose assets it shares).
    prebuilt: Vec<Option<crate::import::parse::Prebuilt>>,
    report: OpenReport,
}

impl ParsedSources {
    /// Each source's scene, in the project's order (`None` for a missing or unreadable one); a
    /// file the project imports several times is read once, its scene shared.
    pub fn scenes(&self) -> &[Option<Arc<treelight_import::ImportedScene>>] {
        &self.parsed
    }
}

/// Checks and parses the sources of `project` (at `path`), touching no scene: the slow part of
/// opening one, which the editor runs off its main thread. A source that is not a scene file fails
/// the open; a missing or unreadable one is reported and its objects kept.
pub fn parse_sources(
    project: &ProjectFile,
    path: &Path,
    progress: Option<&OpenProgress>,
) -> Result<ParsedSources, ProjectError> {
    use std::sync::atomic::Ordering;
    let mut report = OpenReport::default();
    let mut parsed: Vec<Option<Arc<treelight_import::ImportedScene>>> = Vec::new();
    let mut prebuilt: Vec<Option<crate::import::parse::Prebuilt>> = Vec::new();
    let resolved: Vec<PathBuf> = project
        .sources
        .iter()
        .map(|s| resolve_source(path, s))
        .collect();
    if let Some(p) = progress {
        p.total.store(resolved.len(), Ordering::Relaxed);
    }
    for (i, file) in resolved.iter().enumerate() {
        if progress.is_some_and(|p| p.cancelled.load(Ordering::Relaxed)) {
            return Err(ProjectError::Io(
                path.to_owned(),
                "opening cancelled".into(),
            ));
        }
        // A file imported again: read once.
        if let Some(j) = resolved[..i].iter().position(|f| f == file) {
            parsed.push(parsed[j].clone());
            prebuilt.push(None);
            if parsed[j].is_none()
                && let Some(m) = report
                    .missing_sources
                    .iter()
                    .find(|m| m.0 == *file)
                    .cloned()
            {
                report.missing_sources.push(m);
            }
            if let Some(p) = progress {
                p.done.store(i + 1, Ordering::Relaxed);
            }
            continue;
        }
        match check_source(file) {
            Err(problem) => {
                return Err(ProjectError::Source(
                    path.to_owned(),
                    i,
                    project.sources[i].clone(),
                    problem,
                ));
            }
            Ok(false) => {
                report
                    .missing_sources
                    .push((file.clone(), "the file is gone".into()));
                parsed.push(None);
                prebuilt.push(None);
            }
            Ok(true) => match treelight_import::load_scene(file) {
                Ok(scene) => {
                    // Its meshes made here, off the frame, as an import's are.
                    let made = crate::import::parse::ParsedScene::from(scene);
                    parsed.push(Some(made.scene));
                    prebuilt.push(Some(made.parts));
                }
                Err(e) => {
                    report.missing_sources.push((file.clone(), e.to_string()));
                    parsed.push(None);
                    prebuilt.push(None);
                }
            },
        }
        if let Some(p) = progress {
            p.done.store(i + 1, Ordering::Relaxed);
        }
    }
    Ok(ParsedSources {
        resolved,
        parsed,
        prebuilt,
        report,
    })
}

/// [`open_project`] of a project already read and checked; `path` is where it lives (its sources
/// resolve against its folder, errors name it).
pub fn open_project_value(
    world: &mut World,
    project: ProjectFile,
    path: &Path,
) -> Result<OpenReport, ProjectError> {
    let sources = parse_sources(&project, path, None)?;
    open_project_parsed(world, project, path, sources)
}

/// Empties the scene: every object despawned (assemblies from their roots), a fresh history, no
/// sources; an editor is told the scene was replaced.
pub fn empty_scene(world: &mut World) {
    let mut q = world.query_filtered::<Entity, (With<SceneObject>, Without<ChildOf>)>();
    for e in q.iter(world).collect::<Vec<_>>() {
        crate::scene::hierarchy::despawn_subtree(world, e);
    }
    let mut q = world.query_filtered::<Entity, With<SceneObject>>();
    for e in q.iter(world).collect::<Vec<_>>() {
        crate::scene::hierarchy::despawn_subtree(world, e);
    }
    *world.resource_mut::<EditHistory>() = EditHistory::default();
    world.insert_resource(crate::values::look::SceneLook::default());
    world.insert_resource(crate::scene::environment::SceneEnvironment::default());
    world.write_message(DocumentEvent::Replaced);
    world.resource_mut::<SourceCatalog>().clear();
}

/// Empties the scene for a project, and reserves the ids the project holds (those kept while
/// their source is missing too).
fn clear_scene(world: &mut World, project: &ProjectFile, read: &[bool]) {
    empty_scene(world);
    world.resource_mut::<EditedObjects>().0.clear();
    // Fresh ids for the sources' nodes never collide with the project's.
    let mut index = world.resource_mut::<SceneIndex>();
    index.reserve_through(project.top_id());
    // Objects kept while their source is missing are not in the scene, but hold their ids; so
    // do the nodes of a missing source.
    for o in &project.objects {
        index.retire(o.id);
    }
    for s in project.source_ids.iter().filter(|s| !read[s.source]) {
        for run in &s.runs {
            let (_, first, count) = run.parts();
            for id in first..first + count {
                index.retire(SceneId(id));
            }
        }
    }
}

/// Spawns every source that was read, its objects with the ids the plan gives them; each read
/// source's objects in key order.
fn spawn_sources(
    world: &mut World,
    parsed: &[Option<Arc<treelight_import::ImportedScene>>],
    prebuilt: Vec<Option<crate::import::parse::Prebuilt>>,
    resolved: &[PathBuf],
    plan: &OpenPlan,
) -> Vec<Vec<Entity>> {
    let mut objects = Vec::with_capacity(parsed.len());
    let mut prebuilt = prebuilt.into_iter();
    for (i, scene) in parsed.iter().enumerate() {
        let mut made = prebuilt.next().flatten().unwrap_or_default();
        let spawned = scene.as_ref().and_then(|scene| {
            let ids = plan.sources[i].as_ref().map_or(&[][..], |p| &p.ids[..]);
            crate::scene::spawn::spawn_scene_in_world(
                world,
                &resolved[i],
                scene,
                &mut made,
                false,
                ids,
            )
            .ok()
        });
        objects.push(spawned.map_or_else(Vec::new, |s| s.objects));
    }
    objects
}

/// A copy of the mesh on `origin` (the node `n` of a source), sharing its mesh and material;
/// `None` when the node shows no mesh.
fn spawn_copy(world: &mut World, origin: Entity) -> Option<Entity> {
    let mesh = world.get::<Mesh3d>(origin).cloned()?;
    let material = world
        .get::<MeshMaterial3d<StandardMaterial>>(origin)
        .cloned()?;
    let source_key = world.get::<MeshSource>(origin)?.0.clone();
    Some(
        world
            .spawn((SceneObject, mesh, material, MeshSource(source_key)))
            .id(),
    )
}

/// A light as the project describes it.
fn spawn_light(world: &mut World, l: &LightValue) -> Entity {
    let mut e = world.spawn(SceneObject);
    l.put_on(&mut e);
    e.id()
}

/// Parents, once every object exists (a parent may come after its child); a listed node whose
/// parent is not its file's counts as edited. Parents among the unlisted nodes are the files'.
fn link_parents(
    world: &mut World,
    project: &ProjectFile,
    by_id: &HashMap<SceneId, Entity>,
    edited: &mut std::collections::HashSet<SceneId>,
) {
    let index = world.resource::<SceneIndex>();
    let target = |o: &ProjectObject| {
        o.parent
            .and_then(|p| by_id.get(&p).copied().or_else(|| index.entity(p)))
    };
    let targets: Vec<Option<Entity>> = project.objects.iter().map(target).collect();
    for (o, target) in project.objects.iter().zip(targets) {
        let Some(&e) = by_id.get(&o.id) else { continue };
        if world.get::<ChildOf>(e).map(ChildOf::parent) != target {
            edited.insert(o.id);
        }
        match target {
            Some(p) if p != e => {
                world.entity_mut(e).insert(ChildOf(p));
            }
            _ => {
                world.entity_mut(e).remove::<ChildOf>();
            }
        }
    }
}

/// The project's view, kept for the next save and announced for an editor's camera.
fn restore_view(world: &mut World, c: CameraValue) {
    let c = c.clamped();
    world.insert_resource(DocumentView(Some(c)));
    world.write_message(DocumentEvent::View(c));
}

/// Puts a project whose sources were parsed ([`parse_sources`]) in place of the scene.
pub fn open_project_parsed(
    world: &mut World,
    project: ProjectFile,
    path: &Path,
    sources: ParsedSources,
) -> Result<OpenReport, ProjectError> {
    let ParsedSources {
        resolved,
        parsed,
        prebuilt,
        mut report,
    } = sources;
    let plan = crate::project::plan::plan(&project, &parsed)
        .map_err(|e| ProjectError::Format(path.to_owned(), e))?;
    report.changed_sources = plan.changed.iter().map(|&i| resolved[i].clone()).collect();

    let read: Vec<bool> = parsed.iter().map(Option::is_some).collect();
    clear_scene(world, &project, &read);
    let spawned = spawn_sources(world, &parsed, prebuilt, &resolved, &plan);
    let mut state = ProjectState {
        path: Some(path.to_owned()),
        ..default()
    };
    let mut making = ListedObjects {
        parsed: &parsed,
        spawned: &spawned,
        plan: &plan,
        shape_meshes: HashMap::new(),
        shared_materials: HashMap::new(),
        edited: std::collections::HashSet::new(),
    };
    let mut by_id: HashMap<SceneId, Entity> = HashMap::new();
    for o in &project.objects {
        let Some(entity) = making.make(world, o, &mut report) else {
            state.missing.push(o.clone());
            continue;
        };
        world.entity_mut(entity).insert((
            o.id,
            Name::new(o.name.clone()),
            Transform::from(o.transform),
            if o.visible {
                Visibility::Inherited
            } else {
                Visibility::Hidden
            },
        ));
        by_id.insert(o.id, entity);
    }
    let mut edited = std::mem::take(&mut making.edited);
    link_parents(world, &project, &by_id, &mut edited);
    // Deleted nodes go last: their children the user moved elsewhere are elsewhere by now.
    for d in &project.deleted {
        if parsed[d.source].is_none() {
            state.missing_deleted.push((d.source, d.key.clone()));
        } else if let Some(e) = making.node(d.source, &d.key)
            && world.get_entity(e).is_ok()
        {
            crate::scene::hierarchy::despawn_subtree(world, e);
        }
    }
    state.missing_sources = resolved.clone();
    if let Some(c) = project.camera {
        restore_view(world, c);
    }
    // Checked by validation: finite and within range.
    world.insert_resource(project.look.unwrap_or_default());
    // Checked by validation too; the file is read (and a missing one reported) by the loader.
    let environment = project.environment.clone().unwrap_or_default();
    world.insert_resource(crate::scene::environment::SceneEnvironment {
        image: environment
            .image
            .as_deref()
            .map(|i| crate::project::format::resolve_source(path, i)),
        ..environment
    });
    for s in &project.source_ids {
        if parsed[s.source].is_none() {
            state.missing_ids.push(s.clone());
        }
    }
    world.insert_resource(state);
    world.resource_mut::<EditedObjects>().0 = edited;
    world.resource_mut::<EditHistory>().mark_saved();
    Ok(report)
}

/// What making a project's listed objects shares: the sources' spawned nodes, the meshes of the
/// shapes and the materials made so far (one asset for equal values), and the listed nodes whose
/// values differ from their file's (written again by the next save; a version 1 project lists
/// every node, most as the file has them).
struct ListedObjects<'a> {
    parsed: &'a [Option<Arc<treelight_import::ImportedScene>>],
    spawned: &'a [Vec<Entity>],
    plan: &'a OpenPlan<'a>,
    shape_meshes: HashMap<Primitive, Handle<Mesh>>,
    shared_materials: HashMap<String, Handle<StandardMaterial>>,
    edited: std::collections::HashSet<SceneId>,
}

impl ListedObjects<'_> {
    /// The spawned node of source `source` with `key`, if it has one.
    fn node(&self, source: usize, key: &str) -> Option<Entity> {
        self.spawned
            .get(source)?
            .get(self.plan.index_of(source, key)?)
            .copied()
    }

    /// A material of `value` over `base`, shared with any made of the same values.
    fn material(
        &mut self,
        world: &mut World,
        value: &MaterialValue,
        base: StandardMaterial,
    ) -> Handle<StandardMaterial> {
        let key = format!("{value:?}");
        if let Some(h) = self.shared_materials.get(&key) {
            return h.clone();
        }
        let mut m = base;
        value.write(&mut m);
        let h = world.resource_mut::<Assets<StandardMaterial>>().add(m);
        self.shared_materials.insert(key, h.clone());
        h
    }

    /// The entity listed object `o` is: its source's node with the listed values, a copy of one,
    /// or a shape, light or group made anew; `None` where its source or node is missing (counted
    /// in `report`), kept for the next save.
    fn make(
        &mut self,
        world: &mut World,
        o: &ProjectObject,
        report: &mut OpenReport,
    ) -> Option<Entity> {
        let missing_source = |n: &SourceNode| self.parsed[n.source].is_none();
        Some(match &o.kind {
            ObjectKind::Node(n) | ObjectKind::MeshOf(n) if missing_source(n) => return None,
            ObjectKind::Node(n) => {
                let Some(e) = self.node(n.source, &n.key) else {
                    report.missing_nodes += 1;
                    if report.missing_names.len() < 10 {
                        report
                            .missing_names
                            .push(format!("{} ('{}')", o.name, n.key));
                    }
                    return None;
                };
                if !node_as_listed(world, e, o) {
                    self.edited.insert(o.id);
                }
                if let Some(value) = &o.material {
                    apply_node_material(world, e, value);
                }
                if let Some(light) = &o.light {
                    light.put_on(&mut world.entity_mut(e));
                }
                e
            }
            ObjectKind::MeshOf(n) => {
                let origin = self.node(n.source, &n.key);
                let Some(e) = origin.and_then(|origin| spawn_copy(world, origin)) else {
                    report.missing_nodes += 1;
                    return None;
                };
                // A copy shares its original's material until one of them was made unique.
                if let Some(value) = &o.material {
                    apply_node_material(world, e, value);
                }
                if let Some(light) = &o.light {
                    light.put_on(&mut world.entity_mut(e));
                }
                e
            }
            ObjectKind::Shape(shape) => {
                let mesh = self
                    .shape_meshes
                    .entry(*shape)
                    .or_insert_with(|| world.resource_mut::<Assets<Mesh>>().add(shape.mesh()))
                    .clone();
                let value = o
                    .material
                    .unwrap_or_else(|| MaterialValue::of(&shape.material()));
                let material = self.material(world, &value, shape.material());
                world
                    .spawn((
                        SceneObject,
                        Mesh3d(mesh),
                        MeshMaterial3d(material),
                        PrimitiveShape(*shape),
                    ))
                    .id()
            }
            ObjectKind::Light(l) => spawn_light(world, l),
            ObjectKind::Empty => world.spawn((SceneObject, Visibility::default())).id(),
        })
    }
}

/// Whether a source node's spawned values (its file's) are those the project lists: name,
/// transform, visibility and material.
fn node_as_listed(world: &World, e: Entity, o: &ProjectObject) -> bool {
    let name = world.get::<Name>(e).map_or("", |n| n.as_str());
    let transform = world.get::<Transform>(e).copied().unwrap_or_default();
    let hidden = world.get::<Visibility>(e) == Some(&Visibility::Hidden);
    let material = world
        .get::<MeshMaterial3d<StandardMaterial>>(e)
        .and_then(|m| world.resource::<Assets<StandardMaterial>>().get(&m.0))
        .map(MaterialValue::of);
    name == o.name
        && crate::edit::command::TransformValue::from(transform) == o.transform
        && hidden != o.visible
        && o.material.is_none_or(|m| Some(m) == material)
        && o.light
            .is_none_or(|l| Some(l) == LightValue::of(&world.entity(e)))
}
