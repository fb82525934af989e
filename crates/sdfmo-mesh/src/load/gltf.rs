//! glTF 2.0 reader (JSON `.gltf` and binary `.glb`) on top of the `gltf` crate's validated
//! document model.
//!
//! The GLB container is split here (checked lengths, no trust in the header), the JSON is
//! parsed and validated by `gltf`, and accessor data is read here with every offset, stride
//! and count checked against the bytes of its buffer, so a hostile file can neither read out of
//! bounds nor make us allocate more than its buffers hold. Buffers come from the GLB `BIN`
//! chunk, `data:` URIs (base64), or, when loading from a path, files relative to it; no other
//! URI is ever fetched. Images and textures are never decoded.
//!
//! Every triangle primitive (modes TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN) of every mesh
//! instance in the default scene (or the first scene, or, without scenes, every root node)
//! becomes one part, its positions transformed by the node's world matrix. Points and lines are
//! skipped.

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::{LoadLimits, RawMesh};
use crate::error::{MeshError, Result};
use crate::mesh::check_indices;

/// A primitive's positions (model space, before node transforms) and checked triangles.
type Decoded = (Vec<Vec3>, Vec<[u32; 3]>);

struct Ctx<'a> {
    file: &'a str,
    base: Option<&'a Path>,
    limits: &'a LoadLimits,
}

impl Ctx<'_> {
    fn parse(&self, reason: impl Into<String>) -> MeshError {
        MeshError::Parse {
            file: self.file.into(),
            line: None,
            reason: reason.into(),
        }
    }
}

fn le_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Splits a GLB container into its JSON chunk and optional BIN chunk.
/// How many bytes of a GLB file of `len` bytes starting with `head` (at least `min` of them,
/// or the whole file) to read: its declared length (what follows is ignored), checked against
/// the file's length first; the whole file when the header is not a GLB 2 header (the
/// parser reports it).
pub(super) fn glb_read_len(head: &[u8], len: u64, file: &str, min: usize) -> Result<u64> {
    if head.len() < 12 || &head[..4] != b"glTF" || le_u32(head, 4) != 2 {
        return Ok(len);
    }
    let length = u64::from(le_u32(head, 8));
    if length > len {
        return Err(MeshError::Truncated {
            file: file.into(),
            reason: format!("the GLB header announces {length} bytes, the file has {len}"),
        });
    }
    Ok(length.max(min as u64).min(len))
}

fn split_glb<'b>(bytes: &'b [u8], ctx: &Ctx) -> Result<(&'b [u8], Option<&'b [u8]>)> {
    let file = ctx.file;
    if bytes.len() < 12 {
        return Err(MeshError::Truncated {
            file: file.into(),
            reason: format!(
                "a GLB needs a 12-byte header, the file has {} bytes",
                bytes.len()
            ),
        });
    }
    if &bytes[..4] != b"glTF" {
        return Err(ctx.parse("missing the GLB magic `glTF`"));
    }
    let version = le_u32(bytes, 4);
    if version != 2 {
        return Err(MeshError::Unsupported {
            file: file.into(),
            reason: format!("GLB version {version} (only 2 is supported)"),
        });
    }
    let length = le_u32(bytes, 8) as usize;
    if length > bytes.len() {
        return Err(MeshError::Truncated {
            file: file.into(),
            reason: format!(
                "the GLB header announces {length} bytes, the file has {}",
                bytes.len()
            ),
        });
    }
    if length < 20 {
        return Err(MeshError::HeaderMismatch {
            file: file.into(),
            reason: format!("the GLB header announces {length} bytes, too few for a JSON chunk"),
        });
    }
    let data = &bytes[..length];
    let mut at = 12;
    let mut json = None;
    let mut bin = None;
    while at < data.len() {
        if data.len() - at < 8 {
            return Err(MeshError::Truncated {
                file: file.into(),
                reason: format!("GLB chunk header at byte {at} is cut off"),
            });
        }
        let len = le_u32(data, at) as usize;
        let ty = &data[at + 4..at + 8];
        let start = at + 8;
        if len > data.len() - start {
            return Err(MeshError::Truncated {
                file: file.into(),
                reason: format!(
                    "GLB chunk at byte {at} announces {len} bytes, only {} remain",
                    data.len() - start
                ),
            });
        }
        let chunk = &data[start..start + len];
        match (ty, json.is_none()) {
            (b"JSON", true) => json = Some(chunk),
            (_, true) => return Err(ctx.parse("the first GLB chunk is not JSON")),
            (b"BIN\0", false) if bin.is_none() => bin = Some(chunk),
            _ => {} // unknown chunks are skipped, as the specification asks
        }
        at = start + len;
    }
    Ok((
        json.ok_or_else(|| ctx.parse("GLB without a JSON chunk"))?,
        bin,
    ))
}

