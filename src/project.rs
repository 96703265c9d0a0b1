//! Projects: a `.treelight` file (RON, versioned) that holds references to the scene files it was
//! built from, what the user made of their nodes (keyed by source keys: transform, parent,
//! visibility, name, material values, deletions), the objects added in the editor (shapes, lights,
//! groups, copies of imported meshes) and the camera; never a copy of the geometry. Opening one
//! imports its sources again and applies the rest; saving writes a temporary file beside the target,
//! flushes it and renames it over the target.

use crate::camera::OrbitCamera;
use crate::edit::command::in_range;
use crate::edit::snapshot::PrimitiveShape;
use crate::edit::{EditHistory, LightKind, MaterialValue, Primitive, TransformValue};
use crate::import::{MeshSource, SourceCatalog, SourceKey};
use crate::scene_id::{SceneId, SceneIndex};
use crate::selection::{SceneObject, Selection};
use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// The version this editor writes and reads.
pub const PROJECT_VERSION: u32 = 1;

/// Largest project file read, bytes.
const MAX_PROJECT_BYTES: u64 = 256 << 20;
/// Most objects a project may hold.
const MAX_OBJECTS: usize = 2_000_000;
/// Most source files a project may name.
const MAX_SOURCES: usize = 100_000;

/// A node of one of the project's sources.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SourceNode {
    /// Index into the project's sources.
    pub source: usize,
    /// The node's key in that file (the file's root: empty).
    pub key: String,
}

/// A light's values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightValue {
    /// Which kind.
    pub kind: LightKind,
    /// Colour, sRGB.
    pub color: [f32; 3],
    /// Lumens for a point light, lux for a directional one.
    pub intensity: f32,
    /// Whether it casts shadows in the rasterised view.
    #[serde(default = "shown")]
    pub shadows: bool,
    /// A point light's range.
    #[serde(default)]
    pub range: Option<f32>,
}

/// What an object is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ObjectKind {
    /// A node of a source file.
    Node(SourceNode),
    /// A copy showing a source node's mesh.
    MeshOf(SourceNode),
    /// A built-in shape.
    Shape(Primitive),
    /// A light.
    Light(LightValue),
    /// An empty group.
    Empty,
}

/// One object of the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProjectObject {
    /// Its stable id.
    pub id: SceneId,
    /// Its name.
    pub name: String,
    /// Its parent.
    #[serde(default)]
    pub parent: Option<SceneId>,
    /// Its transform relative to its parent.
    pub transform: TransformValue,
    /// Whether it is shown.
    #[serde(default = "shown")]
    pub visible: bool,
    /// What it is.
    pub kind: ObjectKind,
    /// Its material's values, for a mesh.
    #[serde(default)]
    pub material: Option<MaterialValue>,
}

fn shown() -> bool {
    true
}

/// The camera's orbit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraValue {
    /// Point orbited.
    pub focus: [f32; 3],
    /// Distance from it.
    pub radius: f32,
    /// Rotation about the up axis, radians.
    pub yaw: f32,
    /// Elevation, radians.
    pub pitch: f32,
}

/// A project file's contents.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProjectFile {
    /// The format's version.
    pub version: u32,
    /// Scene files, relative to the project's folder when inside it.
    #[serde(default)]
    pub sources: Vec<PathBuf>,
    /// The scene's objects, by id.
    #[serde(default)]
    pub objects: Vec<ProjectObject>,
    /// Source nodes the user deleted.
    #[serde(default)]
    pub deleted: Vec<SourceNode>,
    /// The camera.
    #[serde(default)]
    pub camera: Option<CameraValue>,
}

/// Why a project cannot be opened or saved; each names the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProjectError {
    /// The file cannot be read or written.
    #[error("{0}: {1}")]
    Io(PathBuf, String),
    /// The file is not a project this editor reads.
    #[error("{0}: not a Treelight project: {1}")]
    Format(PathBuf, String),
    /// The file names a source that is not a scene file.
    #[error("{0}: source {1} ('{2}') {3}")]
    Source(PathBuf, usize, PathBuf, String),
}

