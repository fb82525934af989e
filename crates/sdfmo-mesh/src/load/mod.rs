//! Loading meshes from files or bytes: format detection, the per-format readers, cleaning.

mod gltf;
mod obj;
mod stl;

use std::path::Path;

use glam::Vec3;

use crate::clean::{clean, CleanReport};
use crate::error::{MeshError, Result};
use crate::mesh::{check_extent, TriMesh};

/// The mesh file formats understood by [`load_mesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MeshFormat {
    /// Wavefront OBJ (text); `o` and `g` become parts.
    Obj,
    /// glTF 2.0 JSON (`.gltf`), buffers embedded as `data:` URIs or relative files.
    Gltf,
    /// glTF 2.0 binary container (`.glb`).
    Glb,
    /// STL, binary or ASCII; each ASCII `solid` is a part.
    Stl,
}

impl MeshFormat {
    /// The format implied by a file extension (case-insensitive), if any.
    pub fn from_extension(ext: &str) -> Option<MeshFormat> {
        match ext.to_ascii_lowercase().as_str() {
            "obj" => Some(MeshFormat::Obj),
            "gltf" => Some(MeshFormat::Gltf),
            "glb" => Some(MeshFormat::Glb),
            "stl" => Some(MeshFormat::Stl),
            _ => None,
        }
    }

    /// Lower-case name (`"obj"`, `"gltf"`, `"glb"`, `"stl"`).
    pub fn name(self) -> &'static str {
        match self {
            MeshFormat::Obj => "obj",
            MeshFormat::Gltf => "gltf",
            MeshFormat::Glb => "glb",
            MeshFormat::Stl => "stl",
        }
    }
}

/// Bounds that keep a hostile file from making the loader allocate without limit. Counts are
/// always checked against the bytes actually present as well; these caps bound what a small
/// file can legitimately amplify into (glTF node instancing, OBJ polygons).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadLimits {
    /// Most triangles a file may produce (after triangulation and instancing).
    pub max_triangles: usize,
    /// Most vertices a file may hold.
    pub max_vertices: usize,
    /// Most glTF node visits while walking the scene (instancing, deep hierarchies).
    pub max_node_visits: usize,
    /// Most triangles glTF instancing may add: the scene's triangles, counted from the
    /// accessors before anything is decoded or expanded, less each primitive's triangles once.
    /// A 3.5 KB file whose nodes reuse two children at each of 18 levels expands to 33.5 M
    /// triangles; this refuses it in milliseconds instead of a minute and 4 GB.
    pub max_instanced_triangles: usize,
    /// Largest mesh file read, in bytes (checked before reading; only regular files are read).
    pub max_file_bytes: u64,
}

impl Default for LoadLimits {
    /// 2^26 triangles and vertices (about 1.6 GB of mesh, far beyond what the octree builder
    /// needs), 2^20 node visits, 2^22 triangles added by instancing, 4 GiB files (a binary STL
    /// of 2^26 triangles is 3.2 GiB).
    fn default() -> Self {
        LoadLimits {
            max_triangles: 1 << 26,
            max_vertices: 1 << 26,
            max_node_visits: 1 << 20,
            max_instanced_triangles: 1 << 22,
            max_file_bytes: 1 << 32,
        }
    }
}

/// A loaded, welded and cleaned mesh with what cleaning did.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedMesh {
    /// The clean mesh in model units.
    pub mesh: TriMesh,
    /// What welding and cleaning changed.
    pub report: CleanReport,
    /// The format the file was read as.
    pub format: MeshFormat,
    /// Name of each part (index = part id): OBJ object/group, glTF `mesh[/primitive]`, STL
    /// solid name; empty when the file gives none.
    pub part_names: Vec<String>,
}

/// What a format reader produces before cleaning: validated positions and indices.
#[derive(Debug, Default)]
pub(crate) struct RawMesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub parts: Vec<u32>,
    pub part_names: Vec<String>,
}

impl RawMesh {
    /// This mesh, or [`MeshError::NoTriangles`] with `reason` if it has no triangle.
    fn with_triangles(self, file: &str, reason: &str) -> Result<RawMesh> {
        if self.triangles.is_empty() {
            return Err(no_triangles(file, reason));
        }
        Ok(self)
    }

    /// Error if adding `n` more triangles would pass the limit.
    pub(crate) fn check_room(&self, file: &str, n: usize, limits: &LoadLimits) -> Result<()> {
        let count = self.triangles.len().saturating_add(n);
        check_limit(file, "triangle count", count, limits.max_triangles)
    }
}

/// Loads OBJ / glTF / GLB / STL (binary and ASCII), welds bit-identical vertices, removes
/// degenerate and duplicate triangles (counted in the report).
///
/// The format is chosen by the extension and confirmed by the content (magic bytes, binary STL
/// length); a file whose content clearly says otherwise is read as what it is. Only regular
/// files are read (a device or FIFO is refused at once). External glTF buffers are read from
/// files in `path`'s folder only: after percent-decoding, absolute URIs, `..` and symbolic
/// links leading out of the folder are refused, and at most the buffer's declared `byteLength`
/// is read (no other URI schemes than `data:`).
///
/// # Errors
/// A [`MeshError`] naming the file and the reason for every malformed input.
pub fn load_mesh(path: &Path) -> Result<LoadedMesh> {
    load_mesh_with_limits(path, &LoadLimits::default())
}

