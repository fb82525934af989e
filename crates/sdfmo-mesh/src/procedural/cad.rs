//! Seeded CAD-like parts: a base plate with rectangular holes and slots, and on it bosses
//! (faceted cylinders), thin fins with faceted fillets at their foot, stacked blocks (touching,
//! or with a gap thinner than a voxel) and an open, bent sheet above it. Each feature is its own
//! part id, as a CAD exporter writes one solid per feature; features touch (coplanar contact)
//! without sharing vertices, which is exactly where an SVO merges what a multi-octree keeps
//! apart. The datasets of `sdfmo generate-parts` and of the sharded sweeps' tests come from here.
//!
//! The same seed gives the same mesh, bit for bit (the only randomness is [`SplitMix64`]; the
//! only library functions are `sin`/`cos` of facet and yaw angles, which a platform's libm
//! could round differently in the last bit).
//!
//! ```
//! use sdfmo_mesh::procedural::cad::cad_part;
//! let part = cad_part(7);
//! assert_eq!(part.mesh.triangles(), cad_part(7).mesh.triangles());
//! // Every closed feature is watertight on its own; only sheets are open.
//! for f in &part.features {
//!     assert_eq!(f.closed, f.kind != sdfmo_mesh::procedural::cad::FeatureKind::Sheet);
//! }
//! ```

use std::collections::HashMap;

use glam::{Mat3, Vec2, Vec3};
use sdfmo_io::SplitMix64;

use crate::mesh::TriMesh;

/// What a feature of a generated part is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FeatureKind {
    /// The base plate, with its holes and slots cut through.
    Plate,
    /// A faceted cylinder standing on the plate.
    Boss,
    /// A fin thinner than a depth-8 voxel (about) standing on the plate.
    Fin,
    /// A faceted quarter-round fillet in the concave corner at a fin's foot.
    Fillet,
    /// A block on the plate, or stacked on another block (touching, or over a thin gap).
    Block,
    /// An open sheet bent along one line (sheet metal): no inside.
    Sheet,
}

impl FeatureKind {
    /// Lower-case name, as the manifest's `features` column writes it.
    pub fn name(self) -> &'static str {
        match self {
            FeatureKind::Plate => "plate",
            FeatureKind::Boss => "boss",
            FeatureKind::Fin => "fin",
            FeatureKind::Fillet => "fillet",
            FeatureKind::Block => "block",
            FeatureKind::Sheet => "sheet",
        }
    }
}

/// One feature of a generated part: its kind, its part id in the mesh and whether it is closed.
#[derive(Clone, Debug, PartialEq)]
pub struct Feature {
    /// What it is.
    pub kind: FeatureKind,
    /// Its part id in [`CadPart::mesh`] (features are numbered in order).
    pub part: u32,
    /// Whether it is watertight on its own (everything but sheets).
    pub closed: bool,
}

/// A generated part: the mesh (model units, about 2 units across) and what it is made of.
#[derive(Clone, Debug)]
pub struct CadPart {
    /// All features merged, one part id each.
    pub mesh: TriMesh,
    /// The features in part-id order.
    pub features: Vec<Feature>,
    /// Holes and slots cut through the plate.
    pub holes: usize,
}

/// Thickness range of the fins and width range of the stacked blocks' gaps, in model units
/// (the part is about 2 units across, so about one unit = one normalised unit): 0.003–0.02 is
/// 0.4–2.6 voxels at depth 8 and 0.8–5 at depth 9.
pub const THIN_RANGE: (f32, f32) = (0.003, 0.02);

/// The seed of part `index` of a set made from `base`: parts of one set are independent and a
/// set's first parts do not change when more are asked for.
pub fn part_seed(base: u64, index: u64) -> u64 {
    SplitMix64::new(base ^ index.wrapping_mul(0xd134_2543_de82_ef95)).next_u64()
}

