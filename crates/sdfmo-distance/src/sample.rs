//! Deterministic query points for benchmarks, examples and comparisons with other tools.
//!
//! A SplitMix64 generator (Steele, Lea & Flood 2014) keeps the points identical on every platform
//! and independent of the `rand` crate's versions, so a benchmark and a peer script fed from a
//! file see exactly the same points.

use glam::Vec3;
use sdfmo_mesh::TriMesh;

/// The generator of the points (the project's one, from `sdfmo-io`).
pub use sdfmo_io::SplitMix64;

/// `n` points uniformly distributed in the root cube [-1, 1]³.
pub fn uniform_points(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        })
        .collect()
}

/// `n` points near the surface of `mesh`: a triangle chosen with probability proportional to its
/// area, a uniform point on it, then an offset in a uniformly random direction with a length
/// uniform in [0, `max_offset`). Empty if the mesh has no area.
pub fn near_surface_points(mesh: &TriMesh, n: usize, max_offset: f32, seed: u64) -> Vec<Vec3> {
    let mut cumulative = Vec::with_capacity(mesh.triangles().len());
    let mut total = 0.0f64;
    for i in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(i);
        total += 0.5 * (b - a).cross(c - a).length() as f64;
        cumulative.push(total);
    }
    if total <= 0.0 || !total.is_finite() {
        return Vec::new();
    }
    let mut rng = SplitMix64::new(seed);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let x = (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64) * total;
        let t = cumulative
            .partition_point(|&c| c <= x)
            .min(cumulative.len() - 1);
        let [a, b, c] = mesh.triangle(t);
        let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let dir = loop {
            let d = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let l2 = d.length_squared();
            if l2 > 1e-6 && l2 <= 1.0 {
                break d / l2.sqrt();
            }
        };
        out.push(a + (b - a) * u + (c - a) * v + dir * rng.range(0.0, max_offset));
    }
    out
}

/// Settings of [`sdf_training_points`]: DeepSDF-style samples for training neural SDFs.
///
/// Defaults follow DeepSDF (Park et al. 2019, §5: surface points perturbed with Gaussian noise
/// of variance 0.0025 and 0.00025 for a shape normalised into the unit sphere, i.e. σ = 0.05
/// and σ ≈ 0.0158 against a diameter of 2) with σ taken relative to the bounding-box diagonal
/// (≈ the unit sphere's diameter), plus a few uniform points in the padded box as mesh-to-sdf
/// does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainingSamples {
    /// Fraction of the samples taken near the surface (the rest is uniform in the padded box);
    /// in [0, 1]. Default 0.95.
    pub near_fraction: f32,
    /// Standard deviations of the two Gaussian noise scales, as fractions of the bounding-box
    /// diagonal; the near samples alternate between them (even index: the first). Default
    /// (0.025, 0.0079).
    pub sigmas: [f32; 2],
    /// The uniform samples' box is the bounding box grown by `padding` times its longest
    /// extent on every side. Default 0.1.
    pub padding: f32,
}

impl Default for TrainingSamples {
    fn default() -> Self {
        TrainingSamples {
            near_fraction: 0.95,
            sigmas: [0.025, 0.0079],
            padding: 0.1,
        }
    }
}

/// Samples per block of [`sdf_training_points`]: each block has its own generator, so the
/// blocks run in parallel and the points do not depend on the number of threads.
pub const TRAINING_BLOCK: usize = 4096;

/// The generator of block `block` of a run seeded with `seed` (SplitMix64's own mixing of the
/// pair, so neighbouring seeds and blocks give unrelated streams).
fn block_rng(seed: u64, block: u64) -> SplitMix64 {
    let mut mix = SplitMix64::new(seed ^ block.wrapping_mul(0xd1b5_4a32_d192_ed03));
    SplitMix64::new(mix.next_u64())
}

