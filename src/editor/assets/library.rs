//! The Assets panel's folders: the scene files in each folder the user added (and in the built-in
//! samples folder), kept current by a file watcher, each with a small shaded thumbnail that the
//! engine ray-casts on a worker thread.

use crate::editor::core::file_requests::FileChosen;
use crate::editor::core::palette_payload::FileReadAhead;
use crate::editor::core::rest::{Activity, ActivitySources, Waker};
use bevy::prelude::*;
use bevy::tasks::futures_lite::future::{block_on, poll_once};
use bevy::tasks::{AsyncComputeTaskPool, Task};
use notify::{RecommendedWatcher, RecursiveMode, Watcher};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, channel};
use std::time::SystemTime;
use treelight_bvh::glam::Vec3;
use treelight_bvh::{Bvh, Ray, TopDown, Triangle};
use treelight_document::import::parse::ContentHashes;
use treelight_document::scene::notice::Notices;

/// Side of a thumbnail, pixels.
pub const THUMBNAIL: u32 = 72;

/// Files up to this many triangles are kept as read, for a ghost while dragged.
pub const GHOST_TRIANGLES: usize = 500_000;

/// The extensions the panel lists.
const SCENE_FILES: [&str; 4] = ["gltf", "glb", "obj", "ply"];

/// Whether `path` names a scene file the importer reads.
pub fn is_scene_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| SCENE_FILES.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// The scene files directly in `dir`, sorted by name.
pub fn scene_files(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && is_scene_file(p))
        .collect();
    files.sort();
    Ok(files)
}

/// A folder in the panel.
#[derive(Debug, Clone)]
pub struct LibraryFolder {
    /// The folder.
    pub path: PathBuf,
    /// Its scene files, as of the last look.
    pub files: Vec<PathBuf>,
    /// Why it cannot be listed, if it cannot.
    pub error: Option<String>,
    /// Built in (the samples): not removable, not saved in the settings.
    pub built_in: bool,
}

/// A thumbnail, as the worker made it.
#[derive(Clone, Debug)]
pub struct ThumbnailImage {
    /// `THUMBNAIL`² RGBA pixels, sRGB, rows from the top.
    pub rgba: Vec<u8>,
    /// Triangles in the file.
    pub triangles: usize,
    /// The file as read, kept for the ghost a drag over the viewport shows (not for files over
    /// [`GHOST_TRIANGLES`], which are imported on drop without one rather than held in memory).
    pub scene: Option<std::sync::Arc<treelight_import::ImportedScene>>,
    /// The content of its meshes and textures, so that placing it again finds them in the scene
    /// without hashing them on the main thread (empty without `scene`).
    pub hashes: ContentHashes,
    /// The file's world-space bounds, for placing it (made here, not in each frame of a drag).
    pub bounds: (Vec3, Vec3),
}

/// A file's thumbnail state.
#[derive(Clone, Debug)]
pub enum Thumbnail {
    /// Being made.
    Pending,
    /// Made (`version` rises with each remake, so a UI knows to reload its texture).
    Ready {
        /// The picture.
        image: ThumbnailImage,
        /// Raised each time the file's thumbnail is made again.
        version: u32,
    },
    /// The file would not open.
    Failed(String),
}

/// A thumbnail being made: the file, its date when asked, the task.
type ThumbnailJob = (
    PathBuf,
    Option<SystemTime>,
    Task<Result<ThumbnailImage, String>>,
);

/// The panel's folders, their files and their thumbnails.
#[derive(Resource)]
pub struct AssetLibrary {
    /// Folders, built-in first.
    pub folders: Vec<LibraryFolder>,
    /// Thumbnails by file.
    pub thumbnails: HashMap<PathBuf, Thumbnail>,
    jobs: Vec<ThumbnailJob>,
    made: HashMap<PathBuf, Option<SystemTime>>,
    watcher: Option<RecommendedWatcher>,
    events: Mutex<Receiver<notify::Result<notify::Event>>>,
    version: u32,
    /// A folder was added or changed since the files' dates were last looked at.
    stale: bool,
}

impl Default for AssetLibrary {
    /// A library whose watcher wakes no window loop.
    fn default() -> Self {
        Self::waking(Waker::default())
    }
}

