//! Spawning a parsed scene as scene objects: the assembly's hierarchy, its meshes and materials,
//! and the keys that let a project find each node again.

use crate::scene::convert::{
    ImageKey, material, material_maps, put_map, tangents_needed, to_bevy_image, to_bevy_mesh,
};
use crate::scene::parsed::Prebuilt;
use crate::scene::share::{SharedAssets, image_hash, mesh_hash, texture_hash};
use crate::values::object::{SceneId, SceneObject};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use treelight_import::{ImportedMaterial, ImportedScene};

/// Filter for entities that light the scene.
pub type AnyLight = Or<(With<DirectionalLight>, With<PointLight>, With<SpotLight>)>;

/// Every key [`spawn_scene`] gives the objects of `scene`: the root's (empty), each node's, and
/// each mesh's that is not on its node, in the order it spawns them.
pub fn source_keys(scene: &ImportedScene) -> Vec<Arc<str>> {
    source_tree(scene)
        .keys
        .into_iter()
        .map(|k| Arc::from(k.as_ref()))
        .collect()
}

/// The objects [`spawn_scene`] makes of a scene, in the order it makes them: their keys (the
/// nodes' borrowed from the scene) and the parent of each as an index into them (`None` for the
/// root).
pub struct SourceTree<'a> {
    /// Each object's key ([`source_keys`]).
    pub keys: Vec<std::borrow::Cow<'a, str>>,
    /// Each object's parent.
    pub parents: Vec<Option<u32>>,
}

/// The hierarchy [`spawn_scene`] makes of `scene`: the root, each node, and each mesh that is not
/// on its node.
pub fn source_tree(scene: &ImportedScene) -> SourceTree<'_> {
    use std::borrow::Cow;
    let mut keys: Vec<Cow<str>> = Vec::with_capacity(1 + scene.nodes.len());
    let mut parents = Vec::with_capacity(1 + scene.nodes.len());
    keys.push(Cow::Borrowed(""));
    parents.push(None);
    keys.extend(scene.nodes.iter().map(|n| Cow::Borrowed(n.key.as_str())));
    parents.extend(
        scene
            .nodes
            .iter()
            .map(|n| Some(n.parent.map_or(0, |p| p as u32 + 1))),
    );
    let counts = mesh_counts(scene);
    for (i, m) in scene.meshes.iter().enumerate() {
        // A mesh alone on its node lives on the node, under the node's key.
        if let Some(key) = own_mesh_key(scene, i, &counts) {
            keys.push(Cow::Owned(key));
            let node = m.node.filter(|&n| n < scene.nodes.len());
            parents.push(Some(node.map_or(0, |n| n as u32 + 1)));
        }
    }
    SourceTree { keys, parents }
}

/// Meshes on each node of `scene`.
fn mesh_counts(scene: &ImportedScene) -> Vec<u32> {
    let mut counts = vec![0u32; scene.nodes.len()];
    for n in scene.meshes.iter().filter_map(|m| m.node) {
        if let Some(c) = counts.get_mut(n) {
            *c += 1;
        }
    }
    counts
}

/// The key of the object of its own that mesh `i` gets, or `None` when it is its node's only mesh
/// and lives on the node.
fn own_mesh_key(scene: &ImportedScene, i: usize, counts: &[u32]) -> Option<String> {
    let node = scene.meshes[i].node.filter(|&n| n < scene.nodes.len());
    match node {
        _ if !has_own_object(scene, i, counts) => None,
        Some(n) => Some(format!("{}/mesh {i}", scene.nodes[n].key)),
        None => Some(format!("mesh {i}")),
    }
}

/// Whether mesh `i` gets an object of its own: it is not its node's only mesh.
fn has_own_object(scene: &ImportedScene, i: usize, counts: &[u32]) -> bool {
    let node = scene.meshes[i].node.filter(|&n| n < scene.nodes.len());
    node.is_none_or(|n| counts[n] != 1)
}

