//! Procedural test parts, in model units. Every function returns a valid, welded mesh with
//! counter-clockwise triangles seen from outside (outward normals) and no degenerate or
//! duplicate triangle.
//!
//! | part | triangles | closed | parts |
//! |---|---|---|---|
//! | [`box_mesh`] | 12 | yes | 1 |
//! | [`sphere`] (s subdivisions) | 20·4^s | yes | 1 |
//! | [`thin_plate`] | 12 | yes | 1 |
//! | [`open_sheet`] (n segments) | 2·n² | no (4n boundary edges) | 1 |
//! | [`gap_pair`] | 24 | yes | 2 |
//! | [`demo_part`] | 1,456 | no (the sheet is open) | 6 |
//! | [`fan_cylinder`] (n segments) | 4n − 4 | yes | 1 |
//! | [`fan_disc`] (n triangles) | n | no (n boundary edges) | 1 |
//! | [`cad::cad_part`] (seeded) | hundreds to thousands | every part but its sheet | 1–23 |

use std::collections::HashMap;

use glam::{Mat3, Vec3};

use crate::mesh::TriMesh;

pub mod cad;

/// Depth-7 voxel edge in the normalised frame (`2 / 2^7`): the demo's thin plate and gap are
/// sized against it.
pub const DEPTH7_VOXEL: f32 = 2.0 / 128.0;

/// Thickness of the demo's thin plate and width of its gap, in normalised units (equal to the
/// demo's model units): 0.4 of a depth-7 voxel, 0.8 of a depth-8 voxel, 1.6 depth-9 voxels.
pub const DEMO_THIN: f32 = 0.4 * DEPTH7_VOXEL;

/// An axis-aligned box from `min` to `max`: 8 vertices, 12 triangles, closed.
pub fn box_mesh(min: Vec3, max: Vec3) -> TriMesh {
    // Corner i = 4x + 2y + z, the octree's corner order.
    let positions = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 4 != 0 { max.x } else { min.x },
                if i & 2 != 0 { max.y } else { min.y },
                if i & 1 != 0 { max.z } else { min.z },
            )
        })
        .collect();
    let triangles = vec![
        [0, 1, 3],
        [0, 3, 2], // −x
        [4, 7, 5],
        [4, 6, 7], // +x
        [0, 4, 5],
        [0, 5, 1], // −y
        [2, 3, 7],
        [2, 7, 6], // +y
        [0, 2, 6],
        [0, 6, 4], // −z
        [1, 5, 7],
        [1, 7, 3], // +z
    ];
    TriMesh::from_valid(positions, triangles, vec![0; 12])
}

