//! OBJ reader on top of `tobj`.
//!
//! The input is first reduced to the statements that carry geometry (`v`, `f`, `o`, `g`), each
//! checked here with its line number: coordinates must be finite numbers and face indices must
//! be integers that resolve (1-based, or negative = relative) to an existing vertex. Texture
//! and normal references are stripped from faces, so `tobj` never sees an index it might
//! mishandle, and no material file is ever opened. `tobj` then groups faces into objects and
//! triangulates polygons (as fans); each distinct `o`/`g` name becomes a part.

use glam::Vec3;

use super::{LoadLimits, RawMesh};
use crate::error::{MeshError, Result};

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
    let mut clean = String::with_capacity(text.len().min(1 << 30));
    let mut vertices: u64 = 0;
    let mut face_triangles: usize = 0;
    for (i, line) in text.split(|&b| b == b'\n').enumerate() {
        let lineno = i + 1;
        let perr = |reason: String| MeshError::Parse {
            file: file.into(),
            line: Some(lineno),
            reason,
        };
        let line = std::str::from_utf8(line).map_err(|_| perr("not UTF-8 text".into()))?;
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            Some("v") => {
                let nums: Vec<&str> = words.collect();
                if nums.len() < 3 {
                    return Err(perr(format!(
                        "`v` needs 3 coordinates, found {}",
                        nums.len()
                    )));
                }
                let mut c = [0.0f32; 3];
                for (k, w) in nums[..3].iter().enumerate() {
                    c[k] = w.parse::<f32>().map_err(|_| {
                        perr(format!(
                            "`{}` is not a number",
                            w.chars().take(40).collect::<String>()
                        ))
                    })?;
                }
                let p = Vec3::from_array(c);
                if !p.is_finite() {
                    let bad = c.into_iter().find(|x| !x.is_finite()).unwrap_or(f32::NAN);
                    return Err(MeshError::NonFinite {
                        file: file.into(),
                        element: format!("vertex {} (line {lineno})", vertices + 1),
                        value: bad.to_string(),
                    });
                }
                vertices += 1;
                if vertices > limits.max_vertices as u64 {
                    return Err(MeshError::TooLarge {
                        file: file.into(),
                        what: "vertex count".into(),
                        count: vertices,
                        limit: limits.max_vertices as u64,
                    });
                }
                clean.push_str("v ");
                clean.push_str(&nums[..3].join(" "));
                if nums.len() == 4 {
                    // A homogeneous w: `tobj` divides by it (and rejects w = 0).
                    let w: f32 = nums[3]
                        .parse()
                        .map_err(|_| perr("bad `w` coordinate".into()))?;
                    if !w.is_finite() {
                        return Err(MeshError::NonFinite {
                            file: file.into(),
                            element: format!("vertex {vertices} w (line {lineno})"),
                            value: w.to_string(),
                        });
                    }
                    clean.push(' ');
                    clean.push_str(nums[3]);
                }
                clean.push('\n');
            }
            Some("f") => {
                let mut idx = Vec::new();
                for w in words {
                    let first = w.split('/').next().unwrap_or("");
                    let v: i64 = first.parse().map_err(|_| {
                        perr(format!(
                            "face index `{}` is not an integer",
                            w.chars().take(40).collect::<String>()
                        ))
                    })?;
                    let resolved = if v < 0 { vertices as i64 + v + 1 } else { v };
                    if v == 0 || resolved < 1 || resolved > vertices as i64 {
                        return Err(MeshError::IndexOutOfRange {
                            file: file.into(),
                            element: format!("face at line {lineno}"),
                            index: v,
                            vertex_count: vertices as usize,
                        });
                    }
                    idx.push(resolved);
                }
                if idx.len() < 3 {
                    // Points and lines are not surfaces.
                    continue;
                }
                face_triangles = face_triangles.saturating_add(idx.len() - 2);
                if face_triangles > limits.max_triangles {
                    return Err(MeshError::TooLarge {
                        file: file.into(),
                        what: "triangle count".into(),
                        count: face_triangles as u64,
                        limit: limits.max_triangles as u64,
                    });
                }
                clean.push('f');
                for v in idx {
                    clean.push(' ');
                    clean.push_str(&v.to_string());
                }
                clean.push('\n');
            }
            Some(w @ ("o" | "g")) => {
                let name = line.trim_start()[1..].trim();
                clean.push_str(w);
                clean.push(' ');
                clean.push_str(name);
                clean.push('\n');
            }
            _ => {}
        }
    }

    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = tobj::load_obj_buf(&mut clean.as_bytes(), &opts, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| MeshError::Parse {
        file: file.into(),
        line: None,
        reason: format!("tobj: {e}"),
    })?;

    let mut raw = RawMesh::default();
    for model in &models {
        let m = &model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let part = match raw.part_names.iter().position(|n| *n == model.name) {
            Some(p) => p as u32,
            None => {
                raw.part_names.push(model.name.clone());
                (raw.part_names.len() - 1) as u32
            }
        };
        let base = raw.positions.len();
        let nv = m.positions.len() / 3;
        raw.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2])),
        );
        raw.check_room(file, m.indices.len() / 3, limits)?;
        for t in m.indices.chunks_exact(3) {
            let mut tri = [0u32; 3];
            for (k, &v) in t.iter().enumerate() {
                if v as usize >= nv {
                    // tobj guarantees this; kept as an error rather than trust.
                    return Err(MeshError::IndexOutOfRange {
                        file: file.into(),
                        element: format!("object `{}`", model.name),
                        index: v as i64,
                        vertex_count: nv,
                    });
                }
                tri[k] = (base + v as usize) as u32;
            }
            raw.triangles.push(tri);
            raw.parts.push(part);
        }
    }
    for (i, p) in raw.positions.iter().enumerate() {
        if !p.is_finite() {
            // Reachable through a tiny `w` overflowing the division.
            return Err(MeshError::NonFinite {
                file: file.into(),
                element: format!("vertex {i} after dividing by w"),
                value: p.to_string(),
            });
        }
    }
    if raw.triangles.is_empty() {
        return Err(MeshError::NoTriangles {
            file: file.into(),
            reason: "the OBJ has no face with 3 or more vertices".into(),
        });
    }
    Ok(raw)
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
        let first: usize = l.mesh.parts.iter().filter(|&&p| p == 0).count();
        assert_eq!(first, 3);
        // `v 0 2 0 2.0` is divided by w.
        assert!(l.mesh.positions.contains(&Vec3::new(0.0, 1.0, 0.0)));
        assert!(l.mesh.positions.iter().all(|p| p.y <= 1.5));
        // Fan triangulation of the pentagon keeps the +z winding.
        for i in 0..l.mesh.triangle_count() {
            assert!(l.mesh.triangle_normal_f64(i)[2] > 0.0 || l.mesh.parts[i] == 0);
        }
    }

    #[test]
    fn content_sniffing() {
        assert!(looks_like_obj(b"# c\nv 1 2 3\nf 1 1 1\n"));
        assert!(!looks_like_obj(b"hello world\nv 1 2 3\n"));
        assert!(!looks_like_obj(b"# only comments\n"));
    }
}