/// Whether an imported file that brings no light, into a scene that has none, gets a sun
/// ([`DEFAULT_SUN_LUX`], named "Sun"): the sky alone leaves most scenes dim and flat, so the editor
/// adds one and says so in a notice; `treelight render --default-sun off` keeps it out, to render
/// the file's light alone. A project's opening never adds one.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct DefaultSun(pub bool);

impl Default for DefaultSun {
    fn default() -> Self {
        Self(true)
    }
}

/// The illuminance of the sun [`DefaultSun`] adds, in lux: a bright overcast day's, which a
/// camera at Bevy's default exposure shows without clipping a white surface.
pub const DEFAULT_SUN_LUX: f32 = 8_000.0;

/// What [`spawn_scene_in_world`] made.
pub struct SpawnedScene {
    /// The entities at the top: the assembly's root, and the sun if one was added.
    pub top: Vec<Entity>,
    /// The assembly's objects in [`source_keys`] order.
    pub objects: Vec<Entity>,
}

/// Spawns a parsed scene into the world (what the import command does): the assembly, its objects
/// with the ids `ids` gives in [`source_keys`] order (fresh ones past its end, or for
/// [`SceneId::NEW`]), and with `add_sun` a sun when the scene has no light yet. Fails only in a
/// world without mesh, material or image assets.
pub fn spawn_scene_in_world(
    world: &mut World,
    file: &Path,
    scene: &ImportedScene,
    prebuilt: &mut Prebuilt,
    add_sun: bool,
    ids: &[SceneId],
) -> Result<SpawnedScene, String> {
    let mut state: bevy::ecs::system::SystemState<(Commands, SceneAssets)> =
        bevy::ecs::system::SystemState::new(world);
    let keys = source_keys(scene);
    let (import, keys) = match world.get_resource_mut::<SourceCatalog>() {
        Some(mut c) => c.add(file, keys),
        None => (0, Arc::new(keys)),
    };
    let (mut commands, mut assets) = state.get_mut(world).map_err(|e| e.to_string())?;
    let objects = spawn_scene(
        &mut commands,
        (file, import, &keys),
        scene,
        prebuilt,
        &mut assets,
        ids,
    );
    let root = objects[0];
    state.apply(world);
    let mut top = vec![root];
    let mut lights = world.query_filtered::<(), AnyLight>();
    if add_sun && lights.iter(world).next().is_none() {
        top.push(
            world
                .spawn((
                    Name::new("Sun"),
                    SceneObject,
                    DirectionalLight {
                        illuminance: DEFAULT_SUN_LUX,
                        ..default()
                    },
                    Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
                ))
                .id(),
        );
    }
    Ok(SpawnedScene { top, objects })
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
    /// The meshes and images of earlier imports, by content.
    pub shared: ResMut<'w, SharedAssets>,
    /// Each map's own UV transform, for materials whose maps differ.
    pub map_transforms: ResMut<'w, crate::values::map_transforms::MaterialMapTransforms>,
    /// The scene BVH, which takes the traced geometry made with new meshes.
    pub scene_bvh: Option<ResMut<'w, treelight_scene::SceneBvh>>,
}

/// Where an imported object came from: the file and the node's key in it (names from the top,
/// `#index` where a node has none), so a project can find the node again in a later version of
/// the file.
#[derive(Component, Clone, Debug, PartialEq, Eq, Hash)]
pub struct SourceKey {
    /// The file (one copy shared by every object of an import).
    pub file: Arc<Path>,
    /// The node's key in the file; the mesh's index (`mesh N`) for files without nodes. Shared with
    /// the object's [`MeshSource`].
    pub key: Arc<str>,
    /// The key's place in [`source_keys`] of the file as imported.
    pub index: u32,
    /// Which import of the file the object came from, as [`SourceCatalog`] numbers them: a file
    /// imported twice is two sources of a project, each keeping its own edits.
    pub import: u32,
}

/// Which file's mesh an object shows: its own node's for an imported mesh, the original's for a
/// copy (which has no [`SourceKey`] of its own), so a project can find the geometry again.
#[derive(Component, Clone, Debug, PartialEq, Eq, Hash)]
pub struct MeshSource(pub SourceKey);

