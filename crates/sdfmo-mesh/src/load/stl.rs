//! STL reader, binary and ASCII (a small reader of our own: it checks the binary header's
//! triangle count against the file length before allocating anything).

use glam::Vec3;

use super::{LoadLimits, RawMesh};
use crate::error::{MeshError, Result};

const HEADER: usize = 80;
const RECORD: u64 = 50;

/// Bytes at the start of a file that decide between ASCII and binary STL (a NUL byte among
/// them means binary).
pub(super) const SNIFF_BYTES: usize = 4096;

/// Whether a file of `len` bytes starting with `head` (its first bytes, at least 84 when the
/// file has them) has exactly the length its binary STL header announces.
pub(super) fn is_binary_length(head: &[u8], len: u64) -> bool {
    head.len() >= HEADER + 4 && HEADER as u64 + 4 + RECORD * u64::from(count(head)) == len
}

fn count(bytes: &[u8]) -> u32 {
    u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]])
}

/// Whether a file of `len` bytes starting with `head` (its first [`SNIFF_BYTES`] bytes, or the
/// whole file) is read as ASCII STL: it starts with `solid`, its length is not a binary
/// header's, and it has no NUL byte. Binary exporters often start the 80-byte header with
/// "solid" too; text never holds a NUL byte while binary headers and float records almost
/// always do, so such a file with a wrong triangle count is reported as the broken binary STL
/// it is.
fn is_ascii(head: &[u8], len: u64) -> bool {
    let text = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    let trimmed = text.trim_ascii_start();
    let solid = trimmed.len() >= 5 && trimmed[..5].eq_ignore_ascii_case(b"solid");
    let binary_content = head.iter().take(SNIFF_BYTES).any(|&b| b == 0);
    solid && !is_binary_length(head, len) && !binary_content
}

/// The checks of an STL file that its first bytes (`head`: [`SNIFF_BYTES`] or the whole file)
/// and its length allow, before the rest is read: a binary STL's triangle count against the
/// length. The errors are those [`read`] gives for the whole file.
pub(super) fn check_head(head: &[u8], len: u64, file: &str) -> Result<()> {
    let text = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    if text.trim_ascii_start().is_empty() && (head.len() as u64) < len {
        return Ok(()); // only blanks so far: `read` decides on the whole file
    }
    if is_ascii(head, len) {
        return Ok(());
    }
    binary_count(head, len, file).map(drop)
}

/// The triangle count of a binary STL of `len` bytes starting with `head`, checked against
/// the length: [`MeshError::Truncated`] or [`MeshError::HeaderMismatch`] when they disagree,
/// [`MeshError::NoTriangles`] for a count of 0.
fn binary_count(head: &[u8], len: u64, file: &str) -> Result<u32> {
    if len < (HEADER + 4) as u64 || head.len() < HEADER + 4 {
        return Err(MeshError::Truncated {
            file: file.into(),
            reason: format!("a binary STL needs an 84-byte header, the file has {len} bytes"),
        });
    }
    let n = count(head);
    let expected = HEADER as u64 + 4 + RECORD * u64::from(n);
    if expected != len {
        let body = len - HEADER as u64 - 4;
        let reason = format!(
            "the header announces {n} triangles ({expected} bytes), the file has {len} bytes"
        );
        let partial_record = body % RECORD;
        return Err(if len < expected && partial_record != 0 {
            MeshError::Truncated {
                file: file.into(),
                reason,
            }
        } else {
            MeshError::HeaderMismatch {
                file: file.into(),
                reason,
            }
        });
    }
    if n == 0 {
        return Err(super::no_triangles(
            file,
            "the binary STL header announces 0 triangles",
        ));
    }
    Ok(n)
}

pub(super) fn read(bytes: &[u8], file: &str, limits: &LoadLimits) -> Result<RawMesh> {
    if is_ascii(bytes, bytes.len() as u64) {
        let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        let trimmed = text.trim_ascii_start();
        let last_line = trimmed.split(|&b| b == b'\n').count();
        read_ascii(trimmed, file, limits).map_err(|e| match e {
            // A bad last line without a final newline: the file was cut short.
            MeshError::Parse {
                line: Some(l),
                reason,
                ..
            } if l == last_line && !trimmed.ends_with(b"\n") => MeshError::Truncated {
                file: file.into(),
                reason: format!("the ASCII STL ends in the middle of line {l} ({reason})"),
            },
            e => e,
        })
    } else {
        read_binary(bytes, file, limits)
    }
}

