//! The glTF extensions this importer implements itself, because the `gltf` crate does not:
//! `EXT_meshopt_compression` (buffer views stored compressed, decoded with meshoptimizer's own
//! decoder), `KHR_mesh_quantization` (vertex attributes stored as normalized or plain integers) and
//! `KHR_draco_mesh_compression` (a primitive's geometry as one Draco stream).

use crate::types::budget::Budget;
use crate::types::error::{ImportError, MAX_ELEMENTS};
use gltf::accessor::{DataType, Dimensions};
use gltf::json::Value;
use std::path::Path;

/// Required extensions the importer handles; the rest are refused by name.
pub(crate) const OWN_EXTENSIONS: &[&str] = &[
    "EXT_meshopt_compression",
    "KHR_mesh_quantization",
    "KHR_draco_mesh_compression",
];

const MESHOPT: &str = "EXT_meshopt_compression";

/// Bytes charged per JSON object (`{`) and array (`[`) before a document is parsed: the most a
/// parsed glTF object or array takes beside its text (the largest `gltf_json` struct, with room).
const PARSED_OBJECT_BYTES: u64 = 768;
const PARSED_ARRAY_BYTES: u64 = 64;

/// What one more element of a parsed array or object takes: a JSON value (32 bytes), and the
/// growth of its vector (doubling: as much again).
const PARSED_ELEMENT_BYTES: u64 = 64;

/// What one member of a parsed object takes beyond its value: its key's string and map entry.
const PARSED_MEMBER_BYTES: u64 = 64;

/// Parses a .gltf or .glb from its bytes, accepting the extensions in [`OWN_EXTENSIONS`] as
/// required ones. A GLB's binary chunk becomes the blob in place (the file's bytes are held once).
pub(crate) fn parse(
    path: &Path,
    mut bytes: Vec<u8>,
    budget: &mut Budget,
) -> Result<gltf::Gltf, ImportError> {
    let (json, blob) = if bytes.starts_with(b"glTF") {
        let glb = gltf::Glb::from_slice(&bytes)
            .map_err(|e| ImportError::new(path, format!("not a readable GLB file: {e}")))?;
        let json = range_in(&bytes, &glb.json);
        let bin = glb.bin.as_deref().map(|b| range_in(&bytes, b));
        let root = parse_json(path, &bytes[json], budget)?;
        let blob = bin.map(|bin| {
            bytes.truncate(bin.end);
            bytes.drain(..bin.start);
            bytes
        });
        (root, blob)
    } else {
        (parse_json(path, &bytes, budget)?, None)
    };
    let mut root = json;
    let unsupported: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|x| {
            !gltf::json::extensions::ENABLED_EXTENSIONS.contains(x) && !OWN_EXTENSIONS.contains(x)
        })
        .collect();
    if !unsupported.is_empty() {
        return Err(ImportError::new(
            path,
            format!(
                "requires unsupported glTF extension(s): {}",
                unsupported.join(", ")
            ),
        ));
    }
    root.extensions_required
        .retain(|x| !OWN_EXTENSIONS.contains(&x.as_str()));
    // The gltf crate asks every accessor for a buffer view; those of a Draco-compressed primitive
    // have none (the stream holds their data). They name the stream's view while the document is
    // validated, and none again after: every accessor read is checked against its buffer first.
    let mut patched = Vec::new();
    for prim in root.meshes.iter().flat_map(|m| &m.primitives) {
        let Some(view) = prim
            .extensions
            .as_ref()
            .and_then(|e| e.others.get(DRACO))
            .and_then(|d| d.get("bufferView"))
            .and_then(Value::as_u64)
            .and_then(|v| u32::try_from(v).ok())
        else {
            continue;
        };
        for a in prim.attributes.values().chain(prim.indices.iter()) {
            if root
                .accessors
                .get(a.value())
                .is_some_and(|acc| acc.buffer_view.is_none())
            {
                patched.push((a.value(), view));
            }
        }
    }
    guard_validation(path, &root)?;
    for &(a, view) in &patched {
        root.accessors[a].buffer_view = Some(gltf::json::Index::new(view));
    }
    let mut root = gltf::Document::from_json(root)
        .map_err(|e| ImportError::new(path, describe(&e)))?
        .into_json();
    for &(a, _) in &patched {
        root.accessors[a].buffer_view = None;
    }
    let document = gltf::Document::from_json_without_validation(root);
    Ok(gltf::Gltf { document, blob })
}

