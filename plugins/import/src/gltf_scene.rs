//! glTF 2.0 (.gltf with external or embedded buffers, and .glb).

use crate::gltf_compressed::{self, read_floats};
use crate::sandbox::read_uri;
use crate::texture::ImageCache;
use crate::{
    ImportError, ImportedMaterial, ImportedMesh, ImportedNode, ImportedScene, MAX_ELEMENTS,
    check_indices, check_positions,
};
use glam::Mat4;
use gltf::Semantic;
use gltf::mesh::Mode;
use std::collections::HashMap;
use std::path::Path;

/// Loads the default scene of a glTF file (or all root nodes of the first scene), with node
/// transforms applied down the hierarchy.
pub fn load_gltf(path: &Path) -> Result<ImportedScene, ImportError> {
    let bytes = std::fs::read(path).map_err(|e| ImportError::new(path, e.to_string()))?;
    let gltf = gltf_compressed::parse(path, &bytes, |e| describe(e, &bytes))?;
    let mut buffers = load_buffers(path, &gltf)?;
    gltf_compressed::decode_meshopt_views(path, &gltf.document, &mut buffers)?;
    let mut scene = ImportedScene::default();
    let mut images = ImageCache::default();
    for m in gltf.document.materials() {
        let pbr = m.pbr_metallic_roughness();
        let e = m.emissive_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        scene.materials.push(ImportedMaterial {
            name: m.name().map_or_else(
                || format!("material {}", m.index().unwrap_or(0)),
                str::to_owned,
            ),
            base_color: pbr.base_color_factor(),
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            emissive: [e[0] * strength, e[1] * strength, e[2] * strength],
            base_color_texture: pbr.base_color_texture().and_then(|info| {
                images.base_color(
                    path,
                    &buffers,
                    &info,
                    &mut scene.textures,
                    &mut scene.warnings,
                )
            }),
        });
    }
    let default_material = scene.materials.len();
    let mut used_default = false;
    // (mesh, primitive) -> the first entry of `scene.meshes` read from it: a mesh placed by
    // several nodes is read once and marked as the same.
    let mut read: HashMap<(usize, usize), usize> = HashMap::new();
    let mut first_error: Option<ImportError> = None;
    let root_scene = gltf
        .document
        .default_scene()
        .or_else(|| gltf.document.scenes().next());
    let Some(root_scene) = root_scene else {
        return Err(ImportError::new(path, "the file has no scene"));
    };
    // (node, parent's world transform, depth, parent's index in scene.nodes). Popped depth first,
    // so a node is always listed after its parent.
    let mut stack: Vec<(gltf::Node, Mat4, usize, Option<usize>)> = root_scene
        .nodes()
        .map(|n| (n, Mat4::IDENTITY, 0, None))
        .collect();
    while let Some((node, parent, depth, parent_index)) = stack.pop() {
        if depth > 256 {
            return Err(ImportError::new(
                path,
                "the node hierarchy is deeper than 256 levels (a cycle?)",
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(ImportError::new(
                path,
                format!("node {} has a non-finite transform", node.index()),
            ));
        }
        let step = node
            .name()
            .map_or_else(|| format!("#{}", node.index()), |n| n.replace('/', "_"));
        let key = match parent_index {
            Some(p) => format!("{}/{step}", scene.nodes[p].key),
            None => step,
        };
        let index = scene.nodes.len();
        scene.nodes.push(ImportedNode {
            name: node
                .name()
                .map_or_else(|| format!("node {}", node.index()), str::to_owned),
            parent: parent_index,
            local,
            key,
        });
        if let Some(mesh) = node.mesh() {
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
                let key = (mesh.index(), prim.index());
                let first = read.get(&key).copied();
                let m = match first {
                    Some(i) => Some(ImportedMesh {
                        name: name.clone(),
                        same_as: Some(i),
                        ..scene.meshes[i].clone()
                    }),
                    None => match read_primitive(path, &gltf.document, &prim, &name, &buffers) {
                        Ok(m) => m,
                        Err(e) => {
                            // One bad mesh does not sink the file: the rest import, this one is
                            // named (and the whole file fails only when no mesh is left).
                            scene.warnings.push(format!("skipped: {}", e.problem));
                            first_error.get_or_insert(e);
                            None
                        }
                    },
                };
                match m {
                    Some(mut m) => {
                        if first.is_none() {
                            read.insert(key, scene.meshes.len());
                        }
                        m.transform = world;
                        m.node = Some(index);
                        m.material = Some(prim.material().index().unwrap_or_else(|| {
                            used_default = true;
                            default_material
                        }));
                        scene.meshes.push(m);
                    }
                    None => scene
                        .warnings
                        .push(format!("'{name}' has no positions, skipped")),
                }
            }
        }
        for child in node.children() {
            stack.push((child, world, depth + 1, Some(index)));
        }
    }
    if let Some(e) = first_error
        && scene.meshes.is_empty()
    {
        return Err(e);
    }
    if used_default {
        scene.materials.push(ImportedMaterial::default());
    }
    Ok(scene)
}

fn describe(e: &gltf::Error, bytes: &[u8]) -> String {
    if let gltf::Error::Validation(errors) = e {
        // Name the extension the file requires, which is the usual reason for refusal.
        if let Ok(json) = gltf::json::deserialize::from_slice::<gltf::json::Root>(json_chunk(bytes))
        {
            let unsupported: Vec<&str> = json
                .extensions_required
                .iter()
                .map(String::as_str)
                .filter(|x| {
                    !gltf::json::extensions::ENABLED_EXTENSIONS.contains(x)
                        && !gltf_compressed::OWN_EXTENSIONS.contains(x)
                })
                .collect();
            if !unsupported.is_empty() {
                return format!(
                    "requires unsupported glTF extension(s): {}",
                    unsupported.join(", ")
                );
            }
        }
        let list: Vec<String> = errors
            .iter()
            .take(3)
            .map(|(p, err)| format!("{}: {err}", p.as_str()))
            .collect();
        return format!("invalid glTF: {}", list.join("; "));
    }
    format!("not a readable glTF file: {e}")
}

/// The JSON part of a .glb, or the whole slice for a .gltf.
fn json_chunk(bytes: &[u8]) -> &[u8] {
    if bytes.len() >= 20 && &bytes[..4] == b"glTF" {
        let len = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
        if let Some(chunk) = bytes.get(20..20 + len) {
            return chunk;
        }
    }
    bytes
}

fn load_buffers(path: &Path, gltf: &gltf::Gltf) -> Result<Vec<Vec<u8>>, ImportError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    for buffer in gltf.document.buffers() {
        if gltf_compressed::is_fallback(&buffer) {
            // Filled by the compressed views that decode into it.
            if buffer.length() > MAX_ELEMENTS * 16 {
                return Err(ImportError::new(
                    path,
                    format!(
                        "buffer {} declares {} bytes of compressed data",
                        buffer.index(),
                        buffer.length()
                    ),
                ));
            }
            out.push(vec![0u8; buffer.length()]);
            continue;
        }
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                ImportError::new(
                    path,
                    "a buffer refers to the GLB binary chunk, which is missing",
                )
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(path, dir, uri, "buffer")?,
        };
        if data.len() < buffer.length() {
            return Err(ImportError::new(
                path,
                format!(
                    "buffer {} holds {} bytes, the file declares {}",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Reads one triangle primitive (from its accessors, or from its Draco stream), validating sizes
/// before anything reads the buffers.
fn read_primitive(
    path: &Path,
    document: &gltf::Document,
    prim: &gltf::Primitive,
    name: &str,
    buffers: &[Vec<u8>],
) -> Result<Option<ImportedMesh>, ImportError> {
    let (positions, normals, uvs, indices) =
        match gltf_compressed::decode_draco(path, document, prim, name, buffers)? {
            Some(d) => (d.positions, d.normals, d.uvs, d.indices),
            None => match read_accessors(path, prim, name, buffers)? {
                Some(geometry) => geometry,
                None => return Ok(None),
            },
        };
    check_positions(path, name, &positions)?;
    let n = positions.len();
    let normals = normals.filter(|v| v.len() == n);
    let uvs = uvs.filter(|v| v.len() == n);
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
    Ok(Some(ImportedMesh {
        name: name.to_owned(),
        transform: Mat4::IDENTITY,
        node: None,
        positions,
        normals,
        uvs,
        indices,
        material: None,
        same_as: None,
    }))
}

/// Positions, normals, UV set 0 and indices as a primitive's accessors store them.
type Geometry = (
    Vec<[f32; 3]>,
    Option<Vec<[f32; 3]>>,
    Option<Vec<[f32; 2]>>,
    Vec<u32>,
);

/// A primitive's geometry from its accessors (`None` without positions).
fn read_accessors(
    path: &Path,
    prim: &gltf::Primitive,
    name: &str,
    buffers: &[Vec<u8>],
) -> Result<Option<Geometry>, ImportError> {
    for (_, accessor) in prim.attributes() {
        check_accessor(path, name, &accessor, buffers)?;
    }
    if let Some(acc) = prim.indices() {
        check_accessor(path, name, &acc, buffers)?;
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let Some(acc) = prim.get(&Semantic::Positions) else {
        return Ok(None);
    };
    let positions = read_floats::<3>(&acc, buffers).ok_or_else(|| {
        ImportError::new(
            path,
            format!(
                "mesh '{name}': positions stored as {:?} {:?}",
                acc.data_type(),
                acc.dimensions()
            ),
        )
    })?;
    // Quantized normals are only near unit length.
    let normals: Option<Vec<[f32; 3]>> = prim
        .get(&Semantic::Normals)
        .and_then(|a| read_floats::<3>(&a, buffers))
        .map(|v| {
            v.into_iter()
                .map(|c| glam::Vec3::from(c).normalize_or_zero().to_array())
                .collect()
        });
    let uvs: Option<Vec<[f32; 2]>> = prim
        .get(&Semantic::TexCoords(0))
        .and_then(|a| read_floats::<2>(&a, buffers));
    let indices: Vec<u32> = match reader.read_indices() {
        Some(r) => r.into_u32().collect(),
        None => (0..positions.len() as u32).collect(),
    };
    Ok(Some((positions, normals, uvs, indices)))
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
