//! Shading formulas, exactly as written into the images.
//!
//! All values are written as 8-bit without gamma: the shading value in [0, 1] is multiplied by
//! 255 and rounded to nearest (no sRGB transfer function is applied; the image is treated as
//! sRGB-encoded display values by the metrics, as the paper's images are). The background is
//! black (0, 0, 0) in every mode.
//!
//! - **lambert** (the paper's protocol): `value = clamp(AMBIENT·a + LIGHT_INTENSITY·max(0, n·l)·s, 0, 1)`
//!   with white albedo, `l = normalize(1, 1, 1)`, [`AMBIENT`] = 0.25, [`LIGHT_INTENSITY`] = 2/3,
//!   `n` the unit normal flipped to face the viewer (two-sided), `s` = 0 when a shadow ray finds
//!   an occluder and 1 otherwise (always 1 without shadows), `a` = the fraction of unoccluded
//!   ambient-occlusion rays (always 1 without occlusion). Written as grey `round(value · 255)`.
//! - **normal**: `round((n · 0.5 + 0.5) · 255)` per channel (x → R, y → G, z → B).
//! - **depth**: see [`depth_grey`].
//! - **mask**: 255 on hits.
//!
//! Secondary rays start at `p + ε·n` (hit point pushed off the surface along the viewer-facing
//! normal, ε from [`crate::Traceable::epsilon`]) and search `t ∈ [0, ∞)` toward the light for
//! shadows, `t ∈ [0, AO_DISTANCE]` for occlusion. A shadow ray is only cast when `n·l > 0`
//! (otherwise the direct term is zero anyway).

use glam::Vec3;
use sdfmo_io::SplitMix64;

/// Ambient term of the lambert shading.
pub const AMBIENT: f32 = 0.25;
/// Intensity of the directional light.
pub const LIGHT_INTENSITY: f32 = 2.0 / 3.0;
/// Maximum distance of ambient-occlusion rays, normalised units (the root cube has edge 2).
pub const AO_DISTANCE: f32 = 0.5;

/// Unit direction toward the light, normalize(1, 1, 1).
pub fn light_dir() -> Vec3 {
    Vec3::ONE.normalize()
}