fn read_binary(bytes: &[u8], file: &str, limits: &LoadLimits) -> Result<RawMesh> {
    let n = binary_count(bytes, bytes.len() as u64, file)? as usize;
    let mut raw = RawMesh::default();
    raw.check_room(file, n, limits)?;
    // Sized by the header only after checking it against the bytes present; fallibly (a
    // process under an address-space limit gets an error, not an abort).
    let out_of_memory = |what: &str, bytes: usize| super::out_of_memory(file, what, bytes);
    raw.positions
        .try_reserve_exact(3 * n)
        .map_err(|_| out_of_memory("vertices", 3 * n * std::mem::size_of::<Vec3>()))?;
    raw.triangles
        .try_reserve_exact(n)
        .map_err(|_| out_of_memory("triangles", n * 12))?;
    raw.parts
        .try_reserve_exact(n)
        .map_err(|_| out_of_memory("part ids", n * 4))?;
    for (t, rec) in bytes[HEADER + 4..]
        .chunks_exact(RECORD as usize)
        .enumerate()
    {
        for k in 0..3 {
            let o = 12 + 12 * k;
            let c = |i: usize| {
                f32::from_le_bytes([rec[o + i], rec[o + i + 1], rec[o + i + 2], rec[o + i + 3]])
            };
            let p = Vec3::new(c(0), c(4), c(8));
            if !p.is_finite() {
                return Err(non_finite(file, format!("triangle {t} vertex {k}"), p));
            }
            raw.positions.push(p);
        }
        let b = 3 * t as u32;
        raw.triangles.push([b, b + 1, b + 2]);
    }
    raw.parts.resize(n, 0);
    raw.part_names = vec![String::from_utf8_lossy(&bytes[..HEADER])
        .trim_matches(|c: char| c == '\0' || c.is_whitespace())
        .to_string()];
    Ok(raw)
}

