//! `distance_at` against the builder's exact signed distance (`sdfmo-distance`), within the
//! bound derived in its docs (`sdfmo_trace::distance_at`, "Accuracy"): the quantisation half
//! step `δ` plus the trilinear interpolation term `h·√(u(1−u) + v(1−v) + w(1−w))` of a
//! 1-Lipschitz field, and `δ` alone where the field is linear over the cell.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sdfmo_build::{build, BuildSettings, Method};
use sdfmo_distance::MeshDistance;
use sdfmo_format::ValueBits::{self, Eight, Sixteen};
use sdfmo_format::{quant, PackedOctree};
use sdfmo_mesh::{procedural, TriMesh};
use sdfmo_trace::distance_at;

/// f32 rounding of the corner distances (coordinates of magnitude ≤ 1), the dequantisation
/// product and the interpolation: a few ulps of 1.
const ROUNDING: f32 = 8.0 * f32::EPSILON;

/// The SVO of `mesh` at `depth` with `bits` per corner, and what the bounds need: the exact
/// signed distance in the octree's (normalised) frame, the leaf edge `h` and the quantisation
/// half step `δ = dmax / (2Q)`.
fn svo(mesh: &TriMesh, depth: u8, bits: ValueBits) -> (PackedOctree, MeshDistance, f32, f32) {
    let settings = BuildSettings::new(depth, Method::Svo).with_bits(bits);
    let (octree, _) = build(mesh, &settings).unwrap();
    let (normalized, _) = mesh.normalized(settings.margin);
    let exact = MeshDistance::new(&normalized, settings.sign).unwrap();
    let h = octree.meta().leaf_size();
    let delta = octree.meta().dmax() / quant::max_code(bits) as f32 / 2.0;
    (octree, exact, h, delta)
}

/// Points within `spread` of the surface: a random point of a random triangle moved along its
/// normal by up to ±`spread`.
fn near_surface(mesh: &TriMesh, n: usize, spread: f32, seed: u64) -> Vec<Vec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let [a, b, c] = mesh.triangle(rng.random_range(0..mesh.triangle_count()));
            let (mut s, mut t): (f32, f32) = (rng.random(), rng.random());
            if s + t > 1.0 {
                (s, t) = (1.0 - s, 1.0 - t);
            }
            let n = (b - a).cross(c - a).normalize();
            a + (b - a) * s + (c - a) * t + n * rng.random_range(-spread..spread)
        })
        .collect()
}

/// Two bounds on an icosphere. The general one: `δ + h·√Σu(1−u)` (any 1-Lipschitz field).
/// The tight one uses the smooth sphere `g(p) = |p| − R` through the mesh's vertices: the mesh
/// lies within the sagitta `s` of it, so `|f − g| ≤ s` everywhere (the distance functions of two
/// surfaces differ by at most their Hausdorff distance) and the interpolant of `f − g` too;
/// `g`'s second derivative along an axis is at most `1/|p|`, so linear interpolation along each
/// axis errs by at most `(h²/2)·u(1−u)/r` (`r` = the cell's distance from the centre), summed
/// over the three axes of the tensor product. In all: `δ + 2s + (h²/2)·Σu(1−u)/r`.
#[test]
fn sphere_values_are_within_quantisation_plus_interpolation_error() {
    let mesh = procedural::sphere(Vec3::ZERO, 1.0, 5);
    for (depth, bits) in [(5, Eight), (6, Sixteen), (7, Eight)] {
        let (octree, exact, h, delta) = svo(&mesh, depth, bits);
        let (normalized, _) = mesh.normalized(0.05);
        let radius = normalized
            .positions()
            .iter()
            .map(|p| p.length())
            .fold(0.0, f32::max);
        // The centre is `R − s` from the nearest point of the (inscribed) mesh.
        let sagitta = radius + exact.signed_distance(Vec3::ZERO);
        assert!(sagitta > 0.0 && sagitta < 1e-3, "sagitta {sagitta}");
        let points = near_surface(&normalized, 3000, 0.5 * h, u64::from(depth));
        let (mut answered, mut worst_general, mut worst_tight) = (0, 0.0f32, 0.0f32);
        for &p in &points {
            let Some(s) = distance_at(&octree, p) else {
                continue;
            };
            answered += 1;
            let f = exact.signed_distance(p);
            let err = (s.distance - f).abs();
            let l = (p - s.cell_min) / s.cell_size;
            let spread = (l * (Vec3::ONE - l)).element_sum().max(0.0);
            let general = delta + h * spread.sqrt() + ROUNDING;
            let nearest = Vec3::ZERO.clamp(s.cell_min, s.cell_min + Vec3::splat(s.cell_size));
            let tight = delta + 2.0 * sagitta + 0.5 * h * h * spread / nearest.length() + ROUNDING;
            assert!(
                err <= general && err <= tight,
                "depth {depth} {bits:?} at {p}: stored {} exact {f}, error {err} > {general} or {tight}",
                s.distance
            );
            worst_general = worst_general.max(err / general);
            worst_tight = worst_tight.max(err / tight);
        }
        // Half a leaf from the surface, nearly every point is in a stored leaf.
        assert!(
            answered * 10 >= points.len() * 9,
            "depth {depth}: {answered} of {}",
            points.len()
        );
        eprintln!(
            "depth {depth} {bits:?}: {answered} points, sagitta {sagitta:.2e}, worst error \
             {worst_general:.3} of the general bound, {worst_tight:.3} of the tight one"
        );
    }
}

