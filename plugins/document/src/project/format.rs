//! Projects: a `.treelight` file (RON, versioned) that holds references to the scene files it was
//! built from, what the user changed of their nodes (keyed by source keys: transform, parent,
//! visibility, name, material values, deletions), the ids of the nodes left as they were (runs of
//! consecutive ids), the objects added in the editor (shapes, lights, groups, copies of imported
//! meshes), the camera, the look (exposure and tone curve) and the sky panorama; never a copy of the geometry, and no line per unchanged node, so a
//! project grows with the edits, not the sources. Opening one imports its sources again and
//! applies the rest (`restore.rs`); a file imported several times is listed once per
//! import, each its own source with its own edits and ids. Saving writes a temporary file beside the target,
//! flushes it and renames it over the target (`capture.rs`). Version 1 files, which list
//! every node, version 2 files, without a look, and version 3 files, without a sky panorama,
//! still open.

use crate::edit::command::{MaterialValue, TransformValue, in_range};
pub use crate::scene::outbox::CameraValue;
pub use crate::values::light::LightValue;
use crate::values::object::SceneId;
use crate::values::primitive::Primitive;
use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// The version this editor writes.
pub const PROJECT_VERSION: u32 = 4;
/// The oldest version it reads (1 listed every source node as an object; 2 had no look; 3 no
/// sky panorama).
pub const OLDEST_VERSION: u32 = 1;

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
    /// Its light's values, for a source node (or a copy of one) that is a light; a light made in
    /// the editor has them in its kind.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light: Option<LightValue>,
}

fn shown() -> bool {
    true
}

/// Consecutive source nodes with consecutive ids: the nodes at key indices `index` to
/// `index + count - 1` of a source ([`crate::scene::spawn::source_keys`] order) have ids `id` to
/// `id + count - 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct IdRun(pub u32, pub SceneId, pub u32);

impl IdRun {
    /// The first key index, the first id and how many.
    pub fn parts(self) -> (usize, u64, u64) {
        (self.0 as usize, self.1.0, u64::from(self.2))
    }
}

/// The ids of a source's nodes that the project does not list as objects (those the user left as
/// they were), and which list of keys they belong to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SourceIds {
    /// Index into the project's sources.
    pub source: usize,
    /// [`keys_hash`] of the source's keys when saved: a file whose nodes changed since (it was
    /// exported again) gives its unlisted nodes fresh ids instead of another node's.
    pub keys: u64,
    /// The runs of ids.
    pub runs: Vec<IdRun>,
}

/// A fingerprint of a source's node keys, stable across runs and builds (FNV-1a over the keys,
/// each ended by a zero byte).
pub fn keys_hash<'a>(keys: impl IntoIterator<Item = &'a str>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for k in keys {
        for b in k.bytes().chain([0]) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// A project file's contents.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProjectFile {
    /// The format's version.
    pub version: u32,
    /// Scene files, relative to the project's folder when inside it.
    #[serde(default)]
    pub sources: Vec<PathBuf>,
    /// The ids of the source nodes not listed in `objects` (version 2; version 1 lists them all).
    #[serde(default)]
    pub source_ids: Vec<SourceIds>,
    /// The scene's objects, by id: each source's root and the nodes the user changed, and every
    /// object made in the editor.
    #[serde(default)]
    pub objects: Vec<ProjectObject>,
    /// Source nodes the user deleted.
    #[serde(default)]
    pub deleted: Vec<SourceNode>,
    /// The camera.
    #[serde(default)]
    pub camera: Option<CameraValue>,
    /// The exposure and tone curve (version 3; older projects have the defaults).
    #[serde(default)]
    pub look: Option<crate::values::look::SceneLook>,
    /// The sky panorama, its file relative to the project's folder when inside it (version 4;
    /// older projects have none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub environment: Option<crate::scene::environment::SceneEnvironment>,
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
    /// Deleted source nodes of missing sources (by index into `missing_sources`), kept likewise.
    pub missing_deleted: Vec<(usize, String)>,
    /// The node ids of missing sources (their indices into `missing_sources`), kept likewise.
    pub missing_ids: Vec<SourceIds>,
    /// The project's file as this editor last read or wrote it, to tell when something else
    /// (another editor) has written it since.
    pub on_disk: Option<FileStamp>,
}