fn load_buffer(buffer: &gltf::Buffer, bin: Option<&[u8]>, ctx: &Ctx) -> Result<Vec<u8>> {
    let idx = buffer.index();
    let data = match buffer.source() {
        gltf::buffer::Source::Bin => bin
            .ok_or_else(|| ctx.parse(format!("buffer {idx} refers to a missing GLB BIN chunk")))?
            .to_vec(),
        gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
            let (_, payload) =
                uri.split_once(";base64,")
                    .ok_or_else(|| MeshError::Unsupported {
                        file: ctx.file.into(),
                        reason: format!("buffer {idx}: data URI without base64 encoding"),
                    })?;
            decode_base64(payload)
                .ok_or_else(|| ctx.parse(format!("buffer {idx}: invalid base64 in data URI")))?
        }
        gltf::buffer::Source::Uri(uri) => {
            let scheme = uri.split_once(':').map(|(s, _)| s);
            let is_scheme = scheme.is_some_and(|s| {
                s.len() > 1
                    && s.chars()
                        .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
            });
            let shown: String = uri.chars().take(80).collect();
            if is_scheme || uri.starts_with('/') || uri.starts_with('\\') {
                return Err(MeshError::Unsupported {
                    file: ctx.file.into(),
                    reason: format!(
                        "buffer {idx}: URI `{shown}` (only data: URIs and relative paths)"
                    ),
                });
            }
            let Some(base) = ctx.base else {
                return Err(MeshError::Unsupported {
                    file: ctx.file.into(),
                    reason: format!(
                        "buffer {idx}: external file `{shown}` cannot be resolved when loading from bytes"
                    ),
                });
            };
            let rel = percent_encoding::percent_decode_str(uri)
                .decode_utf8()
                .map_err(|_| ctx.parse(format!("buffer {idx}: URI is not UTF-8 once decoded")))?;
            read_external(base, &rel, buffer.length(), idx, ctx)?
        }
    };
    if data.len() < buffer.length() {
        return Err(MeshError::Truncated {
            file: ctx.file.into(),
            reason: format!(
                "buffer {idx} declares {} bytes, its data has {}",
                buffer.length(),
                data.len()
            ),
        });
    }
    Ok(data)
}

/// Standard or URL-safe base64, padded or not, whitespace ignored (as exporters write it).
fn decode_base64(payload: &str) -> Option<Vec<u8>> {
    use base64::engine::general_purpose::{GeneralPurpose, GeneralPurposeConfig};
    use base64::engine::DecodePaddingMode;
    use base64::{alphabet, Engine};
    let config = GeneralPurposeConfig::new()
        .with_decode_padding_mode(DecodePaddingMode::Indifferent)
        .with_decode_allow_trailing_bits(true);
    let compact: String = payload
        .chars()
        .filter(|c| !c.is_ascii_whitespace())
        .collect();
    let alphabet = if compact.contains(['-', '_']) {
        &alphabet::URL_SAFE
    } else {
        &alphabet::STANDARD
    };
    GeneralPurpose::new(alphabet, config).decode(compact).ok()
}

/// Reads at most `length` bytes of the external buffer `rel` (percent-decoded) from the
/// model's folder `base`: the reference must stay in the folder and name a regular file.
fn read_external(base: &Path, rel: &str, length: usize, idx: usize, ctx: &Ctx) -> Result<Vec<u8>> {
    use std::io::Read;
    let external = |source| MeshError::ExternalBuffer {
        file: ctx.file.into(),
        index: idx,
        source,
    };
    let path = sdfmo_io::resolve_in_folder(base, rel).map_err(external)?;
    let (file, _) = sdfmo_io::open_regular(&path).map_err(external)?;
    let mut data = Vec::new();
    file.take(length as u64)
        .read_to_end(&mut data)
        .map_err(|source| {
            external(sdfmo_io::IoError::Os {
                action: "read",
                path: path.clone(),
                source,
            })
        })?;
    Ok(data)
}

/// Lazily loaded buffers, each loaded at most once.
struct Buffers<'a> {
    doc: &'a gltf::Document,
    bin: Option<&'a [u8]>,
    data: Vec<Option<Vec<u8>>>,
}