/// Two independent standard normal numbers (Box–Muller, in f64).
fn normal_pair(rng: &mut SplitMix64) -> (f64, f64) {
    // u1 in (0, 1]: ln(u1) is finite.
    let u1 = ((rng.next_u64() >> 11) + 1) as f64 * (1.0 / (1u64 << 53) as f64);
    let u2 = (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
    let r = (-2.0 * u1.ln()).sqrt();
    let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
    (r * c, r * s)
}

/// `n` DeepSDF-style sample points of `mesh`, in its own units: the first
/// `round(n · near_fraction)` are uniform points on the surface (a triangle chosen with
/// probability proportional to its area, a uniform point on it) plus isotropic Gaussian noise
/// of standard deviation `sigmas[i % 2]` × the bounding-box diagonal; the others are uniform in
/// the padded bounding box. Deterministic for a `seed` whatever the number of rayon threads
/// (blocks of [`TRAINING_BLOCK`] samples with their own generators). A mesh without area gets
/// uniform points only.
///
/// # Panics
/// If `near_fraction` is not in [0, 1] or a sigma or `padding` is negative or not finite
/// (callers validate user input first).
pub fn sdf_training_points(
    mesh: &TriMesh,
    n: usize,
    params: &TrainingSamples,
    seed: u64,
) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; n];
    sdf_training_points_into(mesh, &mut out, params, seed);
    out
}

/// [`sdf_training_points`] into `out`: its `out.len()` points, the same values. For callers
/// that allocate the buffer themselves (fallibly: the Python package turns a failed allocation
/// into `MemoryError`).
///
/// # Panics
/// As [`sdf_training_points`].
pub fn sdf_training_points_into(
    mesh: &TriMesh,
    out: &mut [Vec3],
    params: &TrainingSamples,
    seed: u64,
) {
    sdf_training_points_part(mesh, out.len(), 0, out, params, seed);
}

