//! Opening scene files (command line, drag and drop): parsed on a background task by
//! `treelight_import`, then spawned as scene entities by an import command (one undoable step).
//! Errors become notices; nothing already in the scene is touched by a failed import.

use crate::camera::OrbitCamera;
use crate::notice::Notices;
use crate::scene_id::SceneId;
use crate::selection::SceneObject;
use bevy::asset::RenderAssetUsages;
use bevy::ecs::system::SystemParam;
use bevy::image::{ImageAddressMode, ImageSampler, ImageSamplerDescriptor};
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on, poll_once};
use bevy::window::FileDragAndDrop;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use treelight_import::{
    ImportError, ImportedMaterial, ImportedMesh, ImportedScene, ImportedTexture, WrapMode,
};

/// A file parsed, with its meshes and textures already made into Bevy assets (off the main thread,
/// so the frame that adds them to the scene only moves them in).
pub struct ParsedScene {
    /// What the file holds.
    pub scene: ImportedScene,
    /// Its Bevy meshes and images.
    pub parts: Prebuilt,
    /// Its world-space bounds ([`scene_bounds`]), made with the rest off the main thread.
    pub bounds: Option<(Vec3, Vec3)>,
}

/// Bevy meshes and images made from a scene ahead of spawning it; [`spawn_scene`] takes them and
/// makes whatever is missing.
#[derive(Default)]
pub struct Prebuilt {
    /// One Bevy mesh per mesh of the scene, `None` for one that repeats an earlier one (`same_as`)
    /// and for those already taken.
    pub meshes: Vec<Option<Mesh>>,
    /// The base-colour images the materials use, by texture and wrap modes.
    pub images: HashMap<(usize, [WrapMode; 2]), Image>,
    /// Each mesh's bounds (of `meshes[i]`, or of the mesh it repeats), so that Bevy need not
    /// compute them on the main thread when the objects are spawned.
    pub bounds: Vec<Option<bevy::camera::primitives::Aabb>>,
}

impl From<ImportedScene> for ParsedScene {
    fn from(scene: ImportedScene) -> Self {
        use bevy::camera::primitives::MeshAabb;
        let meshes: Vec<Option<Mesh>> = scene
            .meshes
            .iter()
            .map(|m| m.same_as.is_none().then(|| to_bevy_mesh(m)))
            .collect();
        let own: Vec<_> = meshes
            .iter()
            .map(|m| m.as_ref().and_then(MeshAabb::compute_aabb))
            .collect();
        let bounds = scene
            .meshes
            .iter()
            .enumerate()
            .map(|(i, m)| own.get(m.same_as.unwrap_or(i)).copied().flatten())
            .collect();
        let mut images = HashMap::new();
        for r in scene.materials.iter().filter_map(|m| m.base_color_texture) {
            if let Some(t) = scene.textures.get(r.texture) {
                images
                    .entry((r.texture, r.wrap))
                    .or_insert_with(|| to_bevy_image(t, r.wrap));
            }
        }
        Self {
            bounds: scene_bounds(&scene),
            scene,
            parts: Prebuilt {
                meshes,
                images,
                bounds,
            },
        }
    }
}

/// One file being parsed: its own job, so two drops of one file are two imports, each landing
/// where it was dropped.
pub struct PendingImport {
    /// The file.
    pub path: PathBuf,
    /// Where it was dropped in the window: `None` for a file opened otherwise (framed, kept in
    /// its own coordinates); `Some(None)` for a drop whose position the window system did not
    /// give (the viewport's centre).
    pub dropped_at: Option<Option<Vec2>>,
    task: Task<Result<ParsedScene, ImportError>>,
}

/// Files being parsed.
#[derive(Resource, Default)]
pub struct PendingImports(pub Vec<PendingImport>);

impl PendingImports {
    /// Starts parsing `path` (and making its Bevy meshes) in the background.
    pub fn start(&mut self, path: PathBuf) {
        self.start_at(path, None);
    }

    /// Starts parsing `path`, dropped at `dropped_at` (see [`PendingImport::dropped_at`]).
    pub fn start_at(&mut self, path: PathBuf, dropped_at: Option<Option<Vec2>>) {
        let p = path.clone();
        let task = AsyncComputeTaskPool::get().spawn(async move {
            // A bug in the importer ends this import with an error, not the editor.
            crate::contain::contain(
                || format!("importing {}", p.display()),
                || treelight_import::load_scene(&p).map(ParsedScene::from),
            )
            .unwrap_or_else(|e| {
                Err(ImportError {
                    file: p.clone(),
                    problem: e,
                })
            })
        });
        self.0.push(PendingImport {
            path,
            dropped_at,
            task,
        });
    }
}