/// What the `gltf` crate would panic on instead of reporting: a primitive's accessor index out of
/// range (its validation reads POSITION's accessor before checking the index), and an image with
/// neither a URI nor a buffer view and MIME type.
fn guard_validation(path: &Path, root: &gltf::json::Root) -> Result<(), ImportError> {
    let accessors = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let named = prim
                .attributes
                .values()
                .chain(prim.indices.iter())
                .map(|a| a.value());
            if let Some(a) = named.into_iter().find(|&a| a >= accessors) {
                return Err(ImportError::new(
                    path,
                    format!(
                        "mesh {m}, primitive {p} names accessor {a}, and the file has {accessors}"
                    ),
                ));
            }
        }
    }
    for (i, image) in root.images.iter().enumerate() {
        let whole = match (&image.buffer_view, &image.uri) {
            (Some(_), _) => image.mime_type.is_some(),
            (None, uri) => uri.is_some(),
        };
        if !whole {
            return Err(ImportError::new(
                path,
                format!(
                    "image {i} has neither a URI nor a buffer view with a MIME type, so it \
                     cannot be read"
                ),
            ));
        }
    }
    Ok(())
}

/// Where `part`, a slice borrowed from `whole`, lies in it.
fn range_in(whole: &[u8], part: &[u8]) -> std::ops::Range<usize> {
    let start = part.as_ptr() as usize - whole.as_ptr() as usize;
    start..start + part.len()
}

/// The glTF JSON, charged to `budget` before it is parsed (objects cost more parsed than as text).
fn parse_json(
    path: &Path,
    json: &[u8],
    budget: &mut Budget,
) -> Result<gltf::json::Root, ImportError> {
    // Every value becomes one: objects and arrays their containers, each comma one more
    // element (an array of a million numbers in an extension nobody reads is parsed whole, into
    // values of 32 bytes), each colon a member with its key; strings copy their text.
    let count = |c: u8| json.iter().filter(|&&b| b == c).count() as u64;
    let (objects, arrays) = (count(b'{'), count(b'['));
    let (elements, members) = (count(b','), count(b':'));
    budget.charge(
        objects
            .saturating_mul(PARSED_OBJECT_BYTES)
            .saturating_add(arrays.saturating_mul(PARSED_ARRAY_BYTES))
            .saturating_add(elements.saturating_mul(PARSED_ELEMENT_BYTES))
            .saturating_add(members.saturating_mul(PARSED_MEMBER_BYTES))
            .saturating_add(json.len() as u64),
        || format!("parsing its JSON ({objects} objects, {elements} elements)"),
    )?;
    gltf::json::deserialize::from_slice(json)
        .map_err(|e| ImportError::new(path, format!("not a readable glTF file: {e}")))
}

/// A validation failure, its first few problems named.
fn describe(e: &gltf::Error) -> String {
    if let gltf::Error::Validation(errors) = e {
        let list: Vec<String> = errors
            .iter()
            .take(3)
            .map(|(p, err)| format!("{}: {err}", p.as_str()))
            .collect();
        return format!("invalid glTF: {}", list.join("; "));
    }
    format!("not a readable glTF file: {e}")
}

/// Whether `buffer` is the placeholder that `EXT_meshopt_compression` decodes into (it has no data
/// of its own).
pub(crate) fn is_fallback(buffer: &gltf::Buffer) -> bool {
    buffer
        .extension_value(MESHOPT)
        .and_then(|e| e.get("fallback"))
        .and_then(Value::as_bool)
        == Some(true)
}