/// The open project, and what it holds that the scene does not show.
#[derive(Resource, Debug, Default)]
pub struct ProjectState {
    /// Where it was last opened from or saved to; `None` for a scene never saved.
    pub path: Option<PathBuf>,
    /// Objects whose source file or node is missing: kept so a later save does not drop them.
    pub missing: Vec<ProjectObject>,
    /// The files the missing objects' source indices name (every source of the project as
    /// opened, resolved).
    pub missing_sources: Vec<PathBuf>,
    /// Deleted source nodes of missing sources, kept likewise.
    pub missing_deleted: Vec<(PathBuf, String)>,
}

/// What opening a project found missing, for the user.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct OpenReport {
    /// Sources that are gone or unreadable, with the reason.
    pub missing_sources: Vec<(PathBuf, String)>,
    /// Objects whose node no longer exists in its (readable) source.
    pub missing_nodes: usize,
}

impl ProjectFile {
    /// Checks what a file could get wrong: version, sizes, numbers, ids, references.
    pub fn validate(&self) -> Result<(), String> {
        if self.version != PROJECT_VERSION {
            return Err(format!(
                "version {} is not one this editor reads ({PROJECT_VERSION})",
                self.version
            ));
        }
        if self.sources.len() > MAX_SOURCES || self.objects.len() > MAX_OBJECTS {
            return Err("it names more sources or objects than a project can hold".into());
        }
        let mut ids = HashSet::new();
        for o in &self.objects {
            if !o.id.is_valid() {
                return Err(format!(
                    "object id {} is outside the range of ids (1 to {})",
                    o.id.0,
                    SceneId::MAX.0
                ));
            }
            if !ids.insert(o.id) {
                return Err(format!("object id {} is used twice", o.id.0));
            }
            if !o.transform.is_valid() {
                return Err(format!("object {} has a transform out of range", o.id.0));
            }
            if o.material.as_ref().is_some_and(|m| !m.is_valid()) {
                return Err(format!("object {} has a material out of range", o.id.0));
            }
            match &o.kind {
                ObjectKind::Node(n) | ObjectKind::MeshOf(n) if n.source >= self.sources.len() => {
                    return Err(format!(
                        "object {} names source {}, which the project does not list",
                        o.id.0, n.source
                    ));
                }
                ObjectKind::Light(l)
                    if !l.color.iter().all(|v| in_range(*v))
                        || !in_range(l.intensity)
                        || l.range.is_some_and(|r| !in_range(r)) =>
                {
                    return Err(format!("object {} has a light out of range", o.id.0));
                }
                _ => {}
            }
        }
        self.check_parents(&ids)?;
        if self.deleted.iter().any(|d| d.source >= self.sources.len()) {
            return Err("a deleted node names a source the project does not list".into());
        }
        if let Some(c) = &self.camera
            && !c
                .focus
                .iter()
                .chain([&c.radius, &c.yaw, &c.pitch])
                .all(|v| in_range(*v))
        {
            return Err("the camera is out of range".into());
        }
        Ok(())
    }
}

impl ProjectFile {
    /// Refuses parents that are the object itself, that no object of the file has, or that
    /// lead round in a cycle: the objects must form a forest, as the scene they make does.
    fn check_parents(&self, ids: &HashSet<SceneId>) -> Result<(), String> {
        let parent: HashMap<SceneId, SceneId> = self
            .objects
            .iter()
            .filter_map(|o| Some((o.id, o.parent?)))
            .collect();
        for (&child, &p) in &parent {
            if p == child {
                return Err(format!("object {} is its own parent", child.0));
            }
            if !ids.contains(&p) {
                return Err(format!(
                    "object {} names parent {}, which the project does not hold",
                    child.0, p.0
                ));
            }
        }
        // Walk up from each object; what a finished walk reached is known to end at a root.
        let mut done: HashSet<SceneId> = HashSet::new();
        for o in &self.objects {
            let mut path: Vec<SceneId> = Vec::new();
            let mut on_path = HashSet::new();
            let mut at = o.id;
            while !done.contains(&at) {
                if !on_path.insert(at) {
                    let start = path.iter().position(|x| *x == at).unwrap_or(0);
                    let ring: Vec<String> = path[start..].iter().map(|x| x.0.to_string()).collect();
                    return Err(format!(
                        "the parents of objects {} form a cycle",
                        ring.join(", ")
                    ));
                }
                path.push(at);
                match parent.get(&at) {
                    Some(&p) => at = p,
                    None => break,
                }
            }
            done.extend(path);
        }
        Ok(())
    }
}