impl AssetLibrary {
    /// An empty library whose watcher, seeing a change, wakes a resting editor through `waker`.
    pub fn waking(waker: Waker) -> Self {
        let (tx, rx) = channel();
        // No watcher (an exotic file system): folders are then listed when added, not refreshed.
        let watcher = notify::recommended_watcher(move |e| {
            let _ = tx.send(e);
            waker.wake();
        })
        .ok();
        Self {
            folders: Vec::new(),
            thumbnails: HashMap::new(),
            jobs: Vec::new(),
            made: HashMap::new(),
            watcher,
            events: Mutex::new(rx),
            version: 0,
            stale: false,
        }
    }

    /// Adds a folder (once), lists it and watches it.
    pub fn add_folder(&mut self, path: PathBuf, built_in: bool) {
        if self.folders.iter().any(|f| f.path == path) {
            return;
        }
        if let Some(w) = self.watcher.as_mut() {
            let _ = w.watch(&path, RecursiveMode::NonRecursive);
        }
        let mut folder = LibraryFolder {
            path,
            files: Vec::new(),
            error: None,
            built_in,
        };
        relist(&mut folder);
        self.folders.push(folder);
        self.stale = true;
    }

    /// Removes a folder the user added.
    pub fn remove_folder(&mut self, path: &Path) {
        if let Some(w) = self.watcher.as_mut() {
            let _ = w.unwatch(path);
        }
        self.folders.retain(|f| f.built_in || f.path != path);
    }

    /// The folders the user added, for the settings file.
    pub fn user_folders(&self) -> Vec<PathBuf> {
        self.folders
            .iter()
            .filter(|f| !f.built_in)
            .map(|f| f.path.clone())
            .collect()
    }

    /// Lists again every folder the watcher saw change; starts thumbnails for files without a
    /// current one; collects finished thumbnails. Returns whether anything changed.
    pub fn refresh(&mut self) -> bool {
        let mut changed = false;
        let mut touched: Vec<PathBuf> = Vec::new();
        if let Ok(events) = self.events.lock() {
            while let Ok(event) = events.try_recv() {
                if let Ok(event) = event {
                    touched.extend(event.paths);
                }
            }
        }
        if !touched.is_empty() {
            for folder in &mut self.folders {
                if touched
                    .iter()
                    .any(|p| p.parent() == Some(folder.path.as_path()))
                {
                    relist(folder);
                    changed = true;
                    self.stale = true;
                }
            }
        }
        // Thumbnails for new or modified files (their dates read only after a change was seen).
        let folders = if std::mem::take(&mut self.stale) {
            self.folders.as_slice()
        } else {
            &[]
        };
        for folder in folders {
            for file in &folder.files {
                let modified = std::fs::metadata(file).and_then(|m| m.modified()).ok();
                let current = self.made.get(file) == Some(&modified)
                    || self
                        .jobs
                        .iter()
                        .any(|(p, m, _)| p == file && *m == modified);
                if !current {
                    self.made.insert(file.clone(), modified);
                    self.thumbnails
                        .entry(file.clone())
                        .or_insert(Thumbnail::Pending);
                    let p = file.clone();
                    // A file that crashes the reader is marked failed, not fatal.
                    let task = AsyncComputeTaskPool::get().spawn(async move {
                        treelight_document::files::contain::contain(
                            || format!("reading {}", p.display()),
                            || render_thumbnail(&p),
                        )
                        .unwrap_or_else(Err)
                    });
                    self.jobs.push((file.clone(), modified, task));
                }
            }
        }
        let mut i = 0;
        while i < self.jobs.len() {
            match block_on(poll_once(&mut self.jobs[i].2)) {
                Some(result) => {
                    let (file, _, _) = self.jobs.swap_remove(i);
                    self.version += 1;
                    let t = match result {
                        Ok(image) => Thumbnail::Ready {
                            image,
                            version: self.version,
                        },
                        Err(e) => Thumbnail::Failed(e),
                    };
                    self.thumbnails.insert(file, t);
                    changed = true;
                }
                None => i += 1,
            }
        }
        changed
    }

    /// The file as read for its thumbnail, once it has been (and was small enough to keep).
    pub fn read_ahead(&self, file: &Path) -> Option<FileReadAhead> {
        match self.thumbnails.get(file) {
            Some(Thumbnail::Ready { image, .. }) => {
                image.scene.clone().map(|scene| FileReadAhead {
                    scene,
                    hashes: image.hashes.clone(),
                    bounds: image.bounds,
                })
            }
            _ => None,
        }
    }

    /// Whether thumbnails are still being made.
    pub fn busy(&self) -> bool {
        !self.jobs.is_empty()
    }
}