/// Every import of a file since the scene was opened, by number: the file and the node keys it
/// had when imported, so a project can tell which nodes the user deleted.
#[derive(Resource, Default, Debug)]
pub struct SourceCatalog {
    imports: HashMap<u32, SourceImport>,
    next: u32,
}

/// One import of a file, in the [`SourceCatalog`].
#[derive(Clone, Debug, PartialEq)]
pub struct SourceImport {
    /// The file.
    pub file: PathBuf,
    /// Its [`source_keys`] when imported; shared by the imports of one file that found the same,
    /// and each key with the [`SourceKey`] of its object.
    pub keys: Arc<Vec<Arc<str>>>,
}

impl SourceCatalog {
    /// Notes an import of `file` whose nodes have `keys`; returns its number and the keys as the
    /// catalog keeps them (shared with an earlier import of the file that found the same).
    pub fn add(&mut self, file: &Path, keys: Vec<Arc<str>>) -> (u32, Arc<Vec<Arc<str>>>) {
        let keys = self
            .imports
            .values()
            .find(|i| i.file == file && *i.keys == keys)
            .map_or_else(|| Arc::new(keys), |i| i.keys.clone());
        let number = self.next;
        self.next += 1;
        self.imports.insert(
            number,
            SourceImport {
                file: file.to_owned(),
                keys: keys.clone(),
            },
        );
        (number, keys)
    }

    /// The import numbered `import`.
    pub fn get(&self, import: u32) -> Option<&SourceImport> {
        self.imports.get(&import)
    }

    /// Every import, by number.
    pub fn iter(&self) -> impl Iterator<Item = (u32, &SourceImport)> {
        self.imports.iter().map(|(n, i)| (*n, i))
    }

    /// Forgets every import (a new scene).
    pub fn clear(&mut self) {
        self.imports.clear();
    }
}