/// Decodes every compressed buffer view into its place in its (fallback) buffer, so that accessors
/// read it as if it had been stored plainly. Every size and range is checked before meshoptimizer
/// sees it: its decoders are safe on untrusted data, but assert on impossible strides.
pub(crate) fn decode_meshopt_views(
    path: &Path,
    document: &gltf::Document,
    buffers: &mut [Vec<u8>],
    budget: &mut Budget,
) -> Result<(), ImportError> {
    for view in document.views() {
        let Some(ext) = view.extension_value(MESHOPT) else {
            continue;
        };
        let i = view.index();
        let bad =
            |what: &str| ImportError::new(path, format!("buffer view {i} ({MESHOPT}): {what}"));
        let field = |k: &str| ext.get(k).and_then(Value::as_u64);
        let (Some(source), Some(length), Some(stride), Some(count)) = (
            field("buffer"),
            field("byteLength"),
            field("byteStride"),
            field("count"),
        ) else {
            return Err(bad("buffer, byteLength, byteStride or count is missing"));
        };
        let offset = field("byteOffset").unwrap_or(0);
        let mode = ext.get("mode").and_then(Value::as_str).unwrap_or("");
        let filter = ext.get("filter").and_then(Value::as_str).unwrap_or("NONE");
        if count == 0 || count > MAX_ELEMENTS as u64 || stride == 0 || stride > 256 {
            return Err(bad(&format!("{count} elements of {stride} bytes")));
        }
        let (count, stride) = (count as usize, stride as usize);
        let size = count * stride;
        if size > view.length() {
            return Err(bad(&format!(
                "decodes to {size} bytes, the view holds {}",
                view.length()
            )));
        }
        let src = buffers
            .get(source as usize)
            .and_then(|b| b.get(offset as usize..offset.checked_add(length)? as usize))
            .ok_or_else(|| bad("its compressed bytes lie past the end of their buffer"))?;
        budget.charge(size as u64, || format!("decoding buffer view {i}"))?;
        let mut out = vec![0u8; size];
        // SAFETY: `out` holds count × stride bytes, `src` is a live slice, and the sizes and
        // strides meshoptimizer asserts on are checked just before each call.
        let code = unsafe {
            match mode {
                "ATTRIBUTES" if stride % 4 == 0 => meshopt::ffi::meshopt_decodeVertexBuffer(
                    out.as_mut_ptr().cast(),
                    count,
                    stride,
                    src.as_ptr(),
                    src.len(),
                ),
                "TRIANGLES" if (stride == 2 || stride == 4) && count % 3 == 0 => {
                    meshopt::ffi::meshopt_decodeIndexBuffer(
                        out.as_mut_ptr().cast(),
                        count,
                        stride,
                        src.as_ptr(),
                        src.len(),
                    )
                }
                "INDICES" if stride == 2 || stride == 4 => {
                    meshopt::ffi::meshopt_decodeIndexSequence(
                        out.as_mut_ptr().cast(),
                        count,
                        stride,
                        src.as_ptr(),
                        src.len(),
                    )
                }
                _ => return Err(bad(&format!("mode '{mode}' with {stride}-byte elements"))),
            }
        };
        if code != 0 {
            return Err(bad("the compressed data does not decode"));
        }
        // SAFETY: as above; each filter's stride rule is checked first.
        unsafe {
            let data = out.as_mut_ptr().cast();
            match filter {
                "NONE" => {}
                "OCTAHEDRAL" if stride == 4 || stride == 8 => {
                    meshopt::ffi::meshopt_decodeFilterOct(data, count, stride)
                }
                "QUATERNION" if stride == 8 => {
                    meshopt::ffi::meshopt_decodeFilterQuat(data, count, stride)
                }
                "EXPONENTIAL" if stride % 4 == 0 => {
                    meshopt::ffi::meshopt_decodeFilterExp(data, count, stride)
                }
                "COLOR" if stride == 4 || stride == 8 => {
                    meshopt::ffi::meshopt_decodeFilterColor(data, count, stride)
                }
                _ => return Err(bad(&format!("filter '{filter}' on {stride}-byte elements"))),
            }
        }
        let dest = buffers
            .get_mut(view.buffer().index())
            .and_then(|b| b.get_mut(view.offset()..view.offset().checked_add(size)?))
            .ok_or_else(|| bad("its place lies past the end of its buffer"))?;
        dest.copy_from_slice(&out);
    }
    Ok(())
}

/// An attribute as `N` floats per element, whatever its storage: floats, or (as
/// `KHR_mesh_quantization` allows) 8- or 16-bit integers, normalized or not. `None` for a type or
/// shape that is not `N` numbers. The accessor's range must have been checked against `buffers`.
pub(crate) fn read_floats<const N: usize>(
    acc: &gltf::Accessor,
    buffers: &[Vec<u8>],
) -> Option<Vec<[f32; N]>> {
    // Callers charge `count × N × 4` bytes to the budget before.
    let dims = match acc.dimensions() {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        _ => return None,
    };
    if dims != N {
        return None;
    }
    let view = acc.view()?;
    let data = buffers.get(view.buffer().index())?;
    let stride = view.stride().unwrap_or(acc.size());
    let start = view.offset() + acc.offset();
    let normalized = acc.normalized();
    let width = acc.data_type().size();
    let read = |at: usize| -> Option<f32> {
        let b = data.get(at..at + width)?;
        Some(match acc.data_type() {
            DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            DataType::I8 if normalized => (b[0] as i8 as f32 / 127.0).max(-1.0),
            DataType::I8 => b[0] as i8 as f32,
            DataType::U8 if normalized => b[0] as f32 / 255.0,
            DataType::U8 => b[0] as f32,
            DataType::I16 => {
                let v = i16::from_le_bytes([b[0], b[1]]) as f32;
                if normalized {
                    (v / 32767.0).max(-1.0)
                } else {
                    v
                }
            }
            DataType::U16 => {
                let v = u16::from_le_bytes([b[0], b[1]]) as f32;
                if normalized { v / 65535.0 } else { v }
            }
            DataType::U32 => return None,
        })
    };
    (0..acc.count())
        .map(|k| {
            let at = start + k * stride;
            let mut out = [0.0f32; N];
            for (c, v) in out.iter_mut().enumerate() {
                *v = read(at + c * width)?;
            }
            Some(out)
        })
        .collect()
}