/// Parses and checks a project's text; `path` names it in errors.
pub fn read_project_str(text: &str, path: &Path) -> Result<ProjectFile, ProjectError> {
    let project: ProjectFile =
        ron::from_str(text).map_err(|e| ProjectError::Format(path.to_owned(), e.to_string()))?;
    project
        .validate()
        .map_err(|e| ProjectError::Format(path.to_owned(), e))?;
    Ok(project)
}

/// Reads and checks a project file (nothing in the scene changes).
pub fn read_project(path: &Path) -> Result<ProjectFile, ProjectError> {
    let io = |e: std::io::Error| ProjectError::Io(path.to_owned(), e.to_string());
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(ProjectError::Io(
            path.to_owned(),
            "not a regular file".into(),
        ));
    }
    if meta.len() > MAX_PROJECT_BYTES {
        return Err(ProjectError::Format(
            path.to_owned(),
            format!("{} bytes is larger than a project can be", meta.len()),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(io)?;
    read_project_str(&text, path)
}

/// A source path as the project resolves it: relative ones against the project's folder.
pub fn resolve_source(project: &Path, source: &Path) -> PathBuf {
    if source.is_absolute() {
        source.to_owned()
    } else {
        project.parent().unwrap_or(Path::new(".")).join(source)
    }
}

/// A source path as the project stores it: relative to the project's folder when inside it.
pub fn store_source(project: &Path, source: &Path) -> PathBuf {
    let dir = project.parent().unwrap_or(Path::new("."));
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_owned());
    let (dir, source_abs) = (abs(dir), abs(source));
    match source_abs.strip_prefix(&dir) {
        Ok(rel) => rel.to_owned(),
        Err(_) => source_abs,
    }
}

/// Checks that a source can be a scene file: a known extension, and not a directory or a device.
/// `Ok(false)` when it does not exist (a missing source, which the project keeps).
fn check_source(path: &Path) -> Result<bool, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("gltf" | "glb" | "obj" | "ply")) {
        return Err("is not a .gltf, .glb, .obj or .ply file".into());
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(true),
        Ok(_) => Err("is not a regular file".into()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(e.to_string()),
    }
}

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
    let camera = {
        let mut cams = world.query::<&OrbitCamera>();
        cams.iter(world).next().map(|o| CameraValue {
            focus: o.focus.to_array(),
            radius: o.radius,
            yaw: o.yaw,
            pitch: o.pitch,
        })
    };
    let project = ProjectFile {
        version: PROJECT_VERSION,
        sources: sources.iter().map(|s| store_source(path, s)).collect(),
        objects,
        deleted,
        camera,
    };
    (project, unsaved)
}

/// A project as the text of its file.
pub fn project_text(project: &ProjectFile) -> Result<String, ron::Error> {
    ron::ser::to_string_pretty(project, ron::ser::PrettyConfig::default())
}

/// Writes `project` to `path` atomically ([`crate::atomic_file`]: a temporary file of a unique
/// name beside it, flushed, renamed over it, the folder flushed; a link's destination written).
pub fn write_project(path: &Path, project: &ProjectFile) -> Result<(), ProjectError> {
    let text =
        project_text(project).map_err(|e| ProjectError::Format(path.to_owned(), e.to_string()))?;
    crate::atomic_file::write_atomically(path, text.as_bytes())
        .map_err(|e| ProjectError::Io(path.to_owned(), e.to_string()))
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
    for (p, _) in &state.missing_deleted {
        add(p);
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
    let owner = world.resource::<ProjectState>().path.clone();
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
    world.resource_mut::<ProjectState>().path = owner;
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
        world.entity_mut(e).insert(MeshMaterial3d(unique));
    } else if let Some(mut m) = materials.get_mut(&handle) {
        value.write(&mut m);
    }
}