/// [`load_mesh`] with explicit [`LoadLimits`].
///
/// # Errors
/// As [`load_mesh`].
pub fn load_mesh_with_limits(path: &Path, limits: &LoadLimits) -> Result<LoadedMesh> {
    let name = path.display().to_string();
    let hint = path
        .extension()
        .and_then(|e| e.to_str())
        .and_then(MeshFormat::from_extension);
    let bytes =
        sdfmo_io::read_regular_checked(path, limits.max_file_bytes, HEAD_BYTES, |head, len| {
            check_head(head, len, &name, hint)
        })?;
    load_impl(&bytes, &name, hint, path.parent(), limits)
}

/// Bytes of a mesh file read before the rest, for [`check_head`]: enough to detect the format
/// as [`detect_format`] does on the whole file, when it is STL or GLB.
const HEAD_BYTES: usize = stl::SNIFF_BYTES;

/// The checks the first bytes of a mesh file (`head`: [`HEAD_BYTES`], or the whole file) and
/// its length `len` allow before the rest is read: a binary STL's triangle count and a GLB's
/// declared length against the file's length. Returns how many bytes to read: the whole file,
/// or a GLB's declared length (what follows it is ignored, as [`load_mesh_from_bytes`] ignores
/// it). The errors are those the whole file would give.
fn check_head(head: &[u8], len: u64, name: &str, hint: Option<MeshFormat>) -> Result<u64> {
    match detect_format_sized(head, len, hint) {
        Some(MeshFormat::Stl) => stl::check_head(head, len, name).map(|()| len),
        Some(MeshFormat::Glb) => gltf::glb_read_len(head, len, name, HEAD_BYTES),
        _ => Ok(len),
    }
}

/// [`MeshError::OutOfMemory`]: `bytes` bytes for `what` of `file` could not be allocated.
pub(crate) fn out_of_memory(file: &str, what: &str, bytes: usize) -> MeshError {
    MeshError::OutOfMemory {
        file: file.into(),
        what: what.into(),
        bytes: bytes as u64,
    }
}

/// Loads a mesh from bytes in memory (used by the fuzz targets). `name` is used in errors;
/// `hint` is the format the caller expects (e.g. from an extension): content sniffing confirms
/// or overrides it, and without a hint the content alone decides. glTF files referring to
/// external buffers are [`MeshError::Unsupported`] here.
///
/// # Errors
/// As [`load_mesh`].
pub fn load_mesh_from_bytes(
    bytes: &[u8],
    name: &str,
    hint: Option<MeshFormat>,
) -> Result<LoadedMesh> {
    load_impl(bytes, name, hint, None, &LoadLimits::default())
}

/// [`load_mesh_from_bytes`] with explicit [`LoadLimits`].
///
/// # Errors
/// As [`load_mesh`].
pub fn load_mesh_from_bytes_with_limits(
    bytes: &[u8],
    name: &str,
    hint: Option<MeshFormat>,
    limits: &LoadLimits,
) -> Result<LoadedMesh> {
    load_impl(bytes, name, hint, None, limits)
}

/// What the content says, strongly (magic bytes, exact binary STL length) or weakly.
#[derive(Debug, PartialEq, Eq)]
enum Sniff {
    Strong(MeshFormat),
    Weak(MeshFormat),
    Nothing,
}

/// What the first bytes of a file of `len` bytes say (`bytes` may be the whole file or its
/// first [`HEAD_BYTES`]).
fn sniff(bytes: &[u8], len: u64) -> Sniff {
    if bytes.starts_with(b"glTF") {
        return Sniff::Strong(MeshFormat::Glb);
    }
    if stl::is_binary_length(bytes, len) {
        return Sniff::Strong(MeshFormat::Stl);
    }
    let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let start = text
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(text.len());
    let text = &text[start..];
    if text.starts_with(b"{") {
        return Sniff::Strong(MeshFormat::Gltf);
    }
    if text.len() >= 5 && text[..5].eq_ignore_ascii_case(b"solid") {
        return Sniff::Weak(MeshFormat::Stl);
    }
    if obj::looks_like_obj(text) {
        return Sniff::Weak(MeshFormat::Obj);
    }
    Sniff::Nothing
}

/// Picks the format: strong content evidence wins, then the hint, then weak evidence.
pub fn detect_format(bytes: &[u8], hint: Option<MeshFormat>) -> Option<MeshFormat> {
    detect_format_sized(bytes, bytes.len() as u64, hint)
}

/// [`detect_format`] of a file of `len` bytes from its first bytes.
fn detect_format_sized(bytes: &[u8], len: u64, hint: Option<MeshFormat>) -> Option<MeshFormat> {
    match (sniff(bytes, len), hint) {
        (Sniff::Strong(f), _) => Some(f),
        (_, Some(h)) => Some(h),
        (Sniff::Weak(f), None) => Some(f),
        (Sniff::Nothing, None) => None,
    }
}

