//! glTF 2.0 (.gltf with external or embedded buffers, and .glb).

use crate::files::sandbox::{read_scene_file, read_uri};
use crate::formats::gltf_compressed::{self, read_floats};
use crate::formats::material::MaterialReader;
use crate::scene::imported::{
    ImportedCamera, ImportedLight, ImportedLightKind, ImportedMaterial, ImportedMesh, ImportedNode,
    ImportedScene, MeshGeometry,
};
use crate::scene::texture::ImageCache;
use crate::types::budget::{Budget, ImportOptions};
use crate::types::error::{ImportError, MAX_ELEMENTS, check_indices, check_positions};
use glam::Mat4;
use gltf::Semantic;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

/// Most node instances one file may place (the hierarchy is a forest, so at most its node count).
pub const MAX_NODES: usize = 1 << 24;

/// Deepest node hierarchy accepted.
const MAX_DEPTH: usize = 256;

/// The part of a node's name that goes into its key: the first 255 bytes (whole characters).
fn key_step(name: &str) -> &str {
    let mut end = name.len().min(255);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    &name[..end]
}

/// Loads the default scene of a glTF file (or all root nodes of the first scene), with node
/// transforms applied down the hierarchy, within the default memory budget.
pub fn load_gltf(path: &Path) -> Result<ImportedScene, ImportError> {
    read_gltf(path, &mut Budget::new(path, &ImportOptions::default()))
}

pub(crate) fn read_gltf(path: &Path, budget: &mut Budget) -> Result<ImportedScene, ImportError> {
    let bytes = read_scene_file(path, budget)?;
    let gltf::Gltf { document, blob } = gltf_compressed::parse(path, bytes, budget)?;
    let mut buffers = load_buffers(path, &document, blob, budget)?;
    gltf_compressed::decode_meshopt_views(path, &document, &mut buffers, budget)?;
    let mut scene = ImportedScene::default();
    let mut images = ImageCache::default();
    let mut reader = MaterialReader {
        path,
        buffers: &buffers,
        images: &mut images,
        textures: &mut scene.textures,
        warnings: &mut scene.warnings,
        budget,
        material: String::new(),
    };
    let mut materials = Vec::with_capacity(document.materials().len());
    for m in document.materials() {
        materials.push(reader.read(&m)?);
    }
    scene.materials = materials;
    let mut meshes = MeshReading {
        path,
        document: &document,
        buffers: &buffers,
        read: HashMap::new(),
        first_error: None,
        default_material: scene.materials.len(),
        used_default: false,
    };
    let root_scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    let Some(root_scene) = root_scene else {
        return Err(ImportError::new(path, "the file has no scene"));
    };
    // Each node is visited once ([`check_node`]); keys stay unique among siblings.
    let mut seen = vec![false; document.nodes().len()];
    let mut names = SiblingNames::default();
    // (node, parent's world transform, depth, parent's index in scene.nodes). Popped depth first,
    // so a node is always listed after its parent.
    let mut stack: Vec<(gltf::Node, Mat4, usize, Option<usize>)> = root_scene
        .nodes()
        .map(|n| (n, Mat4::IDENTITY, 0, None))
        .collect();
    while let Some((node, parent, depth, parent_index)) = stack.pop() {
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        check_node(path, &node, &mut seen, depth, scene.nodes.len(), &world)?;
        let step = unique_step(&node, parent_index, &mut names);
        let parent_key = parent_index.map_or(0, |p| scene.nodes[p].key.len() + 1);
        let name_len = node.name().map_or(16, str::len);
        // Charged before anything is made: the key, the name, and the step kept to tell
        // siblings apart (twice, in the two maps).
        budget.charge(
            (std::mem::size_of::<ImportedNode>() + parent_key + 3 * step.len() + name_len + 96)
                as u64,
            || node_label(&node),
        )?;
        names.taken.insert((parent_index, step.clone()));
        let key = match parent_index {
            Some(p) => format!("{}/{step}", scene.nodes[p].key),
            None => step,
        };
        let name = node
            .name()
            .map_or_else(|| format!("node {}", node.index()), str::to_owned);
        let index = scene.nodes.len();
        let light = node
            .light()
            .and_then(|l| checked_light(&l, &name, &mut scene.warnings));
        let camera = node
            .camera()
            .and_then(|c| checked_camera(&c, &name, &mut scene.warnings));
        scene.nodes.push(ImportedNode {
            name,
            parent: parent_index,
            local,
            key,
            light,
            camera,
        });
        meshes.read_node(&node, index, world, &mut scene, budget)?;
        for child in node.children() {
            stack.push((child, world, depth + 1, Some(index)));
        }
    }
    if let Some(e) = meshes.first_error
        && scene.meshes.is_empty()
    {
        return Err(e);
    }
    if meshes.used_default {
        scene.materials.push(ImportedMaterial::default());
    }
    crate::scene::uv_sets::first_set_for_tracing(&mut scene);
    Ok(scene)
}

