//! The glTF extensions this importer implements itself, because the `gltf` crate does not:
//! `EXT_meshopt_compression` (buffer views stored compressed, decoded with meshoptimizer's own
//! decoder), `KHR_mesh_quantization` (vertex attributes stored as normalized or plain integers) and
//! `KHR_draco_mesh_compression` (a primitive's geometry as one Draco stream).

use crate::{ImportError, MAX_ELEMENTS};
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

/// Parses a .gltf or .glb, accepting the extensions in [`OWN_EXTENSIONS`] as required ones.
pub(crate) fn parse(
    path: &Path,
    bytes: &[u8],
    describe: impl Fn(&gltf::Error) -> String,
) -> Result<gltf::Gltf, ImportError> {
    let (json, blob) = if bytes.starts_with(b"glTF") {
        let glb = gltf::Glb::from_slice(bytes).map_err(|e| ImportError::new(path, describe(&e)))?;
        (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes.to_vec(), None)
    };
    let mut root: gltf::json::Root = gltf::json::deserialize::from_slice(&json)
        .map_err(|e| ImportError::new(path, format!("not a readable glTF file: {e}")))?;
    root.extensions_required
        .retain(|x| !OWN_EXTENSIONS.contains(&x.as_str()));
    // The gltf crate asks every accessor for a buffer view; those of a Draco-compressed primitive
    // have none (the stream holds their data). Validate a copy in which they name the stream's
    // view, then keep the file as it is: every accessor read is checked against its buffer first.
    let mut check = root.clone();
    for prim in check.meshes.iter().flat_map(|m| &m.primitives) {
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
            if let Some(acc) = root.accessors.get(a.value())
                && acc.buffer_view.is_none()
            {
                check.accessors[a.value()].buffer_view = Some(gltf::json::Index::new(view));
            }
        }
    }
    gltf::Document::from_json(check).map_err(|e| ImportError::new(path, describe(&e)))?;
    let document = gltf::Document::from_json_without_validation(root);
    Ok(gltf::Gltf { document, blob })
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
    let mut mesh = draco_core::Mesh::new();
    draco_core::MeshDecoder::new()
        .decode(&mut draco_core::DecoderBuffer::new(bytes), &mut mesh)
        .map_err(|e| bad(&format!("the stream does not decode ({e:?})")))?;
    let points = mesh.num_points();
    if points == 0 || points > MAX_ELEMENTS || mesh.num_faces() > MAX_ELEMENTS / 3 {
        return Err(bad(&format!(
            "{points} points and {} faces",
            mesh.num_faces()
        )));
    }
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