fn load_impl(
    bytes: &[u8],
    name: &str,
    hint: Option<MeshFormat>,
    base: Option<&Path>,
    limits: &LoadLimits,
) -> Result<LoadedMesh> {
    let format = detect_format(bytes, hint).ok_or_else(|| MeshError::UnknownFormat {
        file: name.into(),
        reason: if bytes.is_empty() {
            "the file is empty".into()
        } else {
            "no known extension and the content matches no format".into()
        },
    })?;
    let raw = match format {
        MeshFormat::Stl => stl::read(bytes, name, limits)?,
        MeshFormat::Obj => obj::read(bytes, name, limits)?,
        MeshFormat::Gltf | MeshFormat::Glb => gltf::read(bytes, name, base, limits)?,
    };
    check_limit(
        name,
        "vertex count",
        raw.positions.len(),
        limits.max_vertices,
    )?;
    let raw = raw.with_triangles(name, "the file holds no triangle")?;
    let (mesh, report) = clean(name, &raw.positions, &raw.triangles, &raw.parts)?;
    check_extent(name, mesh.positions(), mesh.triangles())?;
    Ok(LoadedMesh {
        mesh,
        report,
        format,
        part_names: raw.part_names,
    })
}

/// The name a mesh file is shown under (tables, image names): its file stem, or `mesh` when it
/// has none.
pub fn mesh_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "mesh".to_owned())
}

/// [`MeshError::TooLarge`]: `count` of `what` in `file` passes `limit`.
pub(crate) fn too_large(file: &str, what: &str, count: usize, limit: usize) -> MeshError {
    MeshError::TooLarge {
        file: file.into(),
        what: what.into(),
        count: count as u64,
        limit: limit as u64,
    }
}

/// [`too_large`] if `count > limit`.
pub(crate) fn check_limit(file: &str, what: &str, count: usize, limit: usize) -> Result<()> {
    if count > limit {
        return Err(too_large(file, what, count, limit));
    }
    Ok(())
}

/// The lines of a text mesh file (OBJ, ASCII STL), numbered from 1, each as UTF-8 text or the
/// parse error naming its line.
pub(crate) fn text_lines<'a>(
    file: &'a str,
    text: &'a [u8],
) -> impl Iterator<Item = Result<(usize, &'a str)>> + 'a {
    text.split(|&b| b == b'\n')
        .enumerate()
        .map(move |(i, line)| {
            std::str::from_utf8(line)
                .map(|line| (i + 1, line))
                .map_err(|_| parse_error(file, i + 1, "not UTF-8 text".into()))
        })
}

/// A parse error of `file` at line `line`.
pub(crate) fn parse_error(file: &str, line: usize, reason: String) -> MeshError {
    MeshError::Parse {
        file: file.into(),
        line: Some(line),
        reason,
    }
}

/// [`MeshError::NoTriangles`] of `file`.
pub(crate) fn no_triangles(file: &str, reason: &str) -> MeshError {
    MeshError::NoTriangles {
        file: file.into(),
        reason: reason.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::box_mesh;
    use crate::write;

    #[test]
    fn extension_chooses_and_content_confirms() {
        let m = box_mesh(Vec3::ZERO, Vec3::ONE);
        let glb = write::to_glb(&m);
        let stl = write::to_stl_binary(&m);
        let ascii = write::to_stl_ascii(&m);
        let obj = write::to_obj(&m);
        let gltf = write::to_gltf_embedded(&m);
        // Strong content evidence wins over a wrong extension.
        assert_eq!(
            detect_format(&glb, Some(MeshFormat::Stl)),
            Some(MeshFormat::Glb)
        );
        assert_eq!(
            detect_format(&stl, Some(MeshFormat::Obj)),
            Some(MeshFormat::Stl)
        );
        assert_eq!(
            detect_format(gltf.as_bytes(), Some(MeshFormat::Obj)),
            Some(MeshFormat::Gltf)
        );
        // Weak evidence yields to the extension, and decides without one.
        assert_eq!(
            detect_format(ascii.as_bytes(), Some(MeshFormat::Obj)),
            Some(MeshFormat::Obj)
        );
        assert_eq!(detect_format(ascii.as_bytes(), None), Some(MeshFormat::Stl));
        assert_eq!(detect_format(obj.as_bytes(), None), Some(MeshFormat::Obj));
        assert_eq!(detect_format(b"\x00\x01garbage", None), None);
        assert_eq!(MeshFormat::from_extension("GLB"), Some(MeshFormat::Glb));
        assert_eq!(MeshFormat::from_extension("ply"), None);
        // A misnamed file loads as what it is.
        let l = load_mesh_from_bytes(&glb, "really_a.stl", Some(MeshFormat::Stl)).unwrap();
        assert_eq!((l.format, l.mesh.triangle_count()), (MeshFormat::Glb, 12));
    }
}