/// Refuses a node reached twice (a node listed under two parents, twice as a root, or on a cycle
/// would make the walk grow without end), too deep, past the most nodes, or with a non-finite
/// world transform.
fn check_node(
    path: &Path,
    node: &gltf::Node,
    seen: &mut [bool],
    depth: usize,
    nodes: usize,
    world: &Mat4,
) -> Result<(), ImportError> {
    // Named only in messages: made when one is written, not for each of a million nodes.
    let label = || node_label(node);
    if std::mem::replace(&mut seen[node.index()], true) {
        return Err(ImportError::new(
            path,
            format!(
                "{} is reached twice (it has two parents, is a root twice, or lies on a \
                 cycle); a glTF node hierarchy must be a forest",
                label()
            ),
        ));
    }
    if depth > MAX_DEPTH {
        return Err(ImportError::new(
            path,
            format!(
                "the node hierarchy is deeper than {MAX_DEPTH} levels at {}",
                label()
            ),
        ));
    }
    if nodes >= MAX_NODES {
        return Err(ImportError::new(
            path,
            format!("the file places more than {MAX_NODES} nodes"),
        ));
    }
    if !world.is_finite() {
        return Err(ImportError::new(
            path,
            format!("{} has a non-finite transform", label()),
        ));
    }
    Ok(())
}

/// A node's step in its key: its name cut to its first 255 bytes (each key repeats its parents'
/// steps, so one long name over many children would be copied into every child's key), made
/// unique among its siblings: the second "bolt" under a parent is "bolt[1]", the third
/// "bolt[2]" (skipping a sibling already named so).
fn unique_step(node: &gltf::Node, parent_index: Option<usize>, names: &mut SiblingNames) -> String {
    let mut step = node.name().map_or_else(
        || format!("#{}", node.index()),
        |n| key_step(n).replace('/', "_"),
    );
    if names.taken.contains(&(parent_index, step.clone())) {
        let next = names
            .next_suffix
            .entry((parent_index, step.clone()))
            .or_insert(1);
        let base = std::mem::take(&mut step);
        loop {
            step = format!("{base}[{next}]");
            *next += 1;
            if !names.taken.contains(&(parent_index, step.clone())) {
                break;
            }
        }
    }
    step
}

/// The steps taken under each parent, and the next suffix to try for each repeated name.
#[derive(Default)]
struct SiblingNames {
    taken: HashSet<(Option<usize>, String)>,
    next_suffix: HashMap<(Option<usize>, String), u32>,
}

/// What reading the meshes of every node shares.
struct MeshReading<'a> {
    path: &'a Path,
    document: &'a gltf::Document,
    buffers: &'a [Vec<u8>],
    /// What a primitive's geometry is read from -> the first entry of `scene.meshes` read from
    /// it: a mesh placed by several nodes, or primitives over the same accessors, are read once
    /// and share the geometry (so a small file cannot make the importer decode one accessor many
    /// times).
    read: HashMap<GeometrySource, usize>,
    first_error: Option<ImportError>,
    default_material: usize,
    used_default: bool,
}