/// The CAD-like part of `seed` (see the module documentation).
pub fn cad_part(seed: u64) -> CadPart {
    let mut g = Gen {
        rng: SplitMix64::new(seed),
        meshes: Vec::new(),
        features: Vec::new(),
        keep_out: Vec::new(),
    };
    let plate = g.plate();
    let bosses = g.below(4);
    for _ in 0..bosses {
        g.boss(&plate);
    }
    let fins = g.below(4);
    for _ in 0..fins {
        g.fin(&plate);
    }
    let blocks = g.below(3);
    for _ in 0..blocks {
        g.block_stack(&plate);
    }
    if g.rng.next_f32() < 0.6 {
        g.sheet(&plate);
    }
    // A yaw so that the paper's axis-aligned cameras see fins and slots at varied angles.
    let yaw = Mat3::from_rotation_y(g.rng.range(0.0, std::f32::consts::FRAC_PI_2));
    let mesh = TriMesh::merge(&g.meshes).transformed(|p| yaw * p);
    CadPart {
        mesh,
        features: g.features,
        holes: plate.holes.len(),
    }
}

/// An axis-aligned rectangle in the plate's xz plane.
#[derive(Clone, Copy, Debug)]
struct Rect {
    min: Vec2,
    max: Vec2,
}

impl Rect {
    fn grown(self, by: f32) -> Rect {
        Rect {
            min: self.min - Vec2::splat(by),
            max: self.max + Vec2::splat(by),
        }
    }
    fn overlaps(&self, o: &Rect) -> bool {
        self.min.x < o.max.x && o.min.x < self.max.x && self.min.y < o.max.y && o.min.y < self.max.y
    }
    fn inside(&self, o: &Rect) -> bool {
        self.min.x >= o.min.x
            && self.min.y >= o.min.y
            && self.max.x <= o.max.x
            && self.max.y <= o.max.y
    }
}

/// The base plate: its outline, holes and top.
struct Plate {
    outline: Rect,
    holes: Vec<Rect>,
    top: f32,
}

/// The generator's state: the random numbers, the features so far and the footprints taken.
struct Gen {
    rng: SplitMix64,
    meshes: Vec<TriMesh>,
    features: Vec<Feature>,
    /// Footprints on the plate's top that are taken (features) or open (holes).
    keep_out: Vec<Rect>,
}

impl Gen {
    /// Uniform integer in `0..=n`.
    fn below(&mut self, n: u64) -> u64 {
        self.rng.next_u64() % (n + 1)
    }

    fn push(&mut self, mesh: TriMesh, kind: FeatureKind) {
        let part = self.features.len() as u32;
        self.features.push(Feature {
            kind,
            part,
            closed: kind != FeatureKind::Sheet,
        });
        self.meshes.push(mesh);
    }

    /// A free footprint of `size` on the plate (away from holes, other features and the rim),
    /// or `None` after a few tries.
    fn place(&mut self, plate: &Plate, size: Vec2, clearance: f32) -> Option<Rect> {
        let inner = plate.outline.grown(-0.03);
        for _ in 0..24 {
            let span = inner.max - inner.min - size;
            if span.x <= 0.0 || span.y <= 0.0 {
                return None;
            }
            let min =
                inner.min + Vec2::new(self.rng.range(0.0, span.x), self.rng.range(0.0, span.y));
            let r = Rect {
                min,
                max: min + size,
            };
            let padded = r.grown(clearance);
            if padded.inside(&plate.outline) && !self.keep_out.iter().any(|k| k.overlaps(&padded)) {
                self.keep_out.push(r);
                return Some(r);
            }
        }
        None
    }