fn non_finite(file: &str, element: String, p: Vec3) -> MeshError {
    let bad = p.to_array().into_iter().find(|c| !c.is_finite());
    MeshError::NonFinite {
        file: file.into(),
        element,
        value: format!("{}", bad.unwrap_or(f32::NAN)),
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum State {
    /// Between solids.
    Outside,
    /// Inside a solid, between facets.
    Solid,
    /// After `facet normal …`, before `outer loop`.
    Facet,
    /// Inside `outer loop`, with this many vertices read.
    Loop(u8),
    /// After `endloop`, before `endfacet`.
    EndLoop,
}

fn read_ascii(text: &[u8], file: &str, limits: &LoadLimits) -> Result<RawMesh> {
    let mut raw = RawMesh::default();
    let mut state = State::Outside;
    let mut part = 0u32;
    let mut facet = 0usize;
    for line in super::text_lines(file, text) {
        let (lineno, line) = line?;
        let perr = |reason: String| super::parse_error(file, lineno, reason);
        let mut words = line.split_ascii_whitespace();
        let Some(word) = words.next() else { continue };
        let word = word.to_ascii_lowercase();
        match (state, word.as_str()) {
            (State::Outside, "solid") => {
                let name = line.trim().get(5..).unwrap_or("").trim().to_string();
                part = raw.part_names.len() as u32;
                raw.part_names.push(name);
                state = State::Solid;
            }
            (State::Solid, "facet") => {
                // The normal is ignored (recomputed from the vertices) but must be three numbers.
                if words.next().map(|w| w.eq_ignore_ascii_case("normal")) != Some(true) {
                    return Err(perr("expected `facet normal nx ny nz`".into()));
                }
                for _ in 0..3 {
                    parse_f32(words.next()).map_err(|r| perr(format!("facet normal: {r}")))?;
                }
                state = State::Facet;
            }
            (State::Solid, "endsolid") => state = State::Outside,
            (State::Facet, "outer") => {
                if words.next().map(|w| w.eq_ignore_ascii_case("loop")) != Some(true) {
                    return Err(perr("expected `outer loop`".into()));
                }
                state = State::Loop(0);
            }
            (State::Loop(k), "vertex") => {
                if k == 3 {
                    return Err(perr(format!(
                        "facet {facet} has more than 3 vertices (only triangles are allowed)"
                    )));
                }
                let mut c = [0.0f32; 3];
                for v in &mut c {
                    *v = parse_f32(words.next()).map_err(|r| perr(format!("vertex: {r}")))?;
                }
                let p = Vec3::from_array(c);
                if !p.is_finite() {
                    return Err(non_finite(
                        file,
                        format!("facet {facet} vertex {k} (line {lineno})"),
                        p,
                    ));
                }
                raw.positions.push(p);
                state = State::Loop(k + 1);
            }
            (State::Loop(k), "endloop") => {
                if k != 3 {
                    return Err(perr(format!("facet {facet} has {k} vertices, expected 3")));
                }
                raw.check_room(file, 1, limits)?;
                let b = raw.positions.len() as u32 - 3;
                raw.triangles.push([b, b + 1, b + 2]);
                raw.parts.push(part);
                facet += 1;
                state = State::EndLoop;
            }
            (State::EndLoop, "endfacet") => state = State::Solid,
            (_, w) => {
                return Err(perr(format!(
                    "unexpected `{}` {}",
                    w.chars().take(40).collect::<String>(),
                    match state {
                        State::Outside => "outside a solid (expected `solid`)",
                        State::Solid => "in a solid (expected `facet` or `endsolid`)",
                        State::Facet => "after `facet` (expected `outer loop`)",
                        State::Loop(_) => "in a loop (expected `vertex` or `endloop`)",
                        State::EndLoop => "after `endloop` (expected `endfacet`)",
                    }
                )))
            }
        }
    }
    if state != State::Outside {
        return Err(MeshError::Truncated {
            file: file.into(),
            reason: format!("the ASCII STL ends inside a {state:?} block (no `endsolid`)"),
        });
    }
    Ok(raw)
}

fn parse_f32(w: Option<&str>) -> std::result::Result<f32, String> {
    let w = w.ok_or_else(|| "missing number".to_string())?;
    w.parse::<f32>().map_err(|_| {
        format!(
            "`{}` is not a number",
            w.chars().take(40).collect::<String>()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::{box_mesh, gap_pair};
    use crate::write::{to_stl_ascii, to_stl_binary};
    use crate::{load_mesh_from_bytes, MeshFormat};

    #[test]
    fn binary_round_trip_welds_to_the_original() {
        let m = box_mesh(Vec3::new(-1.0, -2.0, 0.5), Vec3::new(3.0, 0.25, 0.75));
        let bytes = to_stl_binary(&m);
        assert!(is_binary_length(&bytes, bytes.len() as u64));
        let l = load_mesh_from_bytes(&bytes, "box.stl", None).unwrap();
        assert_eq!(l.format, MeshFormat::Stl);
        assert_eq!(l.mesh.triangle_count(), 12);
        assert_eq!(l.mesh.vertex_count(), 8);
        assert_eq!(l.report.input_vertices, 36);
        assert_eq!(l.report.welded_vertices, 28);
        assert!(l.mesh.topology().watertight);
        for i in 0..12 {
            assert_eq!(l.mesh.triangle(i), m.triangle(i));
        }
    }

    #[test]
    fn ascii_solids_become_parts() {
        let m = gap_pair(1.0, 0.125);
        let text = to_stl_ascii(&m);
        let l = load_mesh_from_bytes(text.as_bytes(), "pair.stl", Some(MeshFormat::Stl)).unwrap();
        assert_eq!(l.mesh.part_count(), 2);
        assert_eq!(l.part_names, vec!["part0", "part1"]);
        assert_eq!((l.mesh.triangle_count(), l.mesh.vertex_count()), (24, 16));
        assert_eq!(l.mesh.topology().component_count, 2);
        assert_eq!(l.mesh.parts(), m.parts());
    }

    #[test]
    fn binary_header_starting_with_solid_is_still_binary() {
        let m = box_mesh(Vec3::ZERO, Vec3::ONE);
        let mut bytes = to_stl_binary(&m);
        bytes[..6].copy_from_slice(b"solid ");
        let l = load_mesh_from_bytes(&bytes, "b.stl", None).unwrap();
        assert_eq!(l.mesh.triangle_count(), 12);
    }
}