impl Buffers<'_> {
    fn get(&mut self, index: usize, ctx: &Ctx) -> Result<&[u8]> {
        if self.data[index].is_none() {
            let buffer = self
                .doc
                .buffers()
                .nth(index)
                .ok_or_else(|| ctx.parse(format!("buffer {index} does not exist")))?;
            self.data[index] = Some(load_buffer(&buffer, self.bin, ctx)?);
        }
        Ok(self.data[index].as_deref().unwrap_or(&[]))
    }
}

/// The checked byte layout of an accessor: `count` elements of `size` bytes, `stride` apart,
/// starting at `start` in `bytes`.
struct Layout<'b> {
    bytes: &'b [u8],
    start: usize,
    stride: usize,
    count: usize,
}

impl Layout<'_> {
    #[inline]
    fn element(&self, i: usize) -> &[u8] {
        &self.bytes[self.start + i * self.stride..]
    }
}

impl Buffers<'_> {
    /// The checked layout of accessor `acc` (for `what`, named in errors) in its buffer.
    fn layout<'b>(&'b mut self, acc: &gltf::Accessor, what: &str, ctx: &Ctx) -> Result<Layout<'b>> {
        let i = acc.index();
        if acc.sparse().is_some() {
            return Err(MeshError::Unsupported {
                file: ctx.file.into(),
                reason: format!("{what}: sparse accessor {i}"),
            });
        }
        let view = acc.view().ok_or_else(|| MeshError::Unsupported {
            file: ctx.file.into(),
            reason: format!("{what}: accessor {i} has no bufferView"),
        })?;
        let size = acc.size();
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(ctx.parse(format!(
                "{what}: accessor {i} elements of {size} bytes overlap (stride {stride})"
            )));
        }
        let bytes = self.get(view.buffer().index(), ctx)?;
        let bad = |reason: String| MeshError::Truncated {
            file: ctx.file.into(),
            reason: format!("{what}: accessor {i}: {reason}"),
        };
        let view_end = view
            .offset()
            .checked_add(view.length())
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| {
                bad(format!(
                    "bufferView {} (offset {}, length {}) exceeds its buffer of {} bytes",
                    view.index(),
                    view.offset(),
                    view.length(),
                    bytes.len()
                ))
            })?;
        let count = acc.count();
        if count > 0 {
            let need = (count - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(size))
                .and_then(|x| x.checked_add(acc.offset()));
            if need.is_none_or(|n| n > view.length()) {
                return Err(bad(format!(
                    "{count} elements of {size} bytes (stride {stride}, offset {}) exceed bufferView {} of {} bytes",
                    acc.offset(),
                    view.index(),
                    view.length()
                )));
            }
        }
        // Checked even for an empty accessor, whose offset no element bounds.
        let start = view.offset().checked_add(acc.offset()).ok_or_else(|| {
            bad(format!(
                "accessor offset {} overflows past bufferView {}",
                acc.offset(),
                view.index()
            ))
        })?;
        Ok(Layout {
            bytes: &bytes[..view_end],
            start,
            stride,
            count,
        })
    }

    /// The positions of accessor `acc` (VEC3 of FLOAT only).
    fn positions(&mut self, acc: &gltf::Accessor, what: &str, ctx: &Ctx) -> Result<Vec<Vec3>> {
        if acc.dimensions() != Dimensions::Vec3 || acc.data_type() != DataType::F32 {
            return Err(MeshError::Unsupported {
                file: ctx.file.into(),
                reason: format!(
                    "{what}: POSITION accessor {} is {:?} of {:?} (only VEC3 of FLOAT)",
                    acc.index(),
                    acc.dimensions(),
                    acc.data_type()
                ),
            });
        }
        let l = self.layout(acc, what, ctx)?;
        Ok((0..l.count)
            .map(|i| {
                let e = l.element(i);
                let f = |k: usize| f32::from_le_bytes([e[k], e[k + 1], e[k + 2], e[k + 3]]);
                Vec3::new(f(0), f(4), f(8))
            })
            .collect())
    }

    /// The indices of accessor `acc` (SCALAR of unsigned integers only).
    fn indices(&mut self, acc: &gltf::Accessor, what: &str, ctx: &Ctx) -> Result<Vec<u32>> {
        if acc.dimensions() != Dimensions::Scalar {
            return Err(ctx.parse(format!(
                "{what}: index accessor {} is not SCALAR",
                acc.index()
            )));
        }
        let ty = acc.data_type();
        let l = self.layout(acc, what, ctx)?;
        let read = |i: usize| -> Option<u32> {
            let e = l.element(i);
            match ty {
                DataType::U8 => Some(e[0] as u32),
                DataType::U16 => Some(u16::from_le_bytes([e[0], e[1]]) as u32),
                DataType::U32 => Some(le_u32(e, 0)),
                _ => None,
            }
        };
        (0..l.count)
            .map(|i| {
                read(i).ok_or_else(|| {
                    ctx.parse(format!(
                        "{what}: index accessor {} has component type {ty:?} (only unsigned integers)",
                        acc.index()
                    ))
                })
            })
            .collect()
    }
}