/// Starts an import for every file dropped on the window, with where it was dropped.
pub fn import_dropped_files(
    mut drops: MessageReader<FileDragAndDrop>,
    mut pending: ResMut<PendingImports>,
    windows: Query<(&Window, Option<&bevy::window::RawHandleWrapper>)>,
) {
    for drop in drops.read() {
        if let FileDragAndDrop::DroppedFile { path_buf, window } = drop {
            // winit knows the pointer except during an X11 drag; then the X server is asked.
            let at = windows.get(*window).ok().and_then(|(w, handle)| {
                w.cursor_position().or_else(|| {
                    handle.and_then(|h| crate::x11_pointer::pointer_in(h, w.scale_factor()))
                })
            });
            pending.start_at(path_buf.clone(), Some(at));
        }
    }
}

/// Where a dropped scene's root goes: its bounds' bottom centre on `surface` by the placement rule
/// (the file's own coordinates otherwise kept: the root only moves).
pub fn drop_transform(bounds: (Vec3, Vec3), surface: crate::placement::Surface) -> Transform {
    Transform::from_translation(crate::placement::place_on(
        surface,
        bounds.0,
        bounds.1,
        Vec3::ONE,
    ))
}

/// Filter for entities that light the scene.
pub type AnyLight = Or<(With<DirectionalLight>, With<PointLight>)>;

/// Files parsed in the background and not yet in the scene, by the id their import command gives
/// its root: the command takes its scene from here (and parses the file itself when a script or a
/// redo names one that is not).
#[derive(Resource, Default)]
pub struct ParsedImports(pub HashMap<SceneId, ParsedScene>);

/// Hands each parsed file to the history as an import command (one undoable step), and frames
/// the camera on it.
#[allow(clippy::too_many_arguments)]
pub fn finish_imports(
    mut pending: ResMut<PendingImports>,
    mut parsed_imports: ResMut<ParsedImports>,
    mut index: ResMut<crate::scene_id::SceneIndex>,
    mut requests: ResMut<crate::edit::EditRequests>,
    mut notices: ResMut<Notices>,
    mut orbit: Query<&mut OrbitCamera>,
    cameras: Query<(&Camera, &GlobalTransform), With<OrbitCamera>>,
    bvh: Res<treelight_scene::SceneBvh>,
    mut jobs: ResMut<crate::import_jobs::TracingImports>,
) {
    let mut i = 0;
    while i < pending.0.len() {
        let Some(result) = block_on(poll_once(&mut pending.0[i].task)) else {
            i += 1;
            continue;
        };
        let PendingImport {
            path, dropped_at, ..
        } = pending.0.remove(i);
        match result {
            Err(e) => notices.error(e.to_string()),
            Ok(parsed) => {
                let scene = &parsed.scene;
                for w in &scene.warnings {
                    notices.warn(format!("{}: {w}", path.display()));
                }
                // A dropped file stands where it was dropped, by the placement rule; a file opened
                // otherwise keeps its coordinates and the camera frames it.
                let bounds = parsed.bounds;
                let mut transform = None;
                if let Some(at) = dropped_at
                    && let (Some(b), Ok((camera, cam_gt))) = (bounds, cameras.single())
                    && let Some(rect) = camera.logical_viewport_rect()
                    && let Ok(ray) = camera.viewport_to_world(cam_gt, at.unwrap_or(rect.center()))
                {
                    let surface = crate::placement::surface_under(&bvh, ray, 5.0);
                    transform = Some(drop_transform(b, surface).into());
                } else if let (Some((min, max)), Ok(mut o)) = (bounds, orbit.single_mut()) {
                    o.focus = (min + max) * 0.5;
                    o.radius = (max - min).length().max(1e-3) * 1.4;
                }
                notices.info(format!(
                    "opened {} ({} meshes, {} triangles)",
                    path.display(),
                    scene.meshes.len(),
                    scene.triangle_count()
                ));
                // The root's id, given now, names this import from the command to its tracking.
                let root = index.allocate();
                parsed_imports.0.insert(root, parsed);
                jobs.awaiting
                    .push((root, path.clone(), std::time::Instant::now()));
                requests.apply(crate::edit::EditCommand::Import {
                    file: path,
                    root: Some(root),
                    transform,
                });
            }
        }
    }
}

