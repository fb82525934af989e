//! Writers for simple interchange formats (binary/ASCII STL, OBJ): used to export procedural
//! parts, to seed the fuzzers and to test the loaders by round trip.

use std::fmt::Write as _;

use crate::mesh::TriMesh;

/// Binary STL bytes (80-byte header, count, 50 bytes per triangle with its unit normal).
/// Parts are not represented (binary STL has none).
pub fn to_stl_binary(mesh: &TriMesh) -> Vec<u8> {
    let mut out = Vec::with_capacity(84 + 50 * mesh.triangle_count());
    let mut header = [b' '; 80];
    header[..16].copy_from_slice(b"sdfmo binary stl");
    out.extend_from_slice(&header);
    out.extend_from_slice(&(mesh.triangle_count() as u32).to_le_bytes());
    for i in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(i);
        let n = (b - a).cross(c - a).normalize_or_zero();
        for v in [n, a, b, c] {
            for x in v.to_array() {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        out.extend_from_slice(&[0, 0]);
    }
    out
}

/// ASCII STL text with one `solid partN` per part (in part order).
pub fn to_stl_ascii(mesh: &TriMesh) -> String {
    let mut s = String::new();
    for part in 0..mesh.part_count() as u32 {
        let _ = writeln!(s, "solid part{part}");
        for i in (0..mesh.triangle_count()).filter(|&i| mesh.parts[i] == part) {
            let [a, b, c] = mesh.triangle(i);
            let n = (b - a).cross(c - a).normalize_or_zero();
            let _ = writeln!(s, "  facet normal {:e} {:e} {:e}", n.x, n.y, n.z);
            s.push_str("    outer loop\n");
            for v in [a, b, c] {
                // `{:e}` of an f32 prints the shortest text that parses back to the same bits.
                let _ = writeln!(s, "      vertex {:e} {:e} {:e}", v.x, v.y, v.z);
            }
            s.push_str("    endloop\n  endfacet\n");
        }
        let _ = writeln!(s, "endsolid part{part}");
    }
    s
}

/// OBJ text: all vertices, then one `o partN` block of faces per part (in part order).
pub fn to_obj(mesh: &TriMesh) -> String {
    let mut s = String::new();
    for p in &mesh.positions {
        let _ = writeln!(s, "v {:e} {:e} {:e}", p.x, p.y, p.z);
    }
    for part in 0..mesh.part_count() as u32 {
        let _ = writeln!(s, "o part{part}");
        for (t, _) in mesh
            .triangles
            .iter()
            .zip(&mesh.parts)
            .filter(|(_, &p)| p == part)
        {
            let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
        }
    }
    s
}