/// Turns a primitive's index list into triangles according to its mode.
fn assemble(mode: Mode, idx: &[u32], what: &str, ctx: &Ctx) -> Result<Vec<[u32; 3]>> {
    Ok(match mode {
        Mode::Triangles => {
            let leftover = idx.len() % 3;
            if leftover != 0 {
                return Err(ctx.parse(format!(
                    "{what}: {} indices is not a multiple of 3",
                    idx.len()
                )));
            }
            idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
        }
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => Vec::new(),
    })
}

/// Triangles of one primitive from its accessors' counts (nothing decoded).
fn primitive_triangles(prim: &gltf::Primitive) -> usize {
    let count = match prim.indices() {
        Some(acc) => acc.count(),
        None => prim
            .get(&gltf::Semantic::Positions)
            .map_or(0, |acc| acc.count()),
    };
    match prim.mode() {
        Mode::Triangles => count / 3,
        Mode::TriangleStrip | Mode::TriangleFan => count.saturating_sub(2),
        _ => 0,
    }
}

/// Refuses a scene whose instancing would expand past the limits, before anything is decoded:
/// the triangles under each node are counted once per node (children before parents, so a
/// shared subtree costs one count however often it is reused), saturating.
fn check_expansion(doc: &gltf::Document, roots: &[gltf::Node], ctx: &Ctx) -> Result<()> {
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let own: Vec<usize> = nodes
        .iter()
        .map(|n| {
            n.mesh().map_or(0, |m| {
                m.primitives()
                    .map(|p| primitive_triangles(&p))
                    .fold(0, usize::saturating_add)
            })
        })
        .collect();
    // Iterative post-order; 1 = on the path (a cycle if met again), 2 = counted.
    let mut state = vec![0u8; nodes.len()];
    let mut total = vec![0usize; nodes.len()];
    for root in roots {
        let mut stack = vec![(root.index(), false)];
        while let Some((n, children_done)) = stack.pop() {
            if children_done {
                total[n] = nodes[n]
                    .children()
                    .map(|c| total[c.index()])
                    .fold(own[n], usize::saturating_add);
                state[n] = 2;
                continue;
            }
            match state[n] {
                2 => continue,
                1 => return Err(ctx.parse(format!("node {n} is its own ancestor (cycle)"))),
                _ => {}
            }
            state[n] = 1;
            stack.push((n, true));
            for c in nodes[n].children() {
                if state[c.index()] == 1 {
                    return Err(
                        ctx.parse(format!("node {} is its own ancestor (cycle)", c.index()))
                    );
                }
                if state[c.index()] == 0 {
                    stack.push((c.index(), false));
                }
            }
        }
    }
    let expanded = roots
        .iter()
        .map(|r| total[r.index()])
        .fold(0, usize::saturating_add);
    let file = ctx.file;
    super::check_limit(
        file,
        "triangle count (after instancing)",
        expanded,
        ctx.limits.max_triangles,
    )?;
    // Each primitive's triangles once: what the file itself holds.
    let distinct: usize = doc
        .meshes()
        .flat_map(|m| m.primitives())
        .map(|p| primitive_triangles(&p))
        .fold(0, usize::saturating_add);
    super::check_limit(
        file,
        "triangles added by instancing",
        expanded.saturating_sub(distinct),
        ctx.limits.max_instanced_triangles,
    )
}