/// Every key [`spawn_scene`] gives the objects of `scene`: the root's (empty), each node's, and
/// each mesh's that is not on its node.
pub fn source_keys(scene: &ImportedScene) -> Vec<String> {
    let mut keys = vec![String::new()];
    keys.extend(scene.nodes.iter().map(|n| n.key.clone()));
    // A mesh alone on its node lives on the node, under the node's key.
    let own = mesh_object_keys(scene)
        .into_iter()
        .zip(&scene.meshes)
        .filter(|(k, m)| {
            m.node
                .and_then(|n| scene.nodes.get(n))
                .is_none_or(|n| n.key != *k)
        })
        .map(|(k, _)| k);
    keys.extend(own);
    keys
}

/// The world-space bounds of a parsed scene's triangles.
pub fn scene_bounds(scene: &ImportedScene) -> Option<(Vec3, Vec3)> {
    let mut bounds: Option<(Vec3, Vec3)> = None;
    for m in &scene.meshes {
        for tri in m.world_triangles() {
            for p in tri {
                bounds = Some(bounds.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
            }
        }
    }
    bounds
}

/// Spawns a parsed scene into the world (what the import command does): the assembly, and with
/// `add_sun` a sun when the scene has no light yet. Returns the entities spawned at the top; fails
/// only in a world without mesh, material or image assets.
pub fn spawn_scene_in_world(
    world: &mut World,
    file: &Path,
    scene: &ImportedScene,
    prebuilt: &mut Prebuilt,
    add_sun: bool,
) -> Result<Vec<Entity>, String> {
    let mut state: bevy::ecs::system::SystemState<(Commands, SceneAssets)> =
        bevy::ecs::system::SystemState::new(world);
    let (mut commands, mut assets) = state.get_mut(world).map_err(|e| e.to_string())?;
    let root = spawn_scene(&mut commands, file, scene, prebuilt, &mut assets);
    state.apply(world);
    if let Some(mut catalog) = world.get_resource_mut::<SourceCatalog>() {
        catalog.0.insert(file.to_owned(), source_keys(scene));
    }
    let mut top = vec![root];
    let mut lights = world.query_filtered::<(), AnyLight>();
    if add_sun && lights.iter(world).next().is_none() {
        top.push(
            world
                .spawn((
                    Name::new("Sun"),
                    SceneObject,
                    DirectionalLight {
                        illuminance: 8_000.0,
                        ..default()
                    },
                    Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
                ))
                .id(),
        );
    }
    Ok(top)
}

/// The asset stores an imported scene is added to.
#[derive(SystemParam)]
pub struct SceneAssets<'w> {
    /// Meshes.
    pub meshes: ResMut<'w, Assets<Mesh>>,
    /// Materials.
    pub materials: ResMut<'w, Assets<StandardMaterial>>,
    /// Textures.
    pub images: ResMut<'w, Assets<Image>>,
}

/// Where an imported object came from: the file and the node's key in it (names from the top,
/// `#index` where a node has none), so a project can find the node again in a later version of
/// the file.
#[derive(Component, Clone, Debug, PartialEq, Eq, Hash)]
pub struct SourceKey {
    /// The file.
    pub file: PathBuf,
    /// The node's key in the file; the mesh's index (`mesh N`) for files without nodes.
    pub key: String,
}

/// Which file's mesh an object shows: its own node's for an imported mesh, the original's for a
/// copy (which has no [`SourceKey`] of its own), so a project can find the geometry again.
#[derive(Component, Clone, Debug, PartialEq, Eq, Hash)]
pub struct MeshSource(pub SourceKey);

/// Every node key each imported file had when it was imported, so a project can tell which nodes
/// the user deleted.
#[derive(Resource, Default, Debug)]
pub struct SourceCatalog(pub HashMap<PathBuf, Vec<String>>);