/// Near the middle of a box face the signed distance is linear over the whole leaf (outside:
/// distance to the face's plane; inside: the face is nearer than any other), so trilinear
/// interpolation is exact and only quantisation remains, for the value and the gradient.
#[test]
fn box_face_values_and_gradients_are_within_quantisation_error() {
    let mesh = procedural::box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5));
    for (depth, bits) in [(6, Eight), (6, Sixteen), (8, Sixteen)] {
        let (octree, exact, h, delta) = svo(&mesh, depth, bits);
        let face = 0.95; // the box normalised to the extent 2·(1 − 0.05)
                         // The layer of leaves the face passes through: every one of them is stored.
        let x0 = ((face + 1.0) / h).floor() * h - 1.0;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut worst = 0.0f32;
        for _ in 0..2000 {
            let (y, z) = (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
            let p = Vec3::new(x0 + rng.random_range(0.0..h), y, z);
            let s = distance_at(&octree, p).unwrap_or_else(|| panic!("no leaf at {p}"));
            let f = exact.signed_distance(p);
            assert!(
                (f - (p.x - face)).abs() <= ROUNDING,
                "the field is the face's plane"
            );
            let err = (s.distance - f).abs();
            assert!(
                err <= delta + ROUNDING,
                "depth {depth} {bits:?} at {p}: error {err} > δ {delta}"
            );
            worst = worst.max(err / (delta + ROUNDING));
            // Each gradient component is a difference of corner values over h.
            let g_err = (s.gradient - Vec3::X).abs().max_element();
            let g_bound = 2.0 * (delta + ROUNDING) / h;
            assert!(
                g_err <= g_bound,
                "depth {depth} {bits:?} at {p}: gradient {} (error {g_err} > {g_bound})",
                s.gradient
            );
        }
        eprintln!("box depth {depth} {bits:?}: worst error {worst:.3} of δ");
    }
}

#[test]
fn far_from_the_surface_there_is_no_stored_leaf() {
    let mesh = procedural::sphere(Vec3::ZERO, 1.0, 3);
    let octree = svo(&mesh, 6, Eight).0;
    assert_eq!(
        distance_at(&octree, Vec3::ZERO),
        None,
        "the centre, 0.95 from the surface"
    );
    assert_eq!(
        distance_at(&octree, Vec3::splat(0.99)),
        None,
        "a corner of the root cube"
    );
    assert_eq!(
        distance_at(&octree, Vec3::new(0.0, 0.0, 1.5)),
        None,
        "outside the root cube"
    );
}
