//! Random ray–voxel kernel cases, shared by the `trace` bench and the `kernel_speed` example
//! (included with `#[path]`: benches and examples cannot import each other).

use std::hint::black_box;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sdfmo_trace::{intersect_voxel, unit_cube_span};

/// One call of the kernel: corners, ray and segment, voxel kind.
pub struct KernelCase {
    pub corners: [f32; 8],
    pub origin: Vec3,
    pub dir: Vec3,
    pub t0: f32,
    pub t1: f32,
    pub surface: bool,
}

/// Voxels whose corners change sign (the early-out does not apply), rays through the cube.
pub fn kernel_cases(n: usize, surface_share: f64) -> Vec<KernelCase> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let corners: [f32; 8] = core::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let (lo, hi) = corners
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &c| (a.min(c), b.max(c)));
        if lo > 0.0 || hi < 0.0 {
            continue;
        }
        let dir = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize();
        let target = Vec3::new(
            rng.random_range(0.0..1.0),
            rng.random_range(0.0..1.0),
            rng.random_range(0.0..1.0),
        );
        let origin = target - dir * 3.0;
        let Some((t0, t1)) = unit_cube_span(origin, dir) else {
            continue;
        };
        out.push(KernelCase {
            corners,
            origin,
            dir,
            t0,
            t1,
            surface: rng.random_bool(surface_share),
        });
    }
    out
}

/// The kernel on every case (inputs behind `black_box`): how many hit.
pub fn hits(cases: &[KernelCase]) -> u32 {
    let mut n = 0;
    for k in cases {
        let r = intersect_voxel(
            black_box(&k.corners),
            black_box(k.origin),
            black_box(k.dir),
            k.t0,
            k.t1,
            k.surface,
        );
        n += u32::from(r.is_some());
    }
    n
}