/// Spawns the file as an assembly: one root named after the file, its node hierarchy beneath as
/// parent and child entities with local transforms, each mesh on its node (or, for a node with
/// several meshes or for files without nodes, as a child of its own). Returns the root.
pub fn spawn_scene(
    commands: &mut Commands,
    file: &Path,
    scene: &ImportedScene,
    prebuilt: &mut Prebuilt,
    assets: &mut SceneAssets,
) -> Entity {
    // One image per texture and sampler, shared by the materials that use it.
    let mut textures: HashMap<(usize, [WrapMode; 2]), Handle<Image>> = HashMap::new();
    let handles: Vec<Handle<StandardMaterial>> = scene
        .materials
        .iter()
        .map(|m| {
            let mut mat = material(m);
            if let Some(r) = m.base_color_texture
                && let Some(t) = scene.textures.get(r.texture)
            {
                let image = textures.entry((r.texture, r.wrap)).or_insert_with(|| {
                    let made = prebuilt.images.remove(&(r.texture, r.wrap));
                    assets
                        .images
                        .add(made.unwrap_or_else(|| to_bevy_image(t, r.wrap)))
                });
                mat.base_color_texture = Some(image.clone());
                // Bevy's rasteriser and the path tracer both read it (KHR_texture_transform).
                let [x, y, t] = r.uv_transform;
                mat.uv_transform = bevy::math::Affine2::from_cols(x.into(), y.into(), t.into());
            }
            assets.materials.add(mat)
        })
        .collect();
    let fallback = assets.materials.add(material(&ImportedMaterial::default()));
    let root_name = file.file_name().map_or_else(
        || file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let root = commands
        .spawn((
            Name::new(root_name),
            SceneObject,
            Transform::IDENTITY,
            Visibility::default(),
            SourceKey {
                file: file.to_owned(),
                key: String::new(),
            },
        ))
        .id();
    // Parents come before their children in the file's node list.
    let mut nodes: Vec<Entity> = Vec::with_capacity(scene.nodes.len());
    for n in &scene.nodes {
        let parent = n.parent.and_then(|p| nodes.get(p).copied()).unwrap_or(root);
        nodes.push(
            commands
                .spawn((
                    Name::new(n.name.clone()),
                    SceneObject,
                    Transform::from_matrix(n.local),
                    Visibility::default(),
                    SourceKey {
                        file: file.to_owned(),
                        key: n.key.clone(),
                    },
                    ChildOf(parent),
                ))
                .id(),
        );
    }
    let mut meshes_per_node: HashMap<usize, usize> = HashMap::new();
    for m in &scene.meshes {
        if let Some(n) = m.node {
            *meshes_per_node.entry(n).or_default() += 1;
        }
    }
    let keys = mesh_object_keys(scene);
    // A mesh the file places at several nodes becomes one asset: the scene BVH then holds its
    // triangles once, each placement an instance.
    let mut mesh_handles: Vec<Handle<Mesh>> = Vec::with_capacity(scene.meshes.len());
    for (i, m) in scene.meshes.iter().enumerate() {
        let mat = m
            .material
            .and_then(|k| handles.get(k))
            .cloned()
            .unwrap_or_else(|| fallback.clone());
        let mesh = match m.same_as.and_then(|j| mesh_handles.get(j)) {
            Some(h) => h.clone(),
            None => assets.meshes.add(
                prebuilt
                    .meshes
                    .get_mut(i)
                    .and_then(Option::take)
                    .unwrap_or_else(|| to_bevy_mesh(m)),
            ),
        };
        mesh_handles.push(mesh.clone());
        let shape = (Mesh3d(mesh), MeshMaterial3d(mat));
        let bound = prebuilt.bounds.get(i).copied().flatten();
        let spawned = match m.node.and_then(|n| nodes.get(n).map(|e| (n, *e))) {
            // A node's only mesh lives on the node itself.
            Some((n, node)) if meshes_per_node.get(&n) == Some(&1) => {
                let key = SourceKey {
                    file: file.to_owned(),
                    key: keys[i].clone(),
                };
                commands.entity(node).insert((shape, MeshSource(key)));
                node
            }
            Some((_, node)) => {
                let key = SourceKey {
                    file: file.to_owned(),
                    key: keys[i].clone(),
                };
                commands
                    .spawn((
                        Name::new(m.name.clone()),
                        SceneObject,
                        shape,
                        Transform::IDENTITY,
                        MeshSource(key.clone()),
                        key,
                        ChildOf(node),
                    ))
                    .id()
            }
            None => {
                let key = SourceKey {
                    file: file.to_owned(),
                    key: keys[i].clone(),
                };
                commands
                    .spawn((
                        Name::new(m.name.clone()),
                        SceneObject,
                        shape,
                        Transform::from_matrix(m.transform),
                        MeshSource(key.clone()),
                        key,
                        ChildOf(root),
                    ))
                    .id()
            }
        };
        // Bounds made with the mesh on the parsing task: Bevy would otherwise compute every new
        // mesh's on the main thread in the frame that spawns them. The editor never edits an
        // imported mesh's vertices, so they stay right.
        if let Some(b) = bound {
            commands
                .entity(spawned)
                .insert((b, bevy::camera::visibility::NoAutoAabb));
        }
    }
    root
}

/// The source key of the object that shows each of `scene`'s meshes: a node's only mesh lives on
/// the node (its key); each of several meshes of one node is a child (`NODE/mesh I`); a mesh of a
/// file without nodes is `mesh I`.
pub fn mesh_object_keys(scene: &ImportedScene) -> Vec<String> {
    let mut per_node: HashMap<usize, usize> = HashMap::new();
    for n in scene.meshes.iter().filter_map(|m| m.node) {
        *per_node.entry(n).or_default() += 1;
    }
    scene
        .meshes
        .iter()
        .enumerate()
        .map(
            |(i, m)| match m.node.and_then(|n| Some((n, scene.nodes.get(n)?))) {
                Some((n, node)) if per_node.get(&n) == Some(&1) => node.key.clone(),
                Some((_, node)) => format!("{}/mesh {i}", node.key),
                None => format!("mesh {i}"),
            },
        )
        .collect()
}

/// A Bevy triangle-list mesh from an imported one (smooth normals computed where the file has none).
pub fn to_bevy_mesh(m: &ImportedMesh) -> Mesh {
    let mut mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, m.geometry.positions.clone())
    .with_inserted_indices(Indices::U32(m.geometry.indices.clone()));
    if let Some(uvs) = &m.geometry.uvs {
        mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uvs.clone());
    }
    match &m.geometry.normals {
        Some(n) => mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, n.clone()),
        None => mesh.compute_smooth_normals(),
    }
    mesh
}