/// Spawns the file as an assembly: one root named after the file, its node hierarchy beneath as
/// parent and child entities with local transforms, each mesh on its node (or, for a node with
/// several meshes or for files without nodes, as a child of its own), each with the id `ids` gives
/// in [`source_keys`] order, as import number `import` of `file` ([`SourceCatalog`]). A mesh or
/// image equal to one already in the scene is that one ([`SharedAssets`]). Returns the objects in
/// that order, the root first.
pub fn spawn_scene(
    commands: &mut Commands,
    (file, import, keys): (&Path, u32, &[Arc<str>]),
    scene: &ImportedScene,
    prebuilt: &mut Prebuilt,
    assets: &mut SceneAssets,
    ids: &[SceneId],
) -> Vec<Entity> {
    let id = |k: usize| ids.get(k).copied().unwrap_or(SceneId::NEW);
    let handles = material_handles(scene, prebuilt, assets);
    let fallback = assets.materials.add(material(&ImportedMaterial::default()));
    let root_name = file.file_name().map_or_else(
        || file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    // One copy of the path for every object's key, and of each key for its object.
    let file: Arc<Path> = Arc::from(file);
    let key_at = |i: usize| keys.get(i).cloned().unwrap_or_default();
    let root = commands
        .spawn((
            Name::new(root_name),
            SceneObject,
            id(0),
            Transform::IDENTITY,
            Visibility::default(),
            SourceKey {
                file: file.clone(),
                key: key_at(0),
                index: 0,
                import,
            },
        ))
        .id();
    let nodes = spawn_nodes(commands, scene, root, (&file, import, keys), ids);
    put_lights_and_cameras(commands, scene, &nodes);
    let counts = mesh_counts(scene);
    let mut objects = Vec::with_capacity(1 + nodes.len());
    objects.push(root);
    objects.extend(&nodes);
    // A mesh the file places at several nodes becomes one asset: the scene BVH then holds its
    // triangles once, each placement an instance.
    let mut mesh_handles: Vec<Handle<Mesh>> = Vec::with_capacity(scene.meshes.len());
    let mut tangents: Option<Vec<bool>> = None;
    for (i, m) in scene.meshes.iter().enumerate() {
        let mat = m
            .material
            .and_then(|k| handles.get(k))
            .cloned()
            .unwrap_or_else(|| fallback.clone());
        let mesh = match m.same_as.and_then(|j| mesh_handles.get(j)) {
            Some(h) => h.clone(),
            None => {
                let needed = tangents.get_or_insert_with(|| tangents_needed(scene));
                let with_tangents = needed.get(i).copied().unwrap_or(false);
                let hash = prebuilt
                    .mesh_hashes
                    .get(i)
                    .copied()
                    .flatten()
                    .unwrap_or_else(|| mesh_hash(&m.geometry, with_tangents));
                let made = prebuilt.meshes.get_mut(i).and_then(Option::take);
                let geometry = prebuilt.geometry.get_mut(i).and_then(Option::take);
                let mut new = false;
                let handle = assets.shared.mesh(hash, &mut assets.meshes, || {
                    new = true;
                    made.unwrap_or_else(|| to_bevy_mesh(m, with_tangents))
                });
                // Only a mesh made now is the one the geometry was made from.
                if new && let (Some(g), Some(bvh)) = (geometry, assets.scene_bvh.as_mut()) {
                    bvh.prepare(handle.id(), g);
                }
                handle
            }
        };
        mesh_handles.push(mesh.clone());
        let shape = (Mesh3d(mesh), MeshMaterial3d(mat));
        let bound = prebuilt.bounds.get(i).copied().flatten();
        let node = m.node.filter(|&n| n < nodes.len());
        let spawned = match has_own_object(scene, i, &counts) {
            // A node's only mesh lives on the node itself.
            false => {
                let n = node.unwrap_or_default();
                let key = SourceKey {
                    file: file.clone(),
                    key: key_at(1 + n),
                    index: 1 + n as u32,
                    import,
                };
                commands.entity(nodes[n]).insert((shape, MeshSource(key)));
                nodes[n]
            }
            // Each of several meshes of one node is a child of it; a mesh of a file without nodes
            // stands under the root with its own transform.
            true => {
                let (parent, transform) = match node {
                    Some(n) => (nodes[n], Transform::IDENTITY),
                    None => (root, Transform::from_matrix(m.transform)),
                };
                let key = SourceKey {
                    file: file.clone(),
                    key: key_at(objects.len()),
                    index: objects.len() as u32,
                    import,
                };
                let e = commands
                    .spawn((
                        Name::new(m.name.clone()),
                        SceneObject,
                        id(objects.len()),
                        shape,
                        transform,
                        MeshSource(key.clone()),
                        key,
                        ChildOf(parent),
                    ))
                    .id();
                objects.push(e);
                e
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
    objects
}

/// The file's lights on their nodes (KHR_lights_punctual), in the editor's units, and its
/// cameras.
fn put_lights_and_cameras(commands: &mut Commands, scene: &ImportedScene, nodes: &[Entity]) {
    for (n, &e) in scene.nodes.iter().zip(nodes) {
        if let Some(c) = n.camera {
            commands
                .entity(e)
                .insert(crate::values::camera::SceneCamera::from_imported(&c));
        }
        if let Some(l) = n.light {
            commands.queue(move |world: &mut World| {
                if let Ok(mut e) = world.get_entity_mut(e) {
                    imported_light(&l).put_on(&mut e);
                }
            });
        }
    }
}

/// The file's nodes as objects under `root`, in the file's order (parents before their
/// children), each with its key.
fn spawn_nodes(
    commands: &mut Commands,
    scene: &ImportedScene,
    root: Entity,
    (file, import, keys): (&Arc<Path>, u32, &[Arc<str>]),
    ids: &[SceneId],
) -> Vec<Entity> {
    let mut nodes: Vec<Entity> = Vec::with_capacity(scene.nodes.len());
    for (k, n) in scene.nodes.iter().enumerate() {
        let parent = n.parent.and_then(|p| nodes.get(p).copied()).unwrap_or(root);
        nodes.push(
            commands
                .spawn((
                    Name::new(n.name.clone()),
                    SceneObject,
                    ids.get(1 + k).copied().unwrap_or(SceneId::NEW),
                    Transform::from_matrix(n.local),
                    Visibility::default(),
                    SourceKey {
                        file: file.clone(),
                        key: keys.get(1 + k).cloned().unwrap_or_default(),
                        index: 1 + k as u32,
                        import,
                    },
                    ChildOf(parent),
                ))
                .id(),
        );
    }
    nodes
}

/// One material per material of the scene, with its maps' images (one image per texture, sampler
/// and storage, shared by the materials that use it; those made ahead of time taken from
/// `prebuilt`).
fn material_handles(
    scene: &ImportedScene,
    prebuilt: &mut Prebuilt,
    assets: &mut SceneAssets,
) -> Vec<Handle<StandardMaterial>> {
    let mut images: HashMap<ImageKey, Handle<Image>> = HashMap::new();
    let mut texture_hashes: HashMap<usize, u64> = HashMap::new();
    scene
        .materials
        .iter()
        .map(|m| {
            let mut mat = material(m);
            for (slot, r, role) in material_maps(m) {
                let Some(t) = scene.textures.get(r.texture) else {
                    continue;
                };
                let key = (r.texture, r.wrap, role);
                let image = images.entry(key).or_insert_with(|| {
                    let texture = *texture_hashes.entry(r.texture).or_insert_with(|| {
                        prebuilt
                            .texture_hashes
                            .get(r.texture)
                            .copied()
                            .unwrap_or_else(|| texture_hash(t))
                    });
                    let made = prebuilt.images.remove(&key);
                    let hash = image_hash(texture, r.wrap, role);
                    assets.shared.image(hash, &mut assets.images, || {
                        made.unwrap_or_else(|| to_bevy_image(t, r.wrap, role))
                    })
                });
                put_map(&mut mat, slot, image.clone(), r.tex_coord);
            }
            let handle = assets.materials.add(mat);
            if let Some(each) = crate::values::map_transforms::of_material(m) {
                assets.map_transforms.0.insert(handle.id(), each);
            }
            handle
        })
        .collect()
}

/// The source key of the object that shows each of `scene`'s meshes: a node's only mesh lives on
/// the node (its key); each of several meshes of one node is a child (`NODE/mesh I`); a mesh of a
/// file without nodes is `mesh I`.
pub fn mesh_object_keys(scene: &ImportedScene) -> Vec<String> {
    let counts = mesh_counts(scene);
    (0..scene.meshes.len())
        .map(|i| {
            own_mesh_key(scene, i, &counts).unwrap_or_else(|| {
                let n = scene.meshes[i].node.unwrap_or_default();
                scene.nodes[n].key.clone()
            })
        })
        .collect()
}

/// A file's light as the editor's: sRGB colour, lumens for point and spot lights (glTF gives
/// candela), lux for directional ones.
pub fn imported_light(l: &treelight_import::ImportedLight) -> crate::values::light::LightValue {
    use crate::values::light::{LightKind, LightValue, candela_to_lumens};
    use treelight_import::ImportedLightKind;
    let [r, g, b] = l.color;
    let (kind, intensity) = match l.kind {
        ImportedLightKind::Point => (LightKind::Point, candela_to_lumens(l.intensity)),
        ImportedLightKind::Spot { .. } => (LightKind::Spot, candela_to_lumens(l.intensity)),
        ImportedLightKind::Directional => (LightKind::Directional, l.intensity),
    };
    let (inner_angle, outer_angle) = match l.kind {
        ImportedLightKind::Spot {
            inner_angle,
            outer_angle,
        } => (inner_angle, outer_angle),
        _ => (0.0, std::f32::consts::FRAC_PI_4),
    };
    // Within what projects accept, so a scene with an absurd light still saves and opens.
    let max = crate::values::transform::MAX_VALUE;
    LightValue {
        kind,
        color: Color::linear_rgb(r, g, b)
            .to_srgba()
            .to_f32_array_no_alpha()
            .map(|c| c.clamp(0.0, max)),
        intensity: intensity.min(max),
        shadows: true,
        range: l.range.filter(|r| kind.is_local() && *r <= max),
        inner_angle,
        outer_angle,
    }
}