fn relist(folder: &mut LibraryFolder) {
    match scene_files(&folder.path) {
        Ok(files) => {
            folder.files = files;
            folder.error = None;
        }
        Err(e) => {
            folder.files.clear();
            folder.error = Some(e);
        }
    }
}

/// The most memory reading a file for its thumbnail may take: the files of an Assets folder are
/// read at every start, so one that claims gigabytes is refused for its preview at this much,
/// not at half the free memory (dragged in, it is read again under the import's own budget).
const THUMBNAIL_BUDGET: u64 = 1 << 30;

/// Opens `path` (within `THUMBNAIL_BUDGET`), builds a tree over its triangles and ray-casts a
/// shaded picture of it from above one corner (a key light and a sky term; the background
/// transparent).
pub fn render_thumbnail(path: &Path) -> Result<ThumbnailImage, String> {
    let options = treelight_import::ImportOptions {
        memory_budget: treelight_import::default_memory_budget().min(THUMBNAIL_BUDGET),
    };
    let scene = treelight_import::load_scene_with(path, &options).map_err(|e| e.to_string())?;
    let triangles: Vec<Triangle> = scene
        .world_triangles()
        .into_iter()
        .map(|[a, b, c]| Triangle::new(a, b, c))
        .collect();
    if triangles.is_empty() {
        return Err(format!("{}: no triangles", path.display()));
    }
    let bvh = Bvh::build_top_down(&triangles, TopDown::BinnedSah, Default::default())
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let b = bvh.bounds();
    let centre = (b.min + b.max) * 0.5;
    let radius = ((b.max - b.min).length() * 0.5).max(1e-6);
    let dir = Vec3::new(-0.55, -0.45, -0.7).normalize();
    let eye = centre - dir * radius * 3.0;
    let right = dir.cross(Vec3::Y).normalize_or(Vec3::X);
    let up = right.cross(dir);
    // The bounding sphere fills the picture at this field of view.
    let half = (radius / (radius * 3.0)).atan().tan() * 1.08;
    let light = Vec3::new(0.4, 0.8, 0.45).normalize();
    let n = THUMBNAIL as usize;
    let mut rgba = vec![0u8; n * n * 4];
    for y in 0..n {
        for x in 0..n {
            let u = ((x as f32 + 0.5) / n as f32 * 2.0 - 1.0) * half;
            let v = (1.0 - (y as f32 + 0.5) / n as f32 * 2.0) * half;
            let d = (dir + right * u + up * v).normalize();
            let Some(hit) = bvh.closest_hit(&Ray::new(eye, d)) else {
                continue;
            };
            let Some(t) = bvh.hit_world_triangle(&hit) else {
                continue;
            };
            let mut normal = t.normal().normalize_or_zero();
            if normal.dot(d) > 0.0 {
                normal = -normal;
            }
            let shade = 0.22 + 0.12 * (normal.y * 0.5 + 0.5) + 0.66 * normal.dot(light).max(0.0);
            let c = (shade.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
            let px = &mut rgba[(y * n + x) * 4..][..4];
            px.copy_from_slice(&[c, c, (c as f32 * 0.96) as u8, 255]);
        }
    }
    let kept = triangles.len() <= GHOST_TRIANGLES;
    Ok(ThumbnailImage {
        rgba,
        triangles: triangles.len(),
        bounds: treelight_document::import::parse::scene_bounds(&scene).unwrap_or((b.min, b.max)),
        hashes: if kept {
            ContentHashes::of(&scene)
        } else {
            ContentHashes::default()
        },
        scene: kept.then(|| std::sync::Arc::new(scene)),
    })
}

/// Looks at the watched folders and the thumbnail jobs once a frame.
pub fn refresh_library(mut library: ResMut<AssetLibrary>) {
    library.refresh();
}

/// Thumbnails being made keep the editor drawing until they are in.
pub fn thumbnails_activity(library: Res<AssetLibrary>, mut activity: ResMut<Activity>) {
    if library.busy() {
        activity.busy("thumbnails");
    }
}

/// Adds the folders the user chose (Assets → Add folder…) to the panel.
pub fn add_chosen_folders(
    mut library: ResMut<AssetLibrary>,
    mut chosen: MessageReader<FileChosen>,
    mut notices: ResMut<Notices>,
) {
    for chosen in chosen.read() {
        let FileChosen::AssetFolder(dir) = chosen else {
            continue;
        };
        let dir = dir.clone();
        if dir.is_dir() {
            library.add_folder(dir, false);
        } else {
            notices.error(format!("{}: not a folder", dir.display()));
        }
    }
}

/// The built-in samples' folder: the repository's `assets/samples`, made by
/// `src/editor/assets/samples.rs`.
pub fn samples_folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/samples")
}

