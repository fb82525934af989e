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
        for i in (0..mesh.triangle_count()).filter(|&i| mesh.parts()[i] == part) {
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
    for p in mesh.positions() {
        let _ = writeln!(s, "v {:e} {:e} {:e}", p.x, p.y, p.z);
    }
    for part in 0..mesh.part_count() as u32 {
        let _ = writeln!(s, "o part{part}");
        for (t, _) in mesh
            .triangles()
            .iter()
            .zip(mesh.parts())
            .filter(|(_, &p)| p == part)
        {
            let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
        }
    }
    s
}

fn base64_encode(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(T[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// The glTF JSON and binary buffer of `mesh`: one node, one mesh, one triangle primitive per
/// part (in part order, parts without triangles skipped), all sharing one POSITION accessor.
fn gltf_parts(mesh: &TriMesh, buffer_uri: Option<&str>) -> (String, Vec<u8>) {
    let mut bin = Vec::new();
    for p in mesh.positions() {
        for x in p.to_array() {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    let pos_len = bin.len();
    let b = crate::Aabb::from_points(mesh.positions().iter().copied());
    let mut views = vec![format!(
        r#"{{"buffer":0,"byteOffset":0,"byteLength":{pos_len}}}"#
    )];
    let mut accessors = vec![format!(
        r#"{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":[{:e},{:e},{:e}],"max":[{:e},{:e},{:e}]}}"#,
        mesh.positions().len(),
        b.min.x,
        b.min.y,
        b.min.z,
        b.max.x,
        b.max.y,
        b.max.z
    )];
    let mut prims = Vec::new();
    for part in 0..mesh.part_count() as u32 {
        let start = bin.len();
        let mut n = 0;
        for (t, _) in mesh
            .triangles()
            .iter()
            .zip(mesh.parts())
            .filter(|(_, &q)| q == part)
        {
            for v in t {
                bin.extend_from_slice(&v.to_le_bytes());
            }
            n += 3;
        }
        if n == 0 {
            continue;
        }
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{start},"byteLength":{}}}"#,
            bin.len() - start
        ));
        accessors.push(format!(
            r#"{{"bufferView":{},"componentType":5125,"count":{n},"type":"SCALAR"}}"#,
            views.len() - 1
        ));
        prims.push(format!(
            r#"{{"attributes":{{"POSITION":0}},"indices":{},"mode":4}}"#,
            accessors.len() - 1
        ));
    }
    let uri = buffer_uri
        .map(|u| format!(r#","uri":"{u}""#))
        .unwrap_or_default();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{}]}}],"buffers":[{{"byteLength":{}{uri}}}],"bufferViews":[{}],"accessors":[{}]}}"#,
        prims.join(","),
        bin.len(),
        views.join(","),
        accessors.join(",")
    );
    (json, bin)
}

/// Binary glTF (GLB) bytes: see [`to_gltf_embedded`] for the layout; the buffer is the BIN
/// chunk.
pub fn to_glb(mesh: &TriMesh) -> Vec<u8> {
    let (json, bin) = gltf_parts(mesh, None);
    glb_container(&json, &bin)
}

/// A GLB file of a JSON chunk `json` (padded with spaces) and a BIN chunk `bin` (padded with
/// zeros), each to a multiple of 4 bytes, behind the 12-byte header (`glTF`, version 2, total
/// length). Also what the tests use to wrap hand-written glTF.
pub fn glb_container(json: &str, bin: &[u8]) -> Vec<u8> {
    let pad = |bytes: &[u8], fill: u8| {
        let mut v = bytes.to_vec();
        v.resize(bytes.len().next_multiple_of(4), fill);
        v
    };
    let (json, bin) = (pad(json.as_bytes(), b' '), pad(bin, 0));
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    for (tag, chunk) in [(b"JSON", &json), (b"BIN\0", &bin)] {
        out.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(tag);
        out.extend_from_slice(chunk);
    }
    out
}

/// glTF JSON text with the buffer embedded as a base64 `data:` URI: one node, one mesh, one
/// triangle primitive per part (so parts survive a round trip), one shared POSITION accessor.
pub fn to_gltf_embedded(mesh: &TriMesh) -> String {
    let (_, bin) = gltf_parts(mesh, None);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64_encode(&bin)
    );
    gltf_parts(mesh, Some(&uri)).0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::{demo_part, gap_pair};
    use crate::{load_mesh_from_bytes, MeshFormat};

    #[test]
    fn base64_known_values() {
        assert_eq!(base64_encode(b"hello"), "aGVsbG8=");
        assert_eq!(base64_encode(b""), "");
        assert_eq!(base64_encode(&[0, 1, 2]), "AAEC");
        assert_eq!(base64_encode(&[255]), "/w==");
    }

    /// Every writer's output loads back to the same mesh (same triangles, positions, parts).
    #[test]
    fn round_trips_through_every_format() {
        for m in [demo_part(), gap_pair(1.0, 0.25)] {
            let cases: Vec<(Vec<u8>, MeshFormat, bool)> = vec![
                (to_glb(&m), MeshFormat::Glb, true),
                (to_gltf_embedded(&m).into_bytes(), MeshFormat::Gltf, true),
                (to_obj(&m).into_bytes(), MeshFormat::Obj, true),
                (to_stl_ascii(&m).into_bytes(), MeshFormat::Stl, true),
                (to_stl_binary(&m), MeshFormat::Stl, false),
            ];
            for (bytes, format, keeps_parts) in cases {
                let l = load_mesh_from_bytes(&bytes, "rt", None).unwrap();
                assert_eq!(l.format, format);
                let r = &l.mesh;
                assert_eq!(r.triangle_count(), m.triangle_count(), "{format:?}");
                assert_eq!(r.vertex_count(), m.vertex_count(), "{format:?}");
                assert_eq!(r.bounds(), m.bounds(), "{format:?}");
                if keeps_parts {
                    assert_eq!(r.part_count(), m.part_count(), "{format:?}");
                    // Triangles are grouped by part on export: compare part by part.
                    for part in 0..m.part_count() as u32 {
                        let a: Vec<_> = (0..m.triangle_count())
                            .filter(|&i| m.parts()[i] == part)
                            .map(|i| m.triangle(i))
                            .collect();
                        let b: Vec<_> = (0..r.triangle_count())
                            .filter(|&i| r.parts()[i] == part)
                            .map(|i| r.triangle(i))
                            .collect();
                        assert_eq!(a, b, "{format:?} part {part}");
                    }
                } else {
                    for i in 0..m.triangle_count() {
                        assert_eq!(r.triangle(i), m.triangle(i));
                    }
                }
            }
        }
    }
}