/// Converts a value in [0, 1] (clamped; NaN → 0) to 8 bits, rounding to nearest.
#[inline]
pub fn to_u8(value: f32) -> u8 {
    // `as` saturates and maps NaN to 0.
    (value.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// The lambert grey value (see the module docs): `n` the unit viewer-facing normal, `shadow`
/// 1 when the light is visible (0 when occluded), `ambient_visibility` the unoccluded fraction
/// of the occlusion rays (1 without occlusion).
#[inline]
pub fn lambert_value(n: Vec3, shadow: f32, ambient_visibility: f32) -> u8 {
    let direct = LIGHT_INTENSITY * n.dot(light_dir()).max(0.0) * shadow;
    to_u8(AMBIENT * ambient_visibility + direct)
}

/// The normal-mode colour of a unit normal: n·0.5 + 0.5 per channel, as 8 bits.
#[inline]
pub fn normal_rgb(n: Vec3) -> [u8; 3] {
    let c = n * 0.5 + Vec3::splat(0.5);
    [to_u8(c.x), to_u8(c.y), to_u8(c.z)]
}

/// The depth-mode grey of a hit at ray distance `t`: with `near = max(0, |eye − c| − r)` and
/// `far = |eye − c| + r` for the bounding sphere (centre `c`, radius `r`) of the scene's
/// [`crate::Traceable::bounds`] (the root cube [-1, 1]³ for octrees and normalised meshes, so
/// both depth images of a model share one scale), `grey = round(255 · (far − t)/(far − near))`
/// clamped to [1, 255]: near is bright, far dark, and a hit is never 0 (the background).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthRange {
    /// Distance mapped to 255.
    pub near: f32,
    /// Distance mapped to the darkest grey.
    pub far: f32,
}

impl DepthRange {
    /// The range for a camera at `eye` and a scene with bounds `[min, max]`.
    pub fn new(eye: Vec3, min: Vec3, max: Vec3) -> DepthRange {
        let c = (min + max) * 0.5;
        let r = (max - min).length() * 0.5;
        let d = eye.distance(c);
        DepthRange {
            near: (d - r).max(0.0),
            far: d + r,
        }
    }
}

/// See [`DepthRange`].
#[inline]
pub fn depth_grey(t: f32, range: DepthRange) -> u8 {
    let span = range.far - range.near;
    let g = if span > 0.0 {
        (range.far - t) / span
    } else {
        1.0
    };
    to_u8(g).max(1)
}

/// A small deterministic per-pixel random generator (the project's SplitMix64), so occlusion
/// samples depend on the pixel and the sample index only, never on the thread or tile order.
#[derive(Clone, Debug)]
pub struct PixelRng(SplitMix64);

impl PixelRng {
    /// The generator of pixel (`px`, `py`).
    pub fn new(px: u32, py: u32) -> PixelRng {
        let mut r = SplitMix64::new((u64::from(py) << 32 | u64::from(px)) ^ 0x5DF0_C7EE_0000_0A0A);
        r.next_u64();
        PixelRng(r)
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// A uniform value in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        self.0.next_f32()
    }
}

/// Cosine-weighted direction on the hemisphere around unit `n` from two uniforms in [0, 1)
/// (Malley's method on the orthonormal basis of Duff et al. 2017).
#[inline]
pub fn cosine_hemisphere(n: Vec3, r1: f32, r2: f32) -> Vec3 {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    let phi = std::f32::consts::TAU * r1;
    let r = r2.sqrt();
    let z = (1.0 - r2).max(0.0).sqrt();
    (t * (r * phi.cos()) + bt * (r * phi.sin()) + n * z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambert_matches_the_documented_formula() {
        let l = light_dir();
        assert_eq!(lambert_value(l, 1.0, 1.0), 234); // (0.25 + 2/3)·255 = 233.75
        assert_eq!(lambert_value(-l, 1.0, 1.0), 64); // ambient only: 63.75
        assert_eq!(lambert_value(l, 0.0, 1.0), 64); // shadowed
        assert_eq!(lambert_value(l, 0.0, 0.0), 0); // shadowed and fully occluded
                                                   // facing +Z: n·l = 1/√3 → 0.25 + 0.3849 = 0.6349 → 161.9
        assert_eq!(lambert_value(Vec3::Z, 1.0, 1.0), 162);
    }

    #[test]
    fn normal_colours_and_depth_greys() {
        assert_eq!(normal_rgb(Vec3::Z), [128, 128, 255]);
        assert_eq!(normal_rgb(-Vec3::X), [0, 128, 128]);
        let range = DepthRange::new(Vec3::new(0.0, 0.0, 3.0), Vec3::splat(-1.0), Vec3::ONE);
        let r = 3f32.sqrt();
        assert!((range.near - (3.0 - r)).abs() < 1e-6 && (range.far - (3.0 + r)).abs() < 1e-6);
        assert_eq!(depth_grey(range.near, range), 255);
        assert_eq!(depth_grey(range.far, range), 1);
        assert_eq!(depth_grey(100.0, range), 1);
        assert!(depth_grey(2.5, range) > depth_grey(3.5, range));
        assert_eq!(to_u8(f32::NAN), 0);
    }

    #[test]
    fn cosine_samples_lie_in_the_hemisphere_with_cosine_mean() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::X,
        ] {
            let mut rng = PixelRng::new(3, 7);
            let mut mean_cos = 0.0f64;
            let k = 20_000;
            for _ in 0..k {
                let d = cosine_hemisphere(n, rng.next_f32(), rng.next_f32());
                assert!((d.length() - 1.0).abs() < 1e-4);
                let c = d.dot(n);
                assert!(c >= -1e-6, "{d} below the hemisphere of {n}");
                mean_cos += f64::from(c);
            }
            // E[cos θ] under the cosine density is 2/3.
            let m = mean_cos / f64::from(k);
            assert!((m - 2.0 / 3.0).abs() < 0.01, "mean cos {m} for {n}");
        }
    }

    #[test]
    fn pixel_rng_depends_on_the_pixel_only() {
        let a: Vec<u64> = (0..4).map(|_| PixelRng::new(5, 9).next_u64()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        assert_ne!(
            PixelRng::new(5, 9).next_u64(),
            PixelRng::new(9, 5).next_u64()
        );
        let mut r = PixelRng::new(0, 0);
        for _ in 0..1000 {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
        }
    }
}