    /// The plate: 1.2–2 × 0.8–1.6, 0.04–0.15 thick, with up to four holes or slots (a slot is
    /// a hole at least three times as long as wide), kept apart from each other and the rim.
    fn plate(&mut self) -> Plate {
        let (w, d) = (self.rng.range(1.2, 2.0), self.rng.range(0.8, 1.6));
        let t = self.rng.range(0.04, 0.15);
        let outline = Rect {
            min: Vec2::new(-w / 2.0, -d / 2.0),
            max: Vec2::new(w / 2.0, d / 2.0),
        };
        let mut plate = Plate {
            outline,
            holes: Vec::new(),
            top: 0.0,
        };
        for _ in 0..self.below(4) {
            let slot = self.rng.next_f32() < 0.5;
            let a = self.rng.range(0.05, 0.2);
            let size = if !slot {
                Vec2::splat(a)
            } else if self.rng.next_f32() < 0.5 {
                Vec2::new(a * self.rng.range(3.0, 5.0), a * 0.5)
            } else {
                Vec2::new(a * 0.5, a * self.rng.range(3.0, 5.0))
            };
            if let Some(r) = self.place(&plate, size, 0.05) {
                plate.holes.push(r);
            }
        }
        let mesh = extrude_with_holes(&plate.outline, &plate.holes, -t, 0.0);
        self.push(mesh, FeatureKind::Plate);
        plate
    }

    /// A boss: a cylinder of 12–96 facets, radius 0.04–0.15, height 0.05–0.4, on the plate.
    fn boss(&mut self, plate: &Plate) {
        let r = self.rng.range(0.04, 0.15);
        let h = self.rng.range(0.05, 0.4);
        let segments = 12 + (self.rng.next_u64() % 85) as usize;
        let Some(at) = self.place(plate, Vec2::splat(2.0 * r), 0.02) else {
            return;
        };
        let c = (at.min + at.max) * 0.5;
        let circle: Vec<Vec2> = (0..segments)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / segments as f64;
                Vec2::new((a.cos() * r as f64) as f32, (a.sin() * r as f64) as f32)
            })
            .collect();
        // Cross-section in (x, z), extruded along +y from the plate's top.
        let frame = Frame {
            origin: Vec3::new(c.x, plate.top, c.y),
            u: Vec3::X,
            v: Vec3::Z,
            w: Vec3::Y,
        };
        self.push(prism(&circle, &frame, 0.0, h), FeatureKind::Boss);
    }

    /// A fin along x or z, thickness in [`THIN_RANGE`], with a faceted fillet at its foot on one
    /// side (most of the time).
    fn fin(&mut self, plate: &Plate) {
        let t = self.rng.range(THIN_RANGE.0, THIN_RANGE.1);
        let len = self.rng.range(0.2, 0.8);
        let h = self.rng.range(0.08, 0.35);
        let fillet = self.rng.next_f32() < 0.7;
        let r = self.rng.range(0.02, 0.06);
        let along_x = self.rng.next_f32() < 0.5;
        // Footprint including the fillet on the fin's −(normal) side.
        let size = if along_x {
            Vec2::new(len, t + r)
        } else {
            Vec2::new(t + r, len)
        };
        let Some(at) = self.place(plate, size, 0.02) else {
            return;
        };
        let (fin_min, fin_max) = if along_x {
            (Vec2::new(at.min.x, at.min.y + r), at.max)
        } else {
            (Vec2::new(at.min.x + r, at.min.y), at.max)
        };
        self.push(
            super::box_mesh(
                Vec3::new(fin_min.x, plate.top, fin_min.y),
                Vec3::new(fin_max.x, plate.top + h, fin_max.y),
            ),
            FeatureKind::Fin,
        );
        if !fillet {
            return;
        }
        let facets = 2 + (self.rng.next_u64() % 7) as usize;
        // Cross-section in (n, y) with n pointing from the fin's face away from it: the corner
        // at the origin, the arc centred at (r, r) from (r, 0) on the plate to (0, r) on the fin.
        let mut section = vec![Vec2::ZERO];
        for k in 0..=facets {
            let a = std::f64::consts::FRAC_PI_2 * k as f64 / facets as f64;
            let (s, c) = a.sin_cos();
            section.push(Vec2::new(
                ((1.0 - s) * r as f64) as f32,
                ((1.0 - c) * r as f64) as f32,
            ));
        }
        let frame = if along_x {
            Frame {
                origin: Vec3::new(fin_min.x, plate.top, fin_min.y),
                u: -Vec3::Z,
                v: Vec3::Y,
                w: Vec3::X,
            }
        } else {
            Frame {
                origin: Vec3::new(fin_min.x, plate.top, fin_min.y),
                u: -Vec3::X,
                v: Vec3::Y,
                w: Vec3::Z,
            }
        };
        self.push(prism(&section, &frame, 0.0, len), FeatureKind::Fillet);
    }

    /// One to three blocks stacked on the plate: each on the one below, touching, or above it
    /// with a gap in [`THIN_RANGE`].
    fn block_stack(&mut self, plate: &Plate) {
        let size = Vec2::new(self.rng.range(0.1, 0.4), self.rng.range(0.1, 0.4));
        let Some(at) = self.place(plate, size, 0.02) else {
            return;
        };
        let mut y = plate.top;
        for level in 0..1 + self.below(2) {
            let inset = if level == 0 {
                0.0
            } else {
                self.rng.range(0.0, 0.03)
            };
            let h = self.rng.range(0.05, 0.15);
            if level > 0 && self.rng.next_f32() < 0.5 {
                y += self.rng.range(THIN_RANGE.0, THIN_RANGE.1);
            }
            self.push(
                super::box_mesh(
                    Vec3::new(at.min.x + inset, y, at.min.y + inset),
                    Vec3::new(at.max.x - inset, y + h, at.max.y - inset),
                ),
                FeatureKind::Block,
            );
            y += h;
        }
    }

    /// An open sheet above the plate, bent down along one edge (an L of sheet metal).
    fn sheet(&mut self, plate: &Plate) {
        let w = self.rng.range(0.3, 0.9);
        let d = self.rng.range(0.3, 0.7);
        let flap = self.rng.range(0.1, 0.3);
        let n = 4 + (self.rng.next_u64() % 13) as u32;
        let lift = self.rng.range(0.55, 0.75);
        let x = self.rng.range(plate.outline.min.x, plate.outline.max.x - w);
        let z = self.rng.range(plate.outline.min.y, plate.outline.max.y - d);
        // A sheet of depth d + flap in the xz plane; the strip beyond z = d folds down.
        let sheet = super::open_sheet(w, d + flap, n);
        let fold = d - (d + flap) * 0.5;
        let bent = sheet.transformed(|p| {
            let (px, pz) = (p.x + w * 0.5 + x, p.z);
            if pz > fold {
                Vec3::new(px, lift - (pz - fold), fold + (d + flap) * 0.5 + z)
            } else {
                Vec3::new(px, lift, pz + (d + flap) * 0.5 + z)
            }
        });
        self.push(bent, FeatureKind::Sheet);
    }
}