/// Opens the project at `path` in place of the scene. Everything that can fail is read and checked
/// first: on an error the scene is untouched. Missing or unreadable sources do not fail the open;
/// the report lists them and their objects stay in the project.
pub fn open_project(world: &mut World, path: &Path) -> Result<OpenReport, ProjectError> {
    let project = read_project(path)?;
    open_project_value(world, project, path)
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
    parsed: Vec<Option<treelight_import::ImportedScene>>,
    report: OpenReport,
}

impl ParsedSources {
    /// Each source's scene, in the project's order (`None` for a missing or unreadable one).
    pub fn scenes(&self) -> &[Option<treelight_import::ImportedScene>] {
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
    let mut parsed: Vec<Option<treelight_import::ImportedScene>> = Vec::new();
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
            }
            Ok(true) => match treelight_import::load_scene(file) {
                Ok(scene) => parsed.push(Some(scene)),
                Err(e) => {
                    report.missing_sources.push((file.clone(), e.to_string()));
                    parsed.push(None);
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
        mut report,
    } = sources;

    // The new scene replaces the old one, with a fresh history.
    let mut q = world.query_filtered::<Entity, (With<SceneObject>, Without<ChildOf>)>();
    for e in q.iter(world).collect::<Vec<_>>() {
        world.entity_mut(e).despawn();
    }
    let mut q = world.query_filtered::<Entity, With<SceneObject>>();
    for e in q.iter(world).collect::<Vec<_>>() {
        world.entity_mut(e).despawn();
    }
    *world.resource_mut::<EditHistory>() = EditHistory::default();
    world.resource_mut::<Selection>().clear();
    world.resource_mut::<SourceCatalog>().0.clear();
    // Fresh ids for the sources' nodes never collide with the project's.
    let top = project
        .objects
        .iter()
        .map(|o| o.id)
        .max()
        .unwrap_or(SceneId::NEW);
    {
        let mut index = world.resource_mut::<SceneIndex>();
        index.reserve_through(top);
        // Objects kept while their source is missing are not in the scene, but hold their ids.
        for o in &project.objects {
            index.retire(o.id);
        }
    }

    let mut nodes: HashMap<(usize, String), Entity> = HashMap::new();
    for (i, scene) in parsed.iter().enumerate() {
        let Some(scene) = scene else { continue };
        if crate::import::spawn_scene_in_world(
            world,
            &resolved[i],
            scene,
            &mut crate::import::Prebuilt::default(),
            false,
        )
        .is_err()
        {
            continue;
        }
        let mut q = world.query::<(Entity, &SourceKey)>();
        for (e, k) in q.iter(world) {
            if k.file == resolved[i] {
                nodes.insert((i, k.key.clone()), e);
            }
        }
    }

    let mut state = ProjectState {
        path: Some(path.to_owned()),
        ..default()
    };
    let missing_source = |n: &SourceNode| parsed[n.source].is_none();
    let mut by_id: HashMap<SceneId, Entity> = HashMap::new();
    let mut shape_meshes: HashMap<Primitive, Handle<Mesh>> = HashMap::new();
    let mut shared_materials: HashMap<String, Handle<StandardMaterial>> = HashMap::new();
    let mut made_material = |world: &mut World, value: &MaterialValue, base: StandardMaterial| {
        let key = format!("{value:?}");
        if let Some(h) = shared_materials.get(&key) {
            return h.clone();
        }
        let mut m = base;
        value.write(&mut m);
        let h = world.resource_mut::<Assets<StandardMaterial>>().add(m);
        shared_materials.insert(key, h.clone());
        h
    };
    for o in &project.objects {
        let entity = match &o.kind {
            ObjectKind::Node(n) | ObjectKind::MeshOf(n) if missing_source(n) => {
                state.missing.push(o.clone());
                continue;
            }
            ObjectKind::Node(n) => match nodes.get(&(n.source, n.key.clone())) {
                Some(e) => {
                    let e = *e;
                    if let Some(value) = &o.material {
                        apply_node_material(world, e, value);
                    }
                    e
                }
                None => {
                    report.missing_nodes += 1;
                    state.missing.push(o.clone());
                    continue;
                }
            },
            ObjectKind::MeshOf(n) => {
                let Some(&origin) = nodes.get(&(n.source, n.key.clone())) else {
                    report.missing_nodes += 1;
                    state.missing.push(o.clone());
                    continue;
                };
                let (Some(mesh), Some(material)) = (
                    world.get::<Mesh3d>(origin).cloned(),
                    world
                        .get::<MeshMaterial3d<StandardMaterial>>(origin)
                        .cloned(),
                ) else {
                    report.missing_nodes += 1;
                    state.missing.push(o.clone());
                    continue;
                };
                let source_key = SourceKey {
                    file: resolved[n.source].clone(),
                    key: n.key.clone(),
                };
                let e = world
                    .spawn((SceneObject, mesh, material, MeshSource(source_key)))
                    .id();
                // A copy shares its original's material until one of them was made unique.
                if let Some(value) = &o.material {
                    apply_node_material(world, e, value);
                }
                e
            }
            ObjectKind::Shape(shape) => {
                let mesh = shape_meshes
                    .entry(*shape)
                    .or_insert_with(|| world.resource_mut::<Assets<Mesh>>().add(shape.mesh()))
                    .clone();
                let value = o
                    .material
                    .unwrap_or_else(|| MaterialValue::of(&shape.material()));
                let material = made_material(world, &value, shape.material());
                world
                    .spawn((
                        SceneObject,
                        Mesh3d(mesh),
                        MeshMaterial3d(material),
                        PrimitiveShape(*shape),
                    ))
                    .id()
            }
            ObjectKind::Light(l) => {
                let [r, g, b] = l.color;
                let color = Color::srgb(r, g, b);
                let mut e = world.spawn(SceneObject);
                match l.kind {
                    LightKind::Point => e.insert(PointLight {
                        color,
                        intensity: l.intensity,
                        range: l.range.filter(|r| *r > 0.0).unwrap_or(40.0),
                        shadow_maps_enabled: l.shadows,
                        ..default()
                    }),
                    LightKind::Directional => e.insert(DirectionalLight {
                        color,
                        illuminance: l.intensity,
                        shadow_maps_enabled: l.shadows,
                        ..default()
                    }),
                };
                e.id()
            }
            ObjectKind::Empty => world.spawn((SceneObject, Visibility::default())).id(),
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
    // Parents once every object exists (a parent may come after its child).
    for o in &project.objects {
        let Some(&e) = by_id.get(&o.id) else { continue };
        match o.parent.and_then(|p| by_id.get(&p)) {
            Some(&p) if p != e => {
                world.entity_mut(e).insert(ChildOf(p));
            }
            _ => {
                world.entity_mut(e).remove::<ChildOf>();
            }
        }
    }
    // Deleted nodes go last: their children the user moved elsewhere are elsewhere by now.
    for d in &project.deleted {
        if parsed[d.source].is_none() {
            state
                .missing_deleted
                .push((resolved[d.source].clone(), d.key.clone()));
        } else if let Some(&e) = nodes.get(&(d.source, d.key.clone()))
            && world.get_entity(e).is_ok()
        {
            world.entity_mut(e).despawn();
        }
    }
    state.missing_sources = resolved.clone();
    if let Some(c) = project.camera {
        let mut cams = world.query::<&mut OrbitCamera>();
        if let Some(mut o) = cams.iter_mut(world).next() {
            o.focus = Vec3::from_array(c.focus);
            o.radius = c.radius.clamp(0.05, 1.0e5);
            o.yaw = c.yaw;
            o.pitch = c.pitch.clamp(-1.55, 1.55);
        }
    }
    // Every node a source had when it was imported, deleted or not.
    for (i, scene) in parsed.iter().enumerate() {
        if let Some(scene) = scene {
            world
                .resource_mut::<SourceCatalog>()
                .0
                .insert(resolved[i].clone(), crate::import::source_keys(scene));
        }
    }
    world.insert_resource(state);
    world.resource_mut::<EditHistory>().mark_saved();
    Ok(report)
}