pub(super) fn read(
    bytes: &[u8],
    file: &str,
    base: Option<&Path>,
    limits: &LoadLimits,
) -> Result<RawMesh> {
    let ctx = Ctx { file, base, limits };
    let (json, bin) = if bytes.starts_with(b"glTF") {
        split_glb(bytes, &ctx)?
    } else {
        (bytes, None)
    };
    let root = gltf::json::deserialize::from_slice::<gltf::json::Root>(json)
        .map_err(|e| ctx.parse(format!("glTF JSON: {e}")))?;
    // gltf-json 1.4.1's POSITION validation hook indexes `root.accessors` before the index
    // itself is validated (a panic on `"POSITION": 0` without accessors): check it first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let pos = prim.attributes.get(&gltf::json::validation::Checked::Valid(
                gltf::Semantic::Positions,
            ));
            if let Some(i) = pos
                .map(|i| i.value())
                .filter(|&i| i >= root.accessors.len())
            {
                return Err(ctx.parse(format!(
                    "mesh {m} primitive {p}: POSITION refers to accessor {i}, there are {}",
                    root.accessors.len()
                )));
            }
        }
    }
    let doc =
        gltf::Document::from_json(root).map_err(|e| ctx.parse(format!("invalid glTF: {e}")))?;

    // Roots to walk: the default scene, else the first scene, else every node that is nobody's
    // child.
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };

    check_expansion(&doc, &roots, &ctx)?;

    let mut buffers = Buffers {
        doc: &doc,
        bin,
        data: vec![None; doc.buffers().len()],
    };
    let node_count = doc.nodes().len();
    let mut raw = RawMesh::default();
    let mut stack: Vec<(gltf::Node, Mat4, usize)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, Mat4::IDENTITY, 0))
        .collect();
    let mut visits = 0usize;
    let mut decoded: HashMap<(usize, usize), Decoded> = HashMap::new();
    while let Some((node, parent, depth)) = stack.pop() {
        visits += 1;
        let limit = ctx.limits.max_node_visits;
        super::check_limit(file, "scene node visits (instancing)", visits, limit)?;
        if depth > node_count {
            return Err(ctx.parse(format!("node {} is its own ancestor (cycle)", node.index())));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let what = format!(
                    "node {} mesh {} primitive {}",
                    node.index(),
                    mesh.index(),
                    prim.index()
                );
                if !matches!(
                    prim.mode(),
                    Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
                ) {
                    continue;
                }
                // Decoded once per primitive, however often its mesh is instanced.
                let key = (mesh.index(), prim.index());
                let (positions, tris) = match decoded.entry(key) {
                    Entry::Occupied(e) => e.into_mut(),
                    Entry::Vacant(slot) => {
                        let pos_acc = prim
                            .get(&gltf::Semantic::Positions)
                            .ok_or_else(|| ctx.parse(format!("{what}: no POSITION attribute")))?;
                        let positions = buffers.positions(&pos_acc, &what, &ctx)?;
                        let idx: Vec<u32> = match prim.indices() {
                            Some(acc) => buffers.indices(&acc, &what, &ctx)?,
                            None => (0..positions.len() as u32).collect(),
                        };
                        let tris = assemble(prim.mode(), &idx, &what, &ctx)?;
                        check_indices(file, &format!("{what} "), &tris, positions.len())?;
                        slot.insert((positions, tris))
                    }
                };
                if tris.is_empty() {
                    continue;
                }
                raw.check_room(file, tris.len(), ctx.limits)?;
                let nv = raw.positions.len().saturating_add(positions.len());
                super::check_limit(file, "vertex count", nv, ctx.limits.max_vertices)?;
                let base = raw.positions.len() as u32;
                for (i, p) in positions.iter().enumerate() {
                    let q = world.transform_point3(*p);
                    if !q.is_finite() {
                        let bad = if p.is_finite() { q } else { *p };
                        return Err(MeshError::NonFinite {
                            file: file.into(),
                            element: format!("{what} vertex {i}"),
                            value: bad.to_string(),
                        });
                    }
                    raw.positions.push(q);
                }
                let part = raw.part_names.len() as u32;
                raw.part_names.push(match mesh.name() {
                    Some(n) => format!("{n}/{}", prim.index()),
                    None => format!("mesh{}/{}", mesh.index(), prim.index()),
                });
                // A negative determinant mirrors the geometry: flip the winding back.
                let mirror = world.determinant() < 0.0;
                for tri in tris {
                    let [a, b, c] = tri.map(|v| v + base);
                    raw.triangles
                        .push(if mirror { [a, c, b] } else { [a, b, c] });
                    raw.parts.push(part);
                }
            }
        }
        for child in node.children() {
            stack.push((child, world, depth + 1));
        }
    }
    raw.with_triangles(file, "the scene has no triangle primitive")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{load_mesh_from_bytes, MeshFormat};

    #[test]
    fn base64_forms() {
        assert_eq!(decode_base64("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(decode_base64("aGVsbG8").unwrap(), b"hello");
        assert_eq!(decode_base64("aGVs\nbG8=").unwrap(), b"hello");
        assert_eq!(decode_base64("AAEC").unwrap(), vec![0, 1, 2]);
        assert_eq!(decode_base64("-_8").unwrap(), vec![0xfb, 0xff]);
        assert!(decode_base64("a*b").is_none());
    }

    /// A GLB around `json` with a BIN chunk of four positions (a unit square in z = 0:
    /// (0,0,0), (1,0,0), (1,1,0), (0,1,0)) followed by u16 indices [0, 1, 2, 3].
    fn glb(json: &str) -> Vec<u8> {
        let mut bin = Vec::new();
        for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
            for c in p {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        for i in [0u16, 1, 2, 3] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        crate::write::glb_container(json, &bin)
    }

    fn doc(scene: &str, nodes: &str, primitives: &str) -> String {
        format!(
            r#"{{"asset":{{"version":"2.0"}},{scene}"nodes":{nodes},
"meshes":[{{"primitives":{primitives}}}],"buffers":[{{"byteLength":56}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":8}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5123,"count":4,"type":"SCALAR"}},
{{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#
        )
    }

    fn load(json: &str) -> crate::LoadedMesh {
        load_mesh_from_bytes(&glb(json), "t.glb", Some(MeshFormat::Glb)).unwrap()
    }

    const TRI: &str = r#"[{"attributes":{"POSITION":0},"indices":2}]"#;

    #[test]
    fn node_transforms_apply_and_mirrors_keep_the_winding() {
        // Node 0 translates its child (node 1) by (10, 0, 0); node 2 mirrors x.
        let l = load(&doc(
            r#""scene":0,"scenes":[{"nodes":[0,2]}],"#,
            r#"[{"translation":[10,0,0],"children":[1]},{"mesh":0,"scale":[2,2,2]},{"mesh":0,"scale":[-1,1,1]}]"#,
            TRI,
        ));
        let m = &l.mesh;
        assert_eq!((m.triangle_count(), m.part_count()), (2, 2));
        assert_eq!(
            m.triangle(0),
            [
                Vec3::new(10.0, 0.0, 0.0),
                Vec3::new(12.0, 0.0, 0.0),
                Vec3::new(12.0, 2.0, 0.0)
            ]
        );
        // Both instances face +z: the mirrored one had its winding flipped back.
        for i in 0..2 {
            assert!(m.triangle_normal_f64(i)[2] > 0.0, "triangle {i}");
        }
        assert_eq!(m.triangle(1)[0], Vec3::ZERO);
        assert_eq!(l.part_names, vec!["mesh0/0", "mesh0/0"]);
    }

    #[test]
    fn default_scene_is_used_and_other_scenes_are_not() {
        let l = load(&doc(
            r#""scene":1,"scenes":[{"nodes":[0]},{"nodes":[1]}],"#,
            r#"[{"mesh":0,"translation":[5,0,0]},{"mesh":0,"translation":[0,7,0]}]"#,
            TRI,
        ));
        assert_eq!(l.mesh.triangle_count(), 1);
        assert_eq!(l.mesh.bounds().min, Vec3::new(0.0, 7.0, 0.0));
        // Without scenes, every root node is walked.
        let l = load(&doc(
            "",
            r#"[{"mesh":0},{"mesh":0,"translation":[0,0,1]}]"#,
            TRI,
        ));
        assert_eq!(l.mesh.triangle_count(), 2);
    }

    #[test]
    fn strips_fans_and_primitives_as_parts() {
        // Primitive 0: a strip over 4 vertices (2 triangles); primitive 1: a fan (2 triangles,
        // coinciding with the strip's, so they are duplicates); primitive 2: points (skipped).
        let prims = r#"[{"attributes":{"POSITION":0},"indices":1,"mode":5},
{"attributes":{"POSITION":0},"indices":1,"mode":6},{"attributes":{"POSITION":0},"mode":0}]"#;
        let l = load(&doc("", r#"[{"mesh":0}]"#, prims));
        // Strip 0-1-2-3: (0,1,2) then, odd, (1,3,2) (the specification's order, written here
        // as its rotation (2,1,3)). Fan 0-1-2-3: (0,1,2) duplicates the strip's first; (0,2,3).
        assert_eq!(l.report.input_triangles, 4);
        assert_eq!(l.mesh.triangles(), vec![[0, 1, 2], [2, 1, 3], [0, 2, 3]]);
        assert_eq!(l.report.duplicate_triangles, 1);
        assert_eq!(l.mesh.parts(), vec![0, 0, 1]);
    }
}