/// A right-handed frame: cross-sections are drawn in (u, v) and extruded along w.
struct Frame {
    origin: Vec3,
    u: Vec3,
    v: Vec3,
    w: Vec3,
}

/// A closed prism: the polygon `section` (star-shaped from its first vertex, which the caps'
/// fans start from) in `frame`'s (u, v) plane, extruded from w = `w0` to `w1`.
fn prism(section: &[Vec2], frame: &Frame, w0: f32, w1: f32) -> TriMesh {
    // Counter-clockwise in (u, v), so an edge's outward normal is (dv, −du).
    let area: f32 = (0..section.len())
        .map(|i| {
            let (a, b) = (section[i], section[(i + 1) % section.len()]);
            a.x * b.y - b.x * a.y
        })
        .sum();
    let poly: Vec<Vec2> = if area < 0.0 {
        let mut p = section.to_vec();
        p[1..].reverse();
        p
    } else {
        section.to_vec()
    };
    let n = poly.len() as u32;
    let at = |p: Vec2, w: f32| frame.origin + frame.u * p.x + frame.v * p.y + frame.w * w;
    let mut positions: Vec<Vec3> = poly.iter().map(|&p| at(p, w0)).collect();
    positions.extend(poly.iter().map(|&p| at(p, w1)));
    let mut b = Builder {
        positions,
        triangles: Vec::new(),
    };
    for k in 1..n - 1 {
        b.tri([0, k, k + 1], -frame.w);
        b.tri([n, n + k, n + k + 1], frame.w);
    }
    for k in 0..n {
        let k1 = (k + 1) % n;
        let d = poly[k1 as usize] - poly[k as usize];
        let out = frame.u * d.y - frame.v * d.x;
        b.quad([k, k1, k1 + n, k + n], out);
    }
    b.finish()
}