impl MeshReading<'_> {
    /// The triangle primitives of `node`'s mesh as meshes of `scene`, placed by `world`. One bad
    /// mesh does not sink the file: the rest import, this one is named (and the whole file fails
    /// only when no mesh is left).
    fn read_node(
        &mut self,
        node: &gltf::Node,
        index: usize,
        world: Mat4,
        scene: &mut ImportedScene,
        budget: &mut Budget,
    ) -> Result<(), ImportError> {
        let Some(mesh) = node.mesh() else {
            return Ok(());
        };
        let base = node
            .name()
            .or(mesh.name())
            .map_or_else(|| format!("mesh {}", mesh.index()), str::to_owned);
        for prim in mesh.primitives() {
            let name = if mesh.primitives().len() > 1 {
                format!("{base} #{}", prim.index())
            } else {
                base.clone()
            };
            if prim.mode() != Mode::Triangles {
                scene.warnings.push(format!(
                    "'{name}': {:?} primitives are not triangles, skipped",
                    prim.mode()
                ));
                continue;
            }
            budget.charge(
                (std::mem::size_of::<ImportedMesh>() + name.len()) as u64,
                || format!("mesh '{name}'"),
            )?;
            let key = GeometrySource::of(&mesh, &prim);
            let first = self.read.get(&key).copied();
            let geometry = match first {
                Some(i) => Some(scene.meshes[i].geometry.clone()),
                None => match read_primitive(
                    self.path,
                    self.document,
                    &prim,
                    &name,
                    self.buffers,
                    budget,
                ) {
                    Ok(g) => g.map(Arc::new),
                    Err(e) if budget.refused() => return Err(e),
                    Err(e) => {
                        scene.warnings.push(format!("skipped: {}", e.problem));
                        self.first_error.get_or_insert(e);
                        continue;
                    }
                },
            };
            let Some(geometry) = geometry else {
                scene
                    .warnings
                    .push(format!("'{name}' has no positions, skipped"));
                continue;
            };
            if first.is_none() {
                self.read.insert(key, scene.meshes.len());
            }
            let material = prim.material().index().unwrap_or_else(|| {
                self.used_default = true;
                self.default_material
            });
            scene.meshes.push(ImportedMesh {
                name,
                transform: world,
                node: Some(index),
                geometry,
                material: Some(material),
                same_as: first,
            });
        }
        Ok(())
    }
}

/// Where a primitive's geometry comes from: its Draco stream (named by mesh and primitive), or its
/// accessors (positions, normals, UV set 0, indices).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum GeometrySource {
    Draco(usize, usize),
    Accessors([Option<usize>; 6]),
}

impl GeometrySource {
    fn of(mesh: &gltf::Mesh, prim: &gltf::Primitive) -> Self {
        if prim.extension_value("KHR_draco_mesh_compression").is_some() {
            return Self::Draco(mesh.index(), prim.index());
        }
        let at = |s: Semantic| prim.get(&s).map(|a| a.index());
        Self::Accessors([
            at(Semantic::Positions),
            at(Semantic::Normals),
            at(Semantic::TexCoords(0)),
            prim.indices().map(|a| a.index()),
            at(Semantic::Tangents),
            at(Semantic::TexCoords(1)),
        ])
    }
}

/// `node N ('name')`, for messages.
fn node_label(node: &gltf::Node) -> String {
    match node.name() {
        Some(name) => format!("node {} ('{name}')", node.index()),
        None => format!("node {}", node.index()),
    }
}