impl ProjectState {
    /// Whether the project's file has been written by someone else since this editor read or
    /// wrote it (a file that is gone has not).
    pub fn changed_on_disk(&self) -> bool {
        self.path
            .as_deref()
            .and_then(FileStamp::of)
            .is_some_and(|now| Some(now) != self.on_disk)
    }
}

/// What tells one version of a file from another without reading it: its modification time,
/// length and (on Unix) its inode, which an atomic save replaces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FileStamp {
    modified: Option<std::time::SystemTime>,
    len: u64,
    inode: u64,
}

impl FileStamp {
    /// The stamp of the file at `path` now, if there is one.
    pub fn of(path: &Path) -> Option<Self> {
        let m = std::fs::metadata(path).ok()?;
        #[cfg(unix)]
        let inode = std::os::unix::fs::MetadataExt::ino(&m);
        #[cfg(not(unix))]
        let inode = 0;
        Some(Self {
            modified: m.modified().ok(),
            len: m.len(),
            inode,
        })
    }
}

/// What opening a project found missing, for the user.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct OpenReport {
    /// Sources that are gone or unreadable, with the reason.
    pub missing_sources: Vec<(PathBuf, String)>,
    /// Objects whose node no longer exists in its (readable) source.
    pub missing_nodes: usize,
    /// Their names (the first few).
    pub missing_names: Vec<String>,
    /// Sources whose nodes changed since the project was saved: their unchanged nodes got new ids.
    pub changed_sources: Vec<PathBuf>,
}