/// The closed slab `outline` × [y0, y1] with the rectangles `holes` cut through, on the grid
/// of every rectangle's edges, so that every vertex of a wall is a vertex of the faces it meets
/// (no T-junctions): watertight when the holes neither touch each other nor the rim.
fn extrude_with_holes(outline: &Rect, holes: &[Rect], y0: f32, y1: f32) -> TriMesh {
    let mut xs = vec![outline.min.x, outline.max.x];
    let mut zs = vec![outline.min.y, outline.max.y];
    for h in holes {
        xs.extend([h.min.x, h.max.x]);
        zs.extend([h.min.y, h.max.y]);
    }
    for v in [&mut xs, &mut zs] {
        v.sort_by(f32::total_cmp);
        v.dedup();
    }
    let (nx, nz) = (xs.len() - 1, zs.len() - 1);
    let solid = |i: isize, j: isize| -> bool {
        if i < 0 || j < 0 || i >= nx as isize || j >= nz as isize {
            return false;
        }
        let c = Vec2::new(
            (xs[i as usize] + xs[i as usize + 1]) * 0.5,
            (zs[j as usize] + zs[j as usize + 1]) * 0.5,
        );
        !holes
            .iter()
            .any(|h| c.x > h.min.x && c.x < h.max.x && c.y > h.min.y && c.y < h.max.y)
    };
    let mut b = Builder {
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    let mut index: HashMap<(usize, usize, bool), u32> = HashMap::new();
    let mut v = |b: &mut Builder, i: usize, j: usize, top: bool| -> u32 {
        *index.entry((i, j, top)).or_insert_with(|| {
            b.positions
                .push(Vec3::new(xs[i], if top { y1 } else { y0 }, zs[j]));
            b.positions.len() as u32 - 1
        })
    };
    for i in 0..nx {
        for j in 0..nz {
            if !solid(i as isize, j as isize) {
                continue;
            }
            for top in [false, true] {
                let q = [
                    v(&mut b, i, j, top),
                    v(&mut b, i + 1, j, top),
                    v(&mut b, i + 1, j + 1, top),
                    v(&mut b, i, j + 1, top),
                ];
                b.quad(q, if top { Vec3::Y } else { -Vec3::Y });
            }
            // Walls towards empty neighbours: (di, dj, the edge's two grid corners).
            let walls = [
                (-1, 0, (i, j), (i, j + 1)),
                (1, 0, (i + 1, j), (i + 1, j + 1)),
                (0, -1, (i, j), (i + 1, j)),
                (0, 1, (i, j + 1), (i + 1, j + 1)),
            ];
            for (di, dj, a, c) in walls {
                if solid(i as isize + di, j as isize + dj) {
                    continue;
                }
                let q = [
                    v(&mut b, a.0, a.1, false),
                    v(&mut b, c.0, c.1, false),
                    v(&mut b, c.0, c.1, true),
                    v(&mut b, a.0, a.1, true),
                ];
                b.quad(q, Vec3::new(di as f32, 0.0, dj as f32));
            }
        }
    }
    b.finish()
}

/// Triangles oriented by an outward direction as they are added.
struct Builder {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl Builder {
    /// Adds a triangle, flipped if its normal points against `outward`.
    fn tri(&mut self, t: [u32; 3], outward: Vec3) {
        let p = t.map(|i| self.positions[i as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        self.triangles.push(if n.dot(outward) < 0.0 {
            [t[0], t[2], t[1]]
        } else {
            t
        });
    }

    /// Adds a planar quad (a, b, c, d in order around it) as two triangles.
    fn quad(&mut self, q: [u32; 4], outward: Vec3) {
        self.tri([q[0], q[1], q[2]], outward);
        self.tri([q[0], q[2], q[3]], outward);
    }

    fn finish(self) -> TriMesh {
        let n = self.triangles.len();
        TriMesh::from_valid(self.positions, self.triangles, vec![0; n])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume by the divergence theorem (positive for outward normals).
    fn volume(m: &TriMesh, part: u32) -> f64 {
        (0..m.triangle_count())
            .filter(|&i| m.parts()[i] == part)
            .map(|i| {
                let [a, b, c] = m.triangle(i);
                a.as_dvec3().dot(b.as_dvec3().cross(c.as_dvec3())) / 6.0
            })
            .sum()
    }

    /// The triangles of one part as a mesh of their own.
    fn part_mesh(m: &TriMesh, part: u32) -> TriMesh {
        let tris: Vec<[u32; 3]> = m
            .triangles()
            .iter()
            .zip(m.parts())
            .filter(|(_, &p)| p == part)
            .map(|(t, _)| *t)
            .collect();
        let n = tris.len();
        TriMesh::new(m.positions().to_vec(), tris, vec![0; n]).unwrap()
    }

    #[test]
    fn parts_are_deterministic_per_seed_and_differ_between_seeds() {
        for seed in 0..20 {
            let (a, b) = (cad_part(seed), cad_part(seed));
            assert_eq!(a.mesh.positions(), b.mesh.positions());
            assert_eq!(a.mesh.triangles(), b.mesh.triangles());
            assert_eq!(a.features, b.features);
        }
        assert_ne!(cad_part(1).mesh.positions(), cad_part(2).mesh.positions());
        assert_ne!(part_seed(5, 0), part_seed(5, 1));
        assert_eq!(part_seed(5, 3), part_seed(5, 3));
    }

    #[test]
    fn closed_features_are_watertight_with_outward_normals_and_sheets_are_open() {
        let mut kinds = std::collections::HashSet::new();
        let mut holes = 0;
        for seed in 0..200 {
            let p = cad_part(part_seed(42, seed));
            holes += p.holes;
            let (_, report) = p.mesh.cleaned().unwrap();
            // Welding may join features that touch at a corner or an edge (a fillet and its
            // fin), as it joins the solids of a CAD export; nothing else is to clean.
            assert_eq!(
                (report.degenerate_triangles, report.duplicate_triangles),
                (0, 0),
                "seed {seed}: generated parts come clean"
            );
            assert_eq!(p.mesh.part_count(), p.features.len(), "seed {seed}");
            for f in &p.features {
                kinds.insert(f.kind);
                let t = part_mesh(&p.mesh, f.part).topology();
                assert_eq!(t.component_count, 1, "seed {seed} {f:?}");
                if f.closed {
                    assert!(t.watertight, "seed {seed} {f:?}: {t:?}");
                    assert!(volume(&p.mesh, f.part) > 0.0, "seed {seed} {f:?}: inward");
                } else {
                    assert!(t.boundary_edges > 0 && t.non_manifold_edges == 0, "{f:?}");
                }
            }
        }
        assert_eq!(kinds.len(), 6, "every kind of feature appears: {kinds:?}");
        assert!(
            holes > 100,
            "holes and slots are common ({holes} in 200 parts)"
        );
    }

    #[test]
    fn a_plate_with_holes_has_the_volume_of_its_solid_area() {
        let outline = Rect {
            min: Vec2::new(-1.0, -0.5),
            max: Vec2::new(1.0, 0.5),
        };
        let holes = [
            Rect {
                min: Vec2::new(-0.5, -0.1),
                max: Vec2::new(-0.3, 0.1),
            },
            Rect {
                min: Vec2::new(0.0, -0.25),
                max: Vec2::new(0.6, -0.15),
            },
        ];
        let m = extrude_with_holes(&outline, &holes, -0.1, 0.0);
        let t = m.topology();
        assert!(t.watertight);
        assert_eq!(t.component_count, 1);
        let solid = 2.0 - 0.2 * 0.2 - 0.6 * 0.1;
        assert!(
            (volume(&m, 0) - solid * 0.1).abs() < 1e-6,
            "{}",
            volume(&m, 0)
        );
    }
}