/// Every buffer's bytes: the GLB's binary chunk (moved, not copied), a data URI, or a regular file
/// beside the opened one read up to its declared length; a meshopt fallback buffer zeroed to be
/// decoded into.
fn load_buffers(
    path: &Path,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    budget: &mut Budget,
) -> Result<Vec<Vec<u8>>, ImportError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let declared = buffer.length();
        if gltf_compressed::is_fallback(&buffer) {
            // Filled by the compressed views that decode into it: as long as the views over it
            // reach, not as long as it claims.
            let reach = document
                .views()
                .filter(|v| v.buffer().index() == buffer.index())
                .map(|v| v.offset().saturating_add(v.length()))
                .max()
                .unwrap_or(0)
                .min(declared);
            budget.charge(reach as u64, || {
                format!("buffer {} (compressed data, decoded)", buffer.index())
            })?;
            out.push(vec![0u8; reach]);
            continue;
        }
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                ImportError::new(
                    path,
                    format!(
                        "buffer {} refers to the GLB binary chunk, which is missing (or taken by \
                         another buffer)",
                        buffer.index()
                    ),
                )
            })?,
            gltf::buffer::Source::Uri(uri) => {
                read_uri(path, dir, uri, "buffer", declared as u64, budget)?
            }
        };
        if data.len() < declared {
            return Err(ImportError::new(
                path,
                format!(
                    "buffer {} holds {} bytes, the file declares {declared}",
                    buffer.index(),
                    data.len(),
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Reads one triangle primitive (from its accessors, or from its Draco stream), validating types
/// and sizes before anything reads the buffers.
fn read_primitive(
    path: &Path,
    document: &gltf::Document,
    prim: &gltf::Primitive,
    name: &str,
    buffers: &[Vec<u8>],
    budget: &mut Budget,
) -> Result<Option<MeshGeometry>, ImportError> {
    let geometry = match gltf_compressed::decode_draco(path, document, prim, name, buffers, budget)?
    {
        Some(d) => MeshGeometry {
            positions: d.positions,
            normals: d.normals,
            uvs: d.uvs,
            uvs1: None,
            tangents: None,
            indices: d.indices,
        },
        None => match read_accessors(path, prim, name, buffers, budget)? {
            Some(geometry) => geometry,
            None => return Ok(None),
        },
    };
    check_positions(path, name, &geometry.positions)?;
    let n = geometry.positions.len();
    let MeshGeometry {
        positions,
        normals,
        uvs,
        uvs1,
        tangents,
        indices,
    } = geometry;
    let normals = normals.filter(|v| v.len() == n);
    let uvs = uvs.filter(|v| v.len() == n);
    let uvs1 = uvs1.filter(|v| v.len() == n);
    let tangents = tangents.filter(|v| v.len() == n);
    if !indices.len().is_multiple_of(3) {
        return Err(ImportError::new(
            path,
            format!(
                "mesh '{name}' has {} indices, not a multiple of 3",
                indices.len()
            ),
        ));
    }
    check_indices(path, name, &indices, n)?;
    Ok(Some(MeshGeometry {
        positions,
        normals,
        uvs,
        uvs1,
        tangents,
        indices,
    }))
}

/// What an attribute the importer reads may be stored as (glTF 2.0 with `KHR_mesh_quantization`).
struct AttributeRule {
    what: &'static str,
    dims: Dimensions,
    /// Component types allowed, each with whether it must be normalized.
    types: &'static [(DataType, Option<bool>)],
    expected: &'static str,
}

/// Floats, or (`KHR_mesh_quantization`) 8- or 16-bit integers, normalized or not.
const FLOAT_OR_SMALL_INTEGER: &[(DataType, Option<bool>)] = &[
    (DataType::F32, Some(false)),
    (DataType::I8, None),
    (DataType::U8, None),
    (DataType::I16, None),
    (DataType::U16, None),
];

const POSITION: AttributeRule = AttributeRule {
    what: "POSITION",
    dims: Dimensions::Vec3,
    types: FLOAT_OR_SMALL_INTEGER,
    expected: "3 floats, or 3 8- or 16-bit integers (KHR_mesh_quantization)",
};

const NORMAL: AttributeRule = AttributeRule {
    what: "NORMAL",
    dims: Dimensions::Vec3,
    types: &[
        (DataType::F32, Some(false)),
        (DataType::I8, Some(true)),
        (DataType::I16, Some(true)),
    ],
    expected: "3 floats, or 3 normalized signed 8- or 16-bit integers",
};

const TANGENT: AttributeRule = AttributeRule {
    what: "TANGENT",
    dims: Dimensions::Vec4,
    types: &[
        (DataType::F32, Some(false)),
        (DataType::I8, Some(true)),
        (DataType::I16, Some(true)),
    ],
    expected: "4 floats, or 4 normalized signed 8- or 16-bit integers",
};

const TEXCOORD: AttributeRule = AttributeRule {
    what: "TEXCOORD_0",
    dims: Dimensions::Vec2,
    types: FLOAT_OR_SMALL_INTEGER,
    expected: "2 floats, or 2 8- or 16-bit integers",
};

const TEXCOORD_1: AttributeRule = AttributeRule {
    what: "TEXCOORD_1",
    ..TEXCOORD
};

/// Refuses an accessor whose shape or component type does not fit what it is read as.
fn check_type(
    path: &Path,
    name: &str,
    acc: &gltf::Accessor,
    rule: &AttributeRule,
) -> Result<(), ImportError> {
    let fits = acc.dimensions() == rule.dims
        && rule
            .types
            .iter()
            .any(|&(t, norm)| t == acc.data_type() && norm.is_none_or(|n| n == acc.normalized()));
    if fits {
        return Ok(());
    }
    Err(ImportError::new(
        path,
        format!(
            "mesh '{name}': its {} accessor {} holds {}, where {} are expected",
            rule.what,
            acc.index(),
            describe_type(acc),
            rule.expected
        ),
    ))
}

fn describe_type(acc: &gltf::Accessor) -> String {
    format!(
        "{:?} {:?}{}",
        acc.dimensions(),
        acc.data_type(),
        if acc.normalized() { " normalized" } else { "" }
    )
}

/// A primitive's geometry from its accessors (`None` without positions).
fn read_accessors(
    path: &Path,
    prim: &gltf::Primitive,
    name: &str,
    buffers: &[Vec<u8>],
    budget: &mut Budget,
) -> Result<Option<MeshGeometry>, ImportError> {
    for (_, accessor) in prim.attributes() {
        check_accessor(path, name, &accessor, buffers)?;
    }
    if let Some(acc) = prim.indices() {
        check_accessor(path, name, &acc, buffers)?;
        let fits = acc.dimensions() == Dimensions::Scalar
            && matches!(
                acc.data_type(),
                DataType::U8 | DataType::U16 | DataType::U32
            );
        if !fits {
            return Err(ImportError::new(
                path,
                format!(
                    "mesh '{name}': its index accessor {} holds {}, where unsigned 8-, 16- or \
                     32-bit scalars are expected",
                    acc.index(),
                    describe_type(&acc)
                ),
            ));
        }
    }
    let Some(acc) = prim.get(&Semantic::Positions) else {
        return Ok(None);
    };
    check_type(path, name, &acc, &POSITION)?;
    let normals_acc = prim.get(&Semantic::Normals);
    if let Some(a) = &normals_acc {
        check_type(path, name, a, &NORMAL)?;
    }
    let uvs_acc = prim.get(&Semantic::TexCoords(0));
    if let Some(a) = &uvs_acc {
        check_type(path, name, a, &TEXCOORD)?;
    }
    let uvs1_acc = prim.get(&Semantic::TexCoords(1));
    if let Some(a) = &uvs1_acc {
        check_type(path, name, a, &TEXCOORD_1)?;
    }
    let tangents_acc = prim.get(&Semantic::Tangents);
    if let Some(a) = &tangents_acc {
        check_type(path, name, a, &TANGENT)?;
    }
    let vertices = acc.count();
    let index_count = prim.indices().map_or(vertices, |a| a.count());
    budget.charge_elements(
        vertices,
        12 + normals_acc.as_ref().map_or(0, |_| 12)
            + uvs_acc.as_ref().map_or(0, |_| 8)
            + uvs1_acc.as_ref().map_or(0, |_| 8)
            + tangents_acc.as_ref().map_or(0, |_| 16),
        || format!("mesh '{name}''s {vertices} vertices"),
    )?;
    budget.charge_elements(index_count, 4, || {
        format!("mesh '{name}''s {index_count} indices")
    })?;
    let unreadable = || {
        ImportError::new(
            path,
            format!("mesh '{name}': an accessor could not be read"),
        )
    };
    let positions = read_floats::<3>(&acc, buffers).ok_or_else(unreadable)?;
    // Quantized normals are only near unit length.
    let normals = match normals_acc {
        Some(a) => Some(
            read_floats::<3>(&a, buffers)
                .ok_or_else(unreadable)?
                .into_iter()
                .map(|c| glam::Vec3::from(c).normalize_or_zero().to_array())
                .collect(),
        ),
        None => None,
    };
    let uvs = match uvs_acc {
        Some(a) => Some(read_floats::<2>(&a, buffers).ok_or_else(unreadable)?),
        None => None,
    };
    let uvs1 = match uvs1_acc {
        Some(a) => Some(read_floats::<2>(&a, buffers).ok_or_else(unreadable)?),
        None => None,
    };
    // Quantized tangents are only near unit length, and w is a sign; a file with a tangent that
    // is no direction has its tangents made from the UVs instead, as for a file without.
    let tangents = match tangents_acc {
        Some(a) => read_floats::<4>(&a, buffers)
            .ok_or_else(unreadable)?
            .into_iter()
            .map(|[x, y, z, w]| {
                let t = glam::Vec3::new(x, y, z).try_normalize()?;
                Some([t.x, t.y, t.z, if w < 0.0 { -1.0 } else { 1.0 }])
            })
            .collect::<Option<Vec<_>>>(),
        None => None,
    };
    let indices = match prim.indices() {
        Some(a) => read_indices(&a, buffers).ok_or_else(unreadable)?,
        None => (0..positions.len() as u32).collect(),
    };
    Ok(Some(MeshGeometry {
        positions,
        normals,
        uvs,
        uvs1,
        tangents,
        indices,
    }))
}

/// An index accessor's values (unsigned scalars of 1, 2 or 4 bytes, checked before); its range
/// must have been checked against `buffers`.
fn read_indices(acc: &gltf::Accessor, buffers: &[Vec<u8>]) -> Option<Vec<u32>> {
    let view = acc.view()?;
    let data = buffers.get(view.buffer().index())?;
    let width = acc.data_type().size();
    let stride = view.stride().unwrap_or(width);
    let start = view.offset() + acc.offset();
    (0..acc.count())
        .map(|k| {
            let at = start + k * stride;
            let b = data.get(at..at + width)?;
            Some(match width {
                1 => u32::from(b[0]),
                2 => u32::from(u16::from_le_bytes([b[0], b[1]])),
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            })
        })
        .collect()
}

fn check_accessor(
    path: &Path,
    name: &str,
    acc: &gltf::Accessor,
    buffers: &[Vec<u8>],
) -> Result<(), ImportError> {
    let count = acc.count();
    if count == 0 || count > MAX_ELEMENTS {
        return Err(ImportError::new(
            path,
            format!("mesh '{name}' has an accessor of {count} elements"),
        ));
    }
    if acc.sparse().is_some() {
        return Err(ImportError::new(
            path,
            format!("mesh '{name}' uses sparse accessors, which are not supported"),
        ));
    }
    let Some(view) = acc.view() else {
        return Err(ImportError::new(
            path,
            format!("mesh '{name}' has an accessor without a buffer view"),
        ));
    };
    let size = acc.size();
    let stride = view.stride().unwrap_or(size);
    let needed = acc.offset() as u128 + stride as u128 * (count as u128 - 1) + size as u128;
    let buffer_len = buffers.get(view.buffer().index()).map_or(0, Vec::len) as u128;
    if needed > view.length() as u128 || view.offset() as u128 + view.length() as u128 > buffer_len
    {
        return Err(ImportError::new(
            path,
            format!(
                "mesh '{name}': accessor {} reads past the end of its buffer",
                acc.index()
            ),
        ));
    }
    Ok(())
}

/// A node's light, if its values are ones a light can take; otherwise a warning naming the node.
/// A node's camera, if its values make one (else a warning naming the node).
fn checked_camera(
    c: &gltf::Camera,
    node: &str,
    warnings: &mut Vec<String>,
) -> Option<ImportedCamera> {
    let camera = match c.projection() {
        gltf::camera::Projection::Perspective(p) => ImportedCamera::Perspective {
            yfov: p.yfov(),
            near: p.znear(),
            far: p.zfar(),
            aspect: p.aspect_ratio(),
        },
        gltf::camera::Projection::Orthographic(o) => ImportedCamera::Orthographic {
            ymag: o.ymag(),
            xmag: o.xmag(),
            near: o.znear(),
            far: o.zfar(),
        },
    };
    let ok = match camera {
        ImportedCamera::Perspective {
            yfov,
            near,
            far,
            aspect,
        } => {
            yfov.is_finite()
                && yfov > 0.0
                && yfov < std::f32::consts::PI
                && near.is_finite()
                && near > 0.0
                && far.is_none_or(|f| f.is_finite() && f > near)
                && aspect.is_none_or(|a| a.is_finite() && a > 0.0)
        }
        ImportedCamera::Orthographic {
            ymag,
            xmag,
            near,
            far,
        } => {
            [ymag, xmag, near, far].iter().all(|v| v.is_finite())
                && ymag != 0.0
                && xmag != 0.0
                && near >= 0.0
                && far > near
        }
    };
    if !ok {
        warnings.push(format!(
            "'{node}': its camera has a field of view, size or near and far planes that make no \
             view, skipped"
        ));
        return None;
    }
    Some(camera)
}

fn checked_light(
    l: &gltf::khr_lights_punctual::Light,
    node: &str,
    warnings: &mut Vec<String>,
) -> Option<ImportedLight> {
    use gltf::khr_lights_punctual::Kind;
    let color = l.color();
    let intensity = l.intensity();
    if !color
        .iter()
        .chain([&intensity])
        .all(|v| v.is_finite() && *v >= 0.0)
    {
        warnings.push(format!(
            "'{node}': its light has a negative or non-finite colour or intensity, skipped"
        ));
        return None;
    }
    let range = match l.range() {
        Some(r) if r.is_finite() && r > 0.0 => Some(r),
        Some(r) => {
            warnings.push(format!(
                "'{node}': its light's range {r} is not positive, ignored"
            ));
            None
        }
        None => None,
    };
    let kind = match l.kind() {
        Kind::Point => ImportedLightKind::Point,
        Kind::Directional => ImportedLightKind::Directional,
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            if !(inner_cone_angle.is_finite() && outer_cone_angle.is_finite()) {
                warnings.push(format!(
                    "'{node}': its spot light's cone is not finite, skipped"
                ));
                return None;
            }
            let outer = outer_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2);
            ImportedLightKind::Spot {
                inner_angle: inner_cone_angle.clamp(0.0, outer),
                outer_angle: outer,
            }
        }
    };
    Some(ImportedLight {
        kind,
        color,
        intensity,
        range,
    })
}