/// A GPU-only Bevy image from a decoded texture (sRGB colour, the file's wrap modes, bilinear).
pub fn to_bevy_image(t: &ImportedTexture, wrap: [WrapMode; 2]) -> Image {
    let address = |w: WrapMode| match w {
        WrapMode::Repeat => ImageAddressMode::Repeat,
        WrapMode::ClampToEdge => ImageAddressMode::ClampToEdge,
        WrapMode::MirroredRepeat => ImageAddressMode::MirrorRepeat,
    };
    let mut image = Image::new(
        Extent3d {
            width: t.width,
            height: t.height,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        t.rgba8.clone(),
        TextureFormat::Rgba8UnormSrgb,
        // The pixels are only needed on the GPU (the path tracer resamples from there too).
        RenderAssetUsages::RENDER_WORLD,
    );
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        address_mode_u: address(wrap[0]),
        address_mode_v: address(wrap[1]),
        ..ImageSamplerDescriptor::linear()
    });
    image
}

fn material(m: &ImportedMaterial) -> StandardMaterial {
    let [r, g, b, a] = m.base_color;
    StandardMaterial {
        base_color: Color::LinearRgba(LinearRgba::new(r, g, b, a)),
        metallic: m.metallic,
        perceptual_roughness: m.roughness,
        emissive: LinearRgba::rgb(m.emissive[0], m.emissive[1], m.emissive[2]),
        alpha_mode: if a < 1.0 {
            AlphaMode::Blend
        } else {
            AlphaMode::Opaque
        },
        ..default()
    }
}

/// Imports as a plugin: the files being parsed, the scenes parsed and waiting for their command,
/// the catalog of what each file held, and the system that hands parsed files to the history.
/// Drops on a window are the shell's ([`import_dropped_files`]).
pub struct ImportPlugin;

impl Plugin for ImportPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<PendingImports>()
            .init_resource::<ParsedImports>()
            .init_resource::<SourceCatalog>()
            .add_systems(
                Update,
                finish_imports.before(crate::edit::apply_edit_requests),
            );
    }
}

/// Opens the file named at start: a project is opened in place of the scene, any other scene file
/// imported into it.
pub fn open_at_start(world: &mut World, path: &Path) {
    if crate::is_project_file(path) {
        world
            .resource_mut::<crate::files::ProjectRequests>()
            .0
            .push(crate::files::ProjectRequest::Open(path.to_owned()));
    } else {
        world
            .resource_mut::<PendingImports>()
            .start(path.to_owned());
    }
}

#[cfg(test)]
mod drop_tests {
    use super::*;
    use crate::placement::Surface;

    #[test]
    fn a_dropped_scene_stands_on_the_surface_where_it_was_dropped() {
        // A scene floating two units up, dropped on the floor at (3, 0, 0).
        let bounds = (Vec3::new(-1.0, 2.0, -1.0), Vec3::new(1.0, 4.0, 1.0));
        let surface = Surface {
            point: Vec3::new(3.0, 0.0, 0.0),
            normal: Vec3::Y,
        };
        let t = drop_transform(bounds, surface);
        let bottom_centre = t.transform_point(Vec3::new(0.0, 2.0, 0.0));
        assert!(
            bottom_centre.distance(surface.point) < 1e-6,
            "{bottom_centre}"
        );
        assert_eq!(t.rotation, Quat::IDENTITY);
    }
}