/// The panel's folders: the built-in samples at start, the user's from the settings, and a look at
/// all of them every frame.
pub struct AssetLibraryPlugin;

impl Plugin for AssetLibraryPlugin {
    fn build(&self, app: &mut App) {
        // The core's waker (its loop is started later; clones made now wake it then).
        let waker = app
            .world()
            .get_resource::<Waker>()
            .cloned()
            .unwrap_or_default();
        app.insert_resource(AssetLibrary::waking(waker))
            .add_systems(Startup, add_samples)
            .add_systems(Update, (add_chosen_folders, refresh_library))
            .add_systems(Last, thumbnails_activity.in_set(ActivitySources));
    }
}

/// Adds the built-in samples' folder to the panel.
pub fn add_samples(mut library: ResMut<AssetLibrary>) {
    let samples = samples_folder();
    if samples.is_dir() {
        library.add_folder(samples, true);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::tasks::TaskPool;
    use std::time::{Duration, Instant};

    fn wait(library: &mut AssetLibrary, what: &str, done: impl Fn(&AssetLibrary) -> bool) {
        let start = Instant::now();
        while !done(library) {
            library.refresh();
            assert!(start.elapsed() < Duration::from_secs(20), "{what}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    #[test]
    fn folders_follow_their_files_and_every_file_gets_a_thumbnail() {
        AsyncComputeTaskPool::get_or_init(TaskPool::default);
        let dir = std::env::temp_dir().join(format!("treelight-library-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let samples = samples_folder();
        std::fs::copy(samples.join("stairs.obj"), dir.join("stairs.obj")).unwrap();
        std::fs::write(dir.join("notes.txt"), "not a scene").unwrap();
        std::fs::write(dir.join("broken.obj"), "v 1 2\nf 1 2 9\n").unwrap();
        let mut library = AssetLibrary::default();
        library.add_folder(dir.clone(), false);
        let names = |l: &AssetLibrary| -> Vec<String> {
            l.folders[0]
                .files
                .iter()
                .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
                .collect()
        };
        assert_eq!(names(&library), ["broken.obj", "stairs.obj"]);
        // The thumbnail: the stairs in the middle, transparent corners; the broken file says why.
        wait(&mut library, "thumbnails", |l| {
            !l.busy() && l.thumbnails.len() == 2
        });
        let Some(Thumbnail::Ready { image, .. }) = library.thumbnails.get(&dir.join("stairs.obj"))
        else {
            panic!("{:?}", library.thumbnails);
        };
        let n = THUMBNAIL as usize;
        let alpha = |x: usize, y: usize| image.rgba[(y * n + x) * 4 + 3];
        assert_eq!(alpha(n / 2, n / 2), 255);
        assert_eq!(alpha(0, 0), 0);
        assert_eq!(alpha(n - 1, 0), 0);
        let covered = image.rgba.chunks(4).filter(|p| p[3] == 255).count();
        assert!(covered > n * n / 8, "the stairs cover {covered} pixels");
        assert!(matches!(
            library.thumbnails.get(&dir.join("broken.obj")),
            Some(Thumbnail::Failed(e)) if e.contains("broken.obj")
        ));
        // A file added, then one removed: the watcher brings the list up to date.
        std::fs::copy(samples.join("arch.obj"), dir.join("arch.obj")).unwrap();
        wait(&mut library, "the new file", |l| names(l).len() == 3);
        assert_eq!(names(&library), ["arch.obj", "broken.obj", "stairs.obj"]);
        std::fs::remove_file(dir.join("broken.obj")).unwrap();
        wait(&mut library, "the removal", |l| names(l).len() == 2);
        wait(&mut library, "the new thumbnail", |l| {
            matches!(
                l.thumbnails.get(&dir.join("arch.obj")),
                Some(Thumbnail::Ready { .. })
            )
        });
        assert_eq!(library.user_folders(), std::slice::from_ref(&dir));
        library.remove_folder(&dir);
        assert!(library.folders.is_empty());
        std::fs::remove_dir_all(&dir).ok();
    }
}