/// A closed icosphere: an icosahedron subdivided `subdivisions` times (clamped to 8), vertices
/// projected onto the sphere; 20·4^s triangles, 10·4^s + 2 vertices.
pub fn sphere(center: Vec3, radius: f32, subdivisions: u32) -> TriMesh {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .into_iter()
    .map(|p| Vec3::from_array(p).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions.min(8) {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    let n = triangles.len();
    TriMesh::from_valid(
        positions.into_iter().map(|p| center + p * radius).collect(),
        triangles,
        vec![0; n],
    )
}

/// A closed box centred at the origin with edge lengths `size` (x, y = thickness, z): a plate
/// lying in the xz plane when `size.y` is small.
pub fn thin_plate(size: Vec3) -> TriMesh {
    box_mesh(-size * 0.5, size * 0.5)
}

/// One open flat sheet in the plane y = 0, centred at the origin, `width` along x and `depth`
/// along z, as a grid of `segments` × `segments` quads (at least 1), normals +y.
pub fn open_sheet(width: f32, depth: f32, segments: u32) -> TriMesh {
    let n = segments.max(1);
    let mut positions = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for i in 0..=n {
        for j in 0..=n {
            positions.push(Vec3::new(
                width * (i as f32 / n as f32 - 0.5),
                0.0,
                depth * (j as f32 / n as f32 - 0.5),
            ));
        }
    }
    let v = |i: u32, j: u32| i * (n + 1) + j;
    let mut triangles = Vec::with_capacity((2 * n * n) as usize);
    for i in 0..n {
        for j in 0..n {
            triangles.push([v(i, j), v(i, j + 1), v(i + 1, j)]);
            triangles.push([v(i + 1, j), v(i, j + 1), v(i + 1, j + 1)]);
        }
    }
    let len = triangles.len();
    TriMesh::from_valid(positions, triangles, vec![0; len])
}

/// Two closed cubes of edge `size`, stacked along y with a horizontal gap of `gap` between them
/// (the gap is the plane y = 0 region |y| < gap/2), centred at the origin; part 0 below, part 1
/// above. Cameras in the y = 0 plane look straight into the slot.
pub fn gap_pair(size: f32, gap: f32) -> TriMesh {
    let h = size * 0.5;
    let g = gap * 0.5;
    let lower = box_mesh(Vec3::new(-h, -size - g, -h), Vec3::new(h, -g, h));
    let upper = box_mesh(Vec3::new(-h, g, -h), Vec3::new(h, size + g, h));
    TriMesh::merge(&[lower, upper])
}

/// A closed cylinder along y (radius `radius`, height `height`, centred at the origin) with
/// `segments` side quads (at least 3) and each cap triangulated as a fan from one of its rim
/// vertices, as CAD exporters (and OBJ polygon triangulation) write n-gons: 4·segments − 4
/// triangles (2,396 for 600 segments), each cap's triangles all sharing rim vertex 0.
pub fn fan_cylinder(segments: u32, radius: f32, height: f32) -> TriMesh {
    let n = segments.max(3);
    let h = height * 0.5;
    // Vertices: bottom ring 0..n, top ring n..2n; angle grows from +x towards +z.
    let mut positions = Vec::with_capacity(2 * n as usize);
    for y in [-h, h] {
        for k in 0..n {
            let a = std::f32::consts::TAU * k as f32 / n as f32;
            positions.push(Vec3::new(radius * a.cos(), y, radius * a.sin()));
        }
    }
    let mut triangles = Vec::with_capacity(4 * n as usize - 4);
    for k in 0..n {
        let k1 = (k + 1) % n;
        // Outward side normals need (k, k + n, k1) order.
        triangles.push([k, k + n, k1]);
        triangles.push([k1, k + n, k1 + n]);
    }
    for k in 1..n - 1 {
        triangles.push([0, k, k + 1]); // bottom cap, normal −y
        triangles.push([n, n + k + 1, n + k]); // top cap, normal +y
    }
    let len = triangles.len();
    TriMesh::from_valid(positions, triangles, vec![0; len])
}

/// An open unit disc in the plane z = 0 made of `triangles` wedges (at least 3) that all share
/// its centre: the shape that makes bottom-up BVH builders degenerate.
pub fn fan_disc(triangles: u32) -> TriMesh {
    let n = triangles.max(3);
    let mut positions = vec![Vec3::ZERO];
    for k in 0..n {
        let a = std::f32::consts::TAU * k as f32 / n as f32;
        positions.push(Vec3::new(a.cos(), a.sin(), 0.0));
    }
    let tris: Vec<[u32; 3]> = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
    let len = tris.len();
    TriMesh::from_valid(positions, tris, vec![0; len])
}

/// The built-in demo: a sphere, a box, a thin plate, an open sheet and two boxes with a
/// sub-voxel gap, laid out so the multi-octree's advantage over an SVO shows in the paper's
/// four views (cameras on a circle in the y = 0 plane looking at the origin, along ±x and ±z).
///
/// Three levels, vertically apart so no level hides another: the gap pair at eye height in the
/// middle, two parts above and two below, each pair on opposite diagonals of the xz plane so
/// neither hides the other from any of the four views. Units are chosen so that normalisation
/// with the default margin 0.05 is the identity (up to rounding): the bounding box is
/// y ∈ [−0.95, 0.95], x, z ∈ [−0.75, 0.75], centred at the origin. Parts (ids):
/// 0. sphere, radius 0.25, centred at (−0.5, 0.7, −0.5) (1,280 triangles);
/// 1. box, edge 0.5, centred at (0.5, 0.7, 0.5): a plain closed volume;
/// 2. thin plate 0.6 wide × 0.5 tall × [`DEMO_THIN`] thick (0.4 of a depth-7 voxel), upright
///    at (0.5, −0.7, −0.5), its normal horizontal at 45° so every view sees a face obliquely:
///    an SVO loses it or shows holes;
/// 3. open sheet 0.6 × 0.5 (8 × 8 quads), upright at (−0.5, −0.7, 0.5), same orientation: it
///    has no inside, so an SVO cannot represent it;
/// 4. and 5. two cubes of edge 0.35 stacked at the origin with a horizontal slot of
///    [`DEMO_THIN`] at y = 0, the eye height, so every view looks straight through it: an SVO
///    closes it.
pub fn demo_part() -> TriMesh {
    let upright = Mat3::from_rotation_y(std::f32::consts::FRAC_PI_4)
        * Mat3::from_rotation_x(std::f32::consts::FRAC_PI_2);
    let place = |m: TriMesh, rot: Mat3, at: Vec3| m.transformed(|p| rot * p + at);
    TriMesh::merge(&[
        sphere(Vec3::new(-0.5, 0.7, -0.5), 0.25, 3),
        box_mesh(Vec3::new(0.25, 0.45, 0.25), Vec3::new(0.75, 0.95, 0.75)),
        place(
            thin_plate(Vec3::new(0.6, DEMO_THIN, 0.5)),
            upright,
            Vec3::new(0.5, -0.7, -0.5),
        ),
        place(open_sheet(0.6, 0.5, 8), upright, Vec3::new(-0.5, -0.7, 0.5)),
        gap_pair(0.35, DEMO_THIN),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume by the divergence theorem (positive for outward normals).
    fn volume(m: &TriMesh) -> f64 {
        (0..m.triangle_count())
            .map(|i| {
                let [a, b, c] = m.triangle(i);
                a.as_dvec3().dot(b.as_dvec3().cross(c.as_dvec3())) / 6.0
            })
            .sum()
    }

    fn assert_clean(m: &TriMesh) {
        let (c, r) = m.cleaned().unwrap();
        assert_eq!(
            (
                r.welded_vertices,
                r.degenerate_triangles,
                r.duplicate_triangles,
                r.unreferenced_vertices
            ),
            (0, 0, 0, 0),
            "procedural meshes come welded and clean"
        );
        assert_eq!(c.triangle_count(), m.triangle_count());
        TriMesh::new(
            m.positions().to_vec(),
            m.triangles().to_vec(),
            m.parts().to_vec(),
        )
        .unwrap();
    }

    #[test]
    fn box_is_closed_and_outward() {
        let m = box_mesh(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(1.0, 3.0, 2.5));
        assert_clean(&m);
        let t = m.topology();
        assert!(t.watertight);
        assert_eq!(
            (m.triangle_count(), m.vertex_count(), t.component_count),
            (12, 8, 1)
        );
        assert!((volume(&m) - 2.0 * 3.0 * 0.5).abs() < 1e-9);
        assert!((m.area() - 2.0 * (6.0 + 1.0 + 1.5)).abs() < 1e-9);
    }

    #[test]
    fn sphere_counts_and_volume() {
        for s in 0..4 {
            let m = sphere(Vec3::new(1.0, 2.0, 3.0), 2.0, s);
            assert_clean(&m);
            assert_eq!(m.triangle_count(), 20 * 4usize.pow(s));
            assert_eq!(m.vertex_count(), 10 * 4usize.pow(s) + 2);
            assert!(m.topology().watertight);
            for p in m.positions() {
                assert!(((*p - Vec3::new(1.0, 2.0, 3.0)).length() - 2.0).abs() < 1e-5);
            }
            let v = volume(&m);
            let exact = 4.0 / 3.0 * std::f64::consts::PI * 8.0;
            assert!(v > 0.0 && v < exact && v > 0.6 * exact, "s={s} v={v}");
        }
    }

    #[test]
    fn sheet_and_plate_and_gap_pair() {
        let s = open_sheet(2.0, 1.0, 4);
        assert_clean(&s);
        let t = s.topology();
        assert_eq!(
            (s.triangle_count(), t.boundary_edges, t.component_count),
            (32, 16, 1)
        );
        assert!(!t.watertight);
        for i in 0..s.triangle_count() {
            assert!(s.triangle_normal_f64(i)[1] > 0.0);
        }
        let p = thin_plate(Vec3::new(1.0, 0.001, 2.0));
        assert!(p.topology().watertight);
        assert!((volume(&p) - 0.002).abs() < 1e-7);
        let g = gap_pair(1.0, 0.01);
        assert_clean(&g);
        let t = g.topology();
        assert_eq!((t.component_count, g.part_count()), (2, 2));
        assert!(t.watertight);
        let b = g.bounds();
        assert!((b.size().y - 2.01).abs() < 1e-6);
    }

    #[test]
    fn demo_is_laid_out_as_documented() {
        let m = demo_part();
        assert_clean(&m);
        assert_eq!(m.triangle_count(), 1280 + 12 + 12 + 128 + 24);
        assert_eq!(m.part_count(), 6);
        let t = m.topology();
        assert_eq!(t.component_count, 6);
        assert_eq!(t.boundary_edges, 32, "only the sheet is open");
        let b = m.bounds();
        assert!(
            (b.min - Vec3::new(-0.75, -0.95, -0.75)).length() < 1e-6,
            "{b:?}"
        );
        assert!(
            (b.max - Vec3::new(0.75, 0.95, 0.75)).length() < 1e-6,
            "{b:?}"
        );
        assert!(b.center().length() < 1e-6);
        // The three levels do not overlap in height: gap pair in the middle, the rest above or
        // below it (so no level hides another from a camera at y = 0).
        for i in 0..m.triangle_count() {
            let ys = m.triangle(i).map(|p| p.y);
            let (lo, hi) = (
                ys.iter().cloned().fold(f32::MAX, f32::min),
                ys.iter().cloned().fold(f32::MIN, f32::max),
            );
            match m.parts()[i] {
                0 | 1 => assert!(lo >= 0.45 - 1e-6),
                2 | 3 => assert!(hi <= -0.45 + 1e-6),
                _ => assert!(lo >= -0.36 && hi <= 0.36),
            }
        }
        let (n, tr) = m.normalized(0.05);
        assert!((tr.scale - 1.0).abs() < 1e-6);
        // The plate and the gap stay thinner than a depth-7 voxel after normalisation.
        let thin = DEMO_THIN * tr.scale;
        assert!(thin < DEPTH7_VOXEL && thin > 0.0);
        // The plate's two faces are DEMO_THIN apart: check via its vertices' spread along the
        // plate normal.
        let normal = Vec3::new(1.0, 0.0, 1.0).normalize();
        let plate: Vec<f32> = n
            .triangles()
            .iter()
            .zip(n.parts())
            .filter(|(_, &p)| p == 2)
            .flat_map(|(t, _)| t.map(|v| n.positions()[v as usize].dot(normal)))
            .collect();
        let spread = plate.iter().cloned().fold(f32::MIN, f32::max)
            - plate.iter().cloned().fold(f32::MAX, f32::min);
        assert!((spread - thin).abs() < 1e-5, "plate thickness {spread}");
    }
}
