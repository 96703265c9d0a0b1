//! Spawning a parsed scene as scene objects: the assembly's hierarchy, its meshes and materials,
//! and the keys that let a project find each node again.

use crate::import::convert::{material, to_bevy_image, to_bevy_mesh};
use crate::import::parse::Prebuilt;
use crate::object::SceneObject;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use treelight_import::{ImportedMaterial, ImportedScene, WrapMode};

/// Filter for entities that light the scene.
pub type AnyLight = Or<(With<DirectionalLight>, With<PointLight>)>;

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
    let handles = material_handles(scene, prebuilt, assets);
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
        let key = SourceKey {
            file: file.to_owned(),
            key: keys[i].clone(),
        };
        let spawned = match m.node.and_then(|n| nodes.get(n).map(|e| (n, *e))) {
            // A node's only mesh lives on the node itself.
            Some((n, node)) if meshes_per_node.get(&n) == Some(&1) => {
                commands.entity(node).insert((shape, MeshSource(key)));
                node
            }
            // Each of several meshes of one node is a child of it; a mesh of a file without nodes
            // stands under the root with its own transform.
            placed => {
                let (parent, transform) = match placed {
                    Some((_, node)) => (node, Transform::IDENTITY),
                    None => (root, Transform::from_matrix(m.transform)),
                };
                commands
                    .spawn((
                        Name::new(m.name.clone()),
                        SceneObject,
                        shape,
                        transform,
                        MeshSource(key.clone()),
                        key,
                        ChildOf(parent),
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

/// One material per material of the scene, with its base-colour image (one image per texture and
/// sampler, shared by the materials that use it; those made ahead of time taken from `prebuilt`).
fn material_handles(
    scene: &ImportedScene,
    prebuilt: &mut Prebuilt,
    assets: &mut SceneAssets,
) -> Vec<Handle<StandardMaterial>> {
    // One image per texture and sampler, shared by the materials that use it.
    let mut textures: HashMap<(usize, [WrapMode; 2]), Handle<Image>> = HashMap::new();
    scene
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
        .collect()
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
