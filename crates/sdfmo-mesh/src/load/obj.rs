//! OBJ reader: one validating pass over the lines that produces positions, triangles and parts
//! directly.
//!
//! Only the statements that carry geometry are read (`v`, `f`, `o`, `g`), each checked with its
//! line number: coordinates must be finite numbers (a fourth, homogeneous `w` divides them and
//! must not be 0) and face indices must be integers that resolve (1-based, or negative =
//! relative) to an already defined vertex. Texture and normal references in faces are ignored,
//! and no material file is ever opened. Polygons are triangulated as fans `(0, k, k + 1)`;
//! points and lines are not surfaces and are skipped.
//!
//! Grouping follows the usual OBJ reading (tobj's, which this reader replaced): every `o` or `g`
//! statement that follows faces starts a new object, named by the rest of the line
//! (`unnamed_object` when empty or before the first statement); each distinct name is a part,
//! and each object gets its own copy of the vertices it uses, in the order of first use. Memory:
//! 20 bytes per `v` line plus the output (12 bytes per position, 16 per triangle), never a
//! re-serialised copy of the text (see `docs/results/mesh.md`).

use std::collections::HashMap;

use glam::Vec3;

use super::{LoadLimits, RawMesh};
use crate::error::{MeshError, Result};

/// Name of the object before the first `o`/`g` statement, and of an `o`/`g` without a name.
const UNNAMED: &str = "unnamed_object";

/// Weak content check: the first meaningful lines are OBJ statements.
pub(super) fn looks_like_obj(text: &[u8]) -> bool {
    const KNOWN: [&[u8]; 14] = [
        b"v", b"vn", b"vt", b"vp", b"f", b"o", b"g", b"s", b"l", b"p", b"mtllib", b"usemtl", b"#",
        b"cstype",
    ];
    let mut saw_geometry = false;
    for line in text.split(|&b| b == b'\n').take(200) {
        let Some(word) = line
            .split(|b| b.is_ascii_whitespace())
            .find(|w| !w.is_empty())
        else {
            continue;
        };
        if word.starts_with(b"#") {
            continue;
        }
        if !KNOWN.contains(&word) {
            return false;
        }
        if word == b"v" || word == b"f" {
            saw_geometry = true;
        }
    }
    saw_geometry
}