impl ProjectFile {
    /// Checks what a file could get wrong: version, sizes, numbers, ids, references.
    pub fn validate(&self) -> Result<(), String> {
        if !(OLDEST_VERSION..=PROJECT_VERSION).contains(&self.version) {
            return Err(format!(
                "version {} is not one this editor reads ({OLDEST_VERSION} to {PROJECT_VERSION})",
                self.version
            ));
        }
        if self.look.is_some_and(|l| !l.is_valid()) {
            return Err(format!(
                "its exposure is not finite or beyond ±{} stops, or its sky is out of range",
                crate::values::look::MAX_EXPOSURE_STOPS
            ));
        }
        if self.environment.as_ref().is_some_and(|e| !e.is_valid()) {
            return Err(
                "its sky panorama is not a .hdr or .exr file, or its rotation or intensity is out \
                 of range"
                    .into(),
            );
        }
        if self.sources.len() > MAX_SOURCES || self.objects.len() > MAX_OBJECTS {
            return Err("it names more sources or objects than a project can hold".into());
        }
        let mut ids = self.run_ids()?;
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
                _ if o.light.is_some_and(|l| !l.is_valid()) => {
                    return Err(format!("object {} has a light out of range", o.id.0));
                }
                ObjectKind::Light(l) if !l.is_valid() => {
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
    /// Every id the runs give, checked: sources the project lists, ids in range, no more than a
    /// project can hold, none given twice.
    fn run_ids(&self) -> Result<HashSet<SceneId>, String> {
        let mut ids = HashSet::new();
        let mut total = 0u64;
        for s in &self.source_ids {
            if s.source >= self.sources.len() {
                return Err(format!(
                    "the ids of source {} are listed, which the project does not list",
                    s.source
                ));
            }
            for run in &s.runs {
                let (_, first, count) = run.parts();
                total += count;
                if total > (MAX_OBJECTS - self.objects.len()) as u64 {
                    return Err("its runs of ids name more objects than a project can hold".into());
                }
                if count == 0 || first == 0 || first + count - 1 > SceneId::MAX.0 {
                    return Err(format!(
                        "a run of {count} ids from {first} is outside the range of ids (1 to {})",
                        SceneId::MAX.0
                    ));
                }
                for id in first..first + count {
                    if !ids.insert(SceneId(id)) {
                        return Err(format!("object id {id} is used twice"));
                    }
                }
            }
        }
        Ok(ids)
    }

    /// The largest id the project holds, objects and runs together.
    pub fn top_id(&self) -> SceneId {
        let runs = self
            .source_ids
            .iter()
            .flat_map(|s| &s.runs)
            .map(|r| SceneId(r.1.0 + u64::from(r.2).saturating_sub(1)));
        self.objects
            .iter()
            .map(|o| o.id)
            .chain(runs)
            .max()
            .unwrap_or(SceneId::NEW)
    }

    /// Refuses parents that are the object itself, that no object of the file has (listed or in a
    /// run), or that lead round in a cycle among the listed objects. (A cycle through a source's
    /// own hierarchy shows only once the sources are read: [`check_forest`] again then.)
    fn check_parents(&self, ids: &HashSet<SceneId>) -> Result<(), String> {
        let parent: HashMap<SceneId, SceneId> = self
            .objects
            .iter()
            .filter_map(|o| Some((o.id, o.parent?)))
            .collect();
        let mut children: Vec<SceneId> = parent.keys().copied().collect();
        children.sort_unstable();
        check_forest(
            &children,
            |id| parent.get(&id).copied(),
            |id| ids.contains(&id),
        )
    }
}

/// Refuses parents that are not a forest: walking up from each of `starts` by `parent_of`, a
/// child its own parent, a parent for which `exists` is false, or a cycle.
pub(crate) fn check_forest(
    starts: &[SceneId],
    parent_of: impl Fn(SceneId) -> Option<SceneId>,
    exists: impl Fn(SceneId) -> bool,
) -> Result<(), String> {
    for &child in starts {
        match parent_of(child) {
            Some(p) if p == child => return Err(format!("object {} is its own parent", child.0)),
            Some(p) if !exists(p) => {
                return Err(format!(
                    "object {} names parent {}, which the project does not hold",
                    child.0, p.0
                ));
            }
            _ => {}
        }
    }
    // Walk up from each; what a finished walk reached is known to end at a root, at a known
    // level (1 at the top).
    let mut level: HashMap<SceneId, usize> = HashMap::new();
    for &start in starts {
        let mut path: Vec<SceneId> = Vec::new();
        let mut on_path = HashSet::new();
        let mut at = start;
        let mut below = 0;
        loop {
            if let Some(&known) = level.get(&at) {
                below = known;
                break;
            }
            if !on_path.insert(at) {
                let from = path.iter().position(|x| *x == at).unwrap_or(0);
                let ring: Vec<String> = path[from..].iter().map(|x| x.0.to_string()).collect();
                return Err(format!(
                    "the parents of objects {} form a cycle",
                    ring.join(", ")
                ));
            }
            path.push(at);
            match parent_of(at) {
                Some(p) => at = p,
                None => break,
            }
        }
        for (k, id) in path.iter().rev().enumerate() {
            let depth = below + k + 1;
            if depth > crate::scene::hierarchy::MAX_HIERARCHY_DEPTH {
                return Err(format!(
                    "object {} lies {depth} levels deep, more than the {} the editor holds",
                    id.0,
                    crate::scene::hierarchy::MAX_HIERARCHY_DEPTH
                ));
            }
            level.insert(*id, depth);
        }
    }
    Ok(())
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

/// How many bytes of memory parsing a project takes for each byte of its text, at most
/// (measured: 8.6 for a 255 MB project of objects; rounded up).
const PARSE_BYTES_PER_BYTE: u64 = 12;

/// Reads and checks a project file (nothing in the scene changes). A file that is not regular
/// is refused without blocking; one larger than a project can be, or whose parse would pass the
/// import's memory budget ([`treelight_import::default_memory_budget`]), is refused before it is
/// read.
pub fn read_project(path: &Path) -> Result<ProjectFile, ProjectError> {
    let io = |e: std::io::Error| ProjectError::Io(path.to_owned(), e.to_string());
    let (_, len) = crate::files::own_file::open_regular(path).map_err(io)?;
    let budget = treelight_import::default_memory_budget();
    if len > MAX_PROJECT_BYTES || len.saturating_mul(PARSE_BYTES_PER_BYTE) > budget {
        return Err(ProjectError::Format(
            path.to_owned(),
            format!(
                "{len} bytes is larger than a project can be (at most {MAX_PROJECT_BYTES}, and \
                 {PARSE_BYTES_PER_BYTE} times its size within the memory budget of {} MiB)",
                budget >> 20
            ),
        ));
    }
    let text = crate::files::own_file::read_text_bounded(path, len.max(1)).map_err(io)?;
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
    // A project named without a folder (`--save proj.treelight`) is in the working folder.
    let dir = project
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_owned());
    let (dir, source_abs) = (abs(dir), abs(source));
    match source_abs.strip_prefix(&dir) {
        Ok(rel) => rel.to_owned(),
        Err(_) => source_abs,
    }
}

/// Checks that a source can be a scene file: a known extension, and not a directory or a device.
/// `Ok(false)` when it does not exist (a missing source, which the project keeps).
pub(crate) fn check_source(path: &Path) -> Result<bool, String> {
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

/// A project as the text of its file.
pub fn project_text(project: &ProjectFile) -> Result<String, ron::Error> {
    ron::ser::to_string_pretty(project, ron::ser::PrettyConfig::default())
}

/// The text of `project` as a save writes it, read back in memory and checked as an open checks
/// a file (its references, ids and parents): a project that would not open again is never
/// written, and the error says why.
pub fn checked_project_text(path: &Path, project: &ProjectFile) -> Result<String, ProjectError> {
    let text =
        project_text(project).map_err(|e| ProjectError::Format(path.to_owned(), e.to_string()))?;
    if let Err(e) = read_project_str(&text, path) {
        let why = match e {
            ProjectError::Format(_, why) => why,
            other => other.to_string(),
        };
        return Err(ProjectError::Format(
            path.to_owned(),
            format!("the scene as saved would not open again ({why}); nothing was written"),
        ));
    }
    Ok(text)
}

/// Writes `project` to `path` atomically ([`crate::files::atomic_file`]: a temporary file of a unique
/// name beside it, flushed, renamed over it, the folder flushed; a link's destination written),
/// once its text has been read back and checked ([`checked_project_text`]).
pub fn write_project(path: &Path, project: &ProjectFile) -> Result<(), ProjectError> {
    let text = checked_project_text(path, project)?;
    crate::files::atomic_file::write_atomically(path, text.as_bytes())
        .map_err(|e| ProjectError::Io(path.to_owned(), e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_beside_the_project_are_stored_relative_whatever_form_they_were_given_in() {
        let cwd = std::env::current_dir().unwrap();
        for (project, source) in [
            ("proj.treelight", "model.glb"),
            ("proj.treelight", "scenes/model.glb"),
            ("./proj.treelight", "model.glb"),
        ] {
            let expected = Path::new(source);
            assert_eq!(
                store_source(Path::new(project), Path::new(source)),
                expected
            );
            let absolute = cwd.join(source);
            assert_eq!(store_source(Path::new(project), &absolute), expected);
            assert_eq!(
                store_source(&cwd.join(project), Path::new(source)),
                expected
            );
            // And it resolves back to the same file.
            assert_eq!(
                std::path::absolute(resolve_source(Path::new(project), expected)).unwrap(),
                absolute
            );
        }
        // A source outside the project's folder stays absolute.
        let outside = store_source(Path::new("proj.treelight"), Path::new("/elsewhere/m.glb"));
        assert_eq!(outside, Path::new("/elsewhere/m.glb"));
    }
}