/// Points `start..start + out.len()` of the `n` points of [`sdf_training_points`], into `out`:
/// the same values as those of the whole run, so a caller can draw a large run in parts and
/// stop between them (the Python package's Ctrl-C). `start` must be a multiple of
/// [`TRAINING_BLOCK`]. Each call costs a pass over the triangles (the area table) besides its
/// points.
///
/// # Panics
/// As [`sdf_training_points`], and if `start` is not a multiple of [`TRAINING_BLOCK`] or the
/// part ends past `n`.
pub fn sdf_training_points_part(
    mesh: &TriMesh,
    n: usize,
    start: usize,
    out: &mut [Vec3],
    params: &TrainingSamples,
    seed: u64,
) {
    use rayon::prelude::*;
    assert!(start.is_multiple_of(TRAINING_BLOCK) && start + out.len() <= n);
    let first_block = start / TRAINING_BLOCK;
    assert!((0.0..=1.0).contains(&params.near_fraction));
    assert!(params.sigmas.iter().all(|s| s.is_finite() && *s >= 0.0));
    assert!(params.padding.is_finite() && params.padding >= 0.0);
    let mut cumulative = Vec::with_capacity(mesh.triangle_count());
    let mut total = 0.0f64;
    for i in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(i).map(|v| v.as_dvec3());
        total += 0.5 * (b - a).cross(c - a).length();
        cumulative.push(total);
    }
    let has_area = total > 0.0 && total.is_finite();
    let near = if has_area {
        ((n as f64) * f64::from(params.near_fraction)).round() as usize
    } else {
        0
    };
    let bounds = mesh.bounds();
    let (lo, hi) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
    let diagonal = (hi - lo).length();
    let pad = f64::from(params.padding) * (hi - lo).max_element();
    let (box_lo, box_hi) = (lo - pad, hi + pad);
    let sigma = params.sigmas.map(|s| f64::from(s) * diagonal);
    out.par_chunks_mut(TRAINING_BLOCK)
        .enumerate()
        .for_each(|(block, chunk)| {
            let block = first_block + block;
            let mut rng = block_rng(seed, block as u64);
            let first = block * TRAINING_BLOCK;
            for (k, slot) in chunk.iter_mut().enumerate() {
                let i = first + k;
                let p = if i < near {
                    let x = (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64) * total;
                    let t = cumulative
                        .partition_point(|&c| c <= x)
                        .min(cumulative.len() - 1);
                    let [a, b, c] = mesh.triangle(t).map(|v| v.as_dvec3());
                    let mut u = (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
                    let mut v = (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
                    if u + v > 1.0 {
                        (u, v) = (1.0 - u, 1.0 - v);
                    }
                    let (g0, g1) = normal_pair(&mut rng);
                    let (g2, _) = normal_pair(&mut rng);
                    let s = sigma[i % 2];
                    a + (b - a) * u + (c - a) * v + glam::DVec3::new(g0, g1, g2) * s
                } else {
                    let r = glam::DVec3::new(
                        (rng.next_u64() >> 11) as f64,
                        (rng.next_u64() >> 11) as f64,
                        (rng.next_u64() >> 11) as f64,
                    ) * (1.0 / (1u64 << 53) as f64);
                    box_lo + (box_hi - box_lo) * r
                };
                *slot = p.as_vec3();
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use sdfmo_mesh::procedural::box_mesh;

    #[test]
    fn a_run_drawn_in_parts_is_the_whole_run() {
        let mesh = box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5));
        let params = TrainingSamples::default();
        let n = 5 * TRAINING_BLOCK + 123;
        let whole = sdf_training_points(&mesh, n, &params, 4);
        let mut parts = vec![Vec3::ZERO; n];
        for (i, chunk) in parts.chunks_mut(2 * TRAINING_BLOCK).enumerate() {
            sdf_training_points_part(&mesh, n, i * 2 * TRAINING_BLOCK, chunk, &params, 4);
        }
        assert_eq!(parts, whole);
    }

    #[test]
    fn points_are_deterministic_and_in_range() {
        let a = uniform_points(1000, 5);
        assert_eq!(a, uniform_points(1000, 5));
        assert_ne!(a, uniform_points(1000, 6));
        assert!(a.iter().all(|p| p.abs().max_element() <= 1.0));
        let mean = a.iter().copied().sum::<Vec3>() / a.len() as f32;
        assert!(mean.abs().max_element() < 0.1, "{mean:?}");
    }

    #[test]
    fn near_surface_points_are_near_the_surface() {
        let mesh = box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5));
        let pts = near_surface_points(&mesh, 500, 0.01, 1);
        assert_eq!(pts.len(), 500);
        for p in &pts {
            // Exact distance to the surface of the box.
            let q = p.abs() - Vec3::splat(0.5);
            let d = if q.max_element() > 0.0 {
                q.max(Vec3::ZERO).length()
            } else {
                -q.max_element()
            };
            assert!(d <= 0.01 + 1e-6, "{p:?} is {d} from the surface");
        }
    }

    #[test]
    fn training_points_do_not_depend_on_the_thread_count() {
        let mesh = box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5));
        let params = TrainingSamples::default();
        let n = 3 * TRAINING_BLOCK + 17;
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| sdf_training_points(&mesh, n, &params, 9));
        let many = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap()
            .install(|| sdf_training_points(&mesh, n, &params, 9));
        assert_eq!(one, many);
        assert_ne!(one, sdf_training_points(&mesh, n, &params, 10));
    }

    #[test]
    fn training_points_follow_the_fractions_and_scales() {
        let mesh = box_mesh(Vec3::splat(-0.5), Vec3::splat(0.5));
        let params = TrainingSamples {
            near_fraction: 0.5,
            sigmas: [0.01, 0.001],
            padding: 0.25,
        };
        let n = 20_000;
        let pts = sdf_training_points(&mesh, n, &params, 1);
        let dist = |p: Vec3| {
            let q = p.abs() - Vec3::splat(0.5);
            q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
        };
        let diag = 3f32.sqrt();
        // Near samples: RMS distance to the surface ≈ σ·diag (one normal component counts
        // away from faces), 4σ bounds nearly all of them; the second scale is ten times finer.
        for (parity, sigma) in [(0, 0.01f32), (1, 0.001)] {
            let ds: Vec<f32> = (parity..n / 2)
                .step_by(2)
                .map(|i| dist(pts[i]).abs())
                .collect();
            let rms = (ds.iter().map(|d| d * d).sum::<f32>() / ds.len() as f32).sqrt();
            let s = sigma * diag;
            assert!(
                rms > 0.7 * s && rms < 1.3 * s,
                "parity {parity}: rms {rms} vs σ {s}"
            );
        }
        // Uniform samples: inside the padded box, and spread over it.
        let uniform = &pts[n / 2..];
        assert!(uniform.iter().all(|p| p.abs().max_element() <= 0.75 + 1e-6));
        let outside = uniform
            .iter()
            .filter(|p| p.abs().max_element() > 0.5)
            .count();
        let expected = 1.0 - (1.0f32 / 1.5).powi(3);
        let got = outside as f32 / uniform.len() as f32;
        assert!((got - expected).abs() < 0.03, "{got} vs {expected}");
    }
}