const DRACO: &str = "KHR_draco_mesh_compression";

/// What a decoded Draco point costs, inside the decoder and copied out (position, normal, UV).
const DRACO_BYTES_PER_POINT: u64 = 2 * (12 + 12 + 8) + 16;
/// What a decoded Draco face costs: its indices, and the decoder's corner tables.
const DRACO_BYTES_PER_FACE: u64 = 12 + 64;

/// A primitive's geometry decoded from its `KHR_draco_mesh_compression` stream (draco-core, a pure
/// Rust decoder): positions, normals and UV set 0 per point, and triangle indices. `None` when the
/// primitive is not Draco-compressed.
pub(crate) struct DracoGeometry {
    /// Positions per point.
    pub positions: Vec<[f32; 3]>,
    pub normals: Option<Vec<[f32; 3]>>,
    pub uvs: Option<Vec<[f32; 2]>>,
    pub indices: Vec<u32>,
}

/// Decodes `prim`'s Draco stream, if it has one; every failure names the mesh.
pub(crate) fn decode_draco(
    path: &Path,
    document: &gltf::Document,
    prim: &gltf::Primitive,
    name: &str,
    buffers: &[Vec<u8>],
    budget: &mut Budget,
) -> Result<Option<DracoGeometry>, ImportError> {
    let Some(ext) = prim.extension_value(DRACO) else {
        return Ok(None);
    };
    let bad = |what: &str| ImportError::new(path, format!("mesh '{name}' ({DRACO}): {what}"));
    let view = ext
        .get("bufferView")
        .and_then(Value::as_u64)
        .and_then(|i| document.views().nth(i as usize))
        .ok_or_else(|| bad("its bufferView is missing or unknown"))?;
    let bytes = buffers
        .get(view.buffer().index())
        .and_then(|b| b.get(view.offset()..view.offset().checked_add(view.length())?))
        .ok_or_else(|| bad("its bufferView lies past the end of its buffer"))?;
    // The decoder's own ceilings come from what is left of the budget: what it decodes (the
    // attribute values, and per face its connectivity tables) and then what is copied out of it.
    let left = budget.remaining();
    let mut limits = draco_core::DecodeLimits::default();
    limits.max_decoded_bytes = left / 4;
    limits.max_points = (left / DRACO_BYTES_PER_POINT).min(MAX_ELEMENTS as u64);
    limits.max_faces = (left / DRACO_BYTES_PER_FACE).min(MAX_ELEMENTS as u64 / 3);
    let mut mesh = draco_core::Mesh::new();
    draco_core::MeshDecoder::new()
        .decode(
            &mut draco_core::DecoderBuffer::new(bytes).with_limits(limits),
            &mut mesh,
        )
        .map_err(|e| {
            if e.kind() == draco_core::ErrorKind::LimitExceeded {
                ImportError::new(
                    path,
                    format!(
                        "mesh '{name}' ({DRACO}) decodes to more than the import's memory budget \
                         allows ({:.1} MiB left)",
                        left as f64 / (1u64 << 20) as f64
                    ),
                )
            } else {
                bad(&format!("the stream does not decode ({e:?})"))
            }
        })?;
    let points = mesh.num_points();
    let faces = mesh.num_faces();
    if points == 0 || points > MAX_ELEMENTS || faces > MAX_ELEMENTS / 3 {
        return Err(bad(&format!("{points} points and {faces} faces")));
    }
    budget.charge(
        points as u64 * DRACO_BYTES_PER_POINT + faces as u64 * DRACO_BYTES_PER_FACE,
        || format!("mesh '{name}' decoded"),
    )?;
    let attribute = |semantic: &str, components: usize| -> Option<Vec<f32>> {
        let id = ext.get("attributes")?.get(semantic)?.as_u64()?;
        let a = mesh.attribute_by_unique_id(u32::try_from(id).ok()?)?;
        Some(a.read_f32s(points, components))
    };
    let positions: Vec<[f32; 3]> = attribute("POSITION", 3)
        .ok_or_else(|| bad("it has no POSITION attribute"))?
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let normals = attribute("NORMAL", 3).map(|v| {
        v.chunks_exact(3)
            .map(|c| {
                glam::Vec3::new(c[0], c[1], c[2])
                    .normalize_or_zero()
                    .to_array()
            })
            .collect()
    });
    let uvs = attribute("TEXCOORD_0", 2).map(|v| v.chunks_exact(2).map(|c| [c[0], c[1]]).collect());
    let indices = mesh.faces().iter().flatten().map(|p| p.0).collect();
    Ok(Some(DracoGeometry {
        positions,
        normals,
        uvs,
        indices,
    }))
}