pub(super) fn read(bytes: &[u8], file: &str, limits: &LoadLimits) -> Result<RawMesh> {
    let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut raw = RawMesh::default();
    // Every vertex read so far (after dividing by w).
    let mut vertices: Vec<Vec3> = Vec::new();
    // `owner[v] == object` when vertex `v` already has a copy in the current object, at
    // `raw.positions[copy[v]]`.
    let mut owner: Vec<u32> = Vec::new();
    let mut copy: Vec<u32> = Vec::new();
    let mut object: u32 = 0;
    let mut name = String::from(UNNAMED);
    // The part of the current object, assigned at its first face.
    let mut part: Option<u32> = None;
    let mut part_ids: HashMap<String, u32> = HashMap::new();
    let mut face: Vec<u32> = Vec::new();
    for line in super::text_lines(file, text) {
        let (lineno, line) = line?;
        let perr = |reason: String| super::parse_error(file, lineno, reason);
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            Some("v") => {
                let n = vertices.len() + 1;
                let mut c = [0.0f32; 3];
                for (k, x) in c.iter_mut().enumerate() {
                    let w = words
                        .next()
                        .ok_or_else(|| perr(format!("`v` needs 3 coordinates, found {k}")))?;
                    *x = w.parse::<f32>().map_err(|_| {
                        perr(format!(
                            "`{}` is not a number",
                            w.chars().take(40).collect::<String>()
                        ))
                    })?;
                }
                let mut p = Vec3::from_array(c);
                if !p.is_finite() {
                    let bad = c.into_iter().find(|x| !x.is_finite()).unwrap_or(f32::NAN);
                    return Err(MeshError::NonFinite {
                        file: file.into(),
                        element: format!("vertex {n} (line {lineno})"),
                        value: bad.to_string(),
                    });
                }
                // Exactly four numbers: a homogeneous w. More (vertex colours) are ignored.
                if let (Some(w), None) = (words.next(), words.next()) {
                    let w: f32 = w.parse().map_err(|_| perr("bad `w` coordinate".into()))?;
                    if !w.is_finite() {
                        return Err(MeshError::NonFinite {
                            file: file.into(),
                            element: format!("vertex {n} w (line {lineno})"),
                            value: w.to_string(),
                        });
                    }
                    if w == 0.0 {
                        return Err(perr("`w` is 0: cannot divide the coordinates by it".into()));
                    }
                    p /= w;
                    if !p.is_finite() {
                        // A tiny w overflows the division.
                        return Err(MeshError::NonFinite {
                            file: file.into(),
                            element: format!("vertex {n} after dividing by w (line {lineno})"),
                            value: p.to_string(),
                        });
                    }
                }
                // Indices are u32: never more vertices than that, whatever the limits say.
                if n > limits.max_vertices.min(u32::MAX as usize) {
                    return Err(super::too_large(
                        file,
                        "vertex count",
                        n,
                        limits.max_vertices,
                    ));
                }
                vertices.push(p);
                owner.push(u32::MAX);
                copy.push(0);
            }
            Some("f") => {
                face.clear();
                let count = vertices.len() as i64;
                for w in words {
                    let first = w.split('/').next().unwrap_or("");
                    let v: i64 = first.parse().map_err(|_| {
                        perr(format!(
                            "face index `{}` is not an integer",
                            w.chars().take(40).collect::<String>()
                        ))
                    })?;
                    let resolved = if v < 0 { count + v + 1 } else { v };
                    if v == 0 || resolved < 1 || resolved > count {
                        return Err(MeshError::IndexOutOfRange {
                            file: file.into(),
                            element: format!("face at line {lineno}"),
                            index: v,
                            vertex_count: vertices.len(),
                        });
                    }
                    // `resolved <= count <= u32::MAX` (checked at each `v`).
                    face.push((resolved - 1) as u32);
                }
                if face.len() < 3 {
                    // Points and lines are not surfaces.
                    continue;
                }
                raw.check_room(file, face.len() - 2, limits)?;
                let part = *part.get_or_insert_with(|| {
                    let next = part_ids.len() as u32;
                    *part_ids.entry(name.clone()).or_insert_with(|| {
                        raw.part_names.push(name.clone());
                        next
                    })
                });
                let copies = raw.positions.len() + face.len();
                let what = "vertex count (copies per object)";
                super::check_limit(file, what, copies, u32::MAX as usize)?;
                for v in face.iter_mut() {
                    let k = *v as usize;
                    if owner[k] != object {
                        owner[k] = object;
                        copy[k] = raw.positions.len() as u32;
                        raw.positions.push(vertices[k]);
                    }
                    *v = copy[k];
                }
                for k in 1..face.len() - 1 {
                    raw.triangles.push([face[0], face[k], face[k + 1]]);
                    raw.parts.push(part);
                }
            }
            Some("o" | "g") => {
                if part.is_some() {
                    // The current object has faces: the statement ends it.
                    object += 1;
                    part = None;
                }
                let named = line.trim_start()[1..].trim();
                name.clear();
                name.push_str(if named.is_empty() { UNNAMED } else { named });
            }
            _ => {}
        }
    }
    raw.with_triangles(file, "the OBJ has no face with 3 or more vertices")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{load_mesh_from_bytes, MeshFormat};

    #[test]
    fn groups_polygons_relative_indices_and_w() {
        let text =
            b"# features\nmtllib missing.mtl\no first\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 2 0 2.0\n\
vt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\ng second\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0.5 1.5 1\n\
v 0 1 1\nusemtl m\nf -5 -4 -3 -2 -1\no first\nf 1//1 3//1 5//1\ns off\nl 1 2\nf 1 2\n";
        let l = load_mesh_from_bytes(text, "f.obj", None).unwrap();
        assert_eq!(l.format, MeshFormat::Obj);
        // A quad (2 triangles), a pentagon (3), one more triangle back in `first`.
        assert_eq!(l.mesh.triangle_count(), 6);
        assert_eq!(l.part_names, vec!["first", "second"]);
        assert_eq!(l.mesh.part_count(), 2);
        let first: usize = l.mesh.parts().iter().filter(|&&p| p == 0).count();
        assert_eq!(first, 3);
        // `v 0 2 0 2.0` is divided by w.
        assert!(l.mesh.positions().contains(&Vec3::new(0.0, 1.0, 0.0)));
        assert!(l.mesh.positions().iter().all(|p| p.y <= 1.5));
        // Fan triangulation of the pentagon keeps the +z winding.
        for i in 0..l.mesh.triangle_count() {
            assert!(l.mesh.triangle_normal_f64(i)[2] > 0.0 || l.mesh.parts()[i] == 0);
        }
    }

    /// The reader's raw output before welding: each object gets its own copies of the vertices it
    /// uses, in order of first use (as tobj gave them before this reader replaced it), and an
    /// `o`/`g` without a name, or faces before the first one, belong to `unnamed_object`.
    #[test]
    fn objects_copy_their_vertices_and_unnamed_objects_share_a_part() {
        let text = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 3 2 1\ng\nf 2 4 3\ng named\nf 1 2 3\n";
        let raw = read(text, "o.obj", &LoadLimits::default()).unwrap();
        assert_eq!(raw.part_names, vec![UNNAMED, "named"]);
        assert_eq!(raw.parts, vec![0, 0, 1]);
        assert_eq!(raw.triangles, vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]]);
        let v = |x, y| Vec3::new(x, y, 0.0);
        assert_eq!(
            raw.positions,
            vec![
                v(0., 1.),
                v(1., 0.),
                v(0., 0.),
                v(1., 0.),
                v(1., 1.),
                v(0., 1.),
                v(0., 0.),
                v(1., 0.),
                v(0., 1.)
            ]
        );
        // `o`/`g` statements with no faces between them do not split an object.
        let raw = read(
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\ng a\no b\nf 1 2 3\nf 1 2 3\n",
            "o.obj",
            &LoadLimits::default(),
        )
        .unwrap();
        assert_eq!(
            (raw.part_names, raw.positions.len()),
            (vec!["b".to_string()], 3)
        );
    }

    #[test]
    fn w_that_overflows_the_division_is_non_finite() {
        let text = b"v 1e30 0 0 1e-30\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let err = read(text, "w.obj", &LoadLimits::default()).unwrap_err();
        assert!(matches!(err, MeshError::NonFinite { .. }), "{err}");
        let err = read(b"v 1 0 0 0\n", "w.obj", &LoadLimits::default()).unwrap_err();
        assert!(
            matches!(err, MeshError::Parse { line: Some(1), .. }),
            "{err}"
        );
    }

    #[test]
    fn content_sniffing() {
        assert!(looks_like_obj(b"# c\nv 1 2 3\nf 1 1 1\n"));
        assert!(!looks_like_obj(b"hello world\nv 1 2 3\n"));
        assert!(!looks_like_obj(b"# only comments\n"));
    }
}
