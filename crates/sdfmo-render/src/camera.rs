//! The pinhole camera (the repository's `docs/architecture.md`, Conventions) and the paper's four
//! views.
//!
//! Pixel `(px, py)`, `py` counted from the top, is sampled at its centre:
//!
//! ```text
//! u = (2(px + 0.5)/W − 1) · tan(fov/2) · W/H
//! v = (1 − 2(py + 0.5)/H) · tan(fov/2)
//! dir = normalize(fwd + u·right + v·up')
//! fwd = normalize(target − eye), right = normalize(fwd × up), up' = right × fwd
//! ```
//!
//! `fov` is the vertical field of view. When `fwd` is (anti)parallel to the `up` hint, +Z is used
//! as the hint instead (+Y if the hint was already ±Z). The frame is computed in f64 and each ray
//! direction rounded to f32 once, so an independent implementation of the same formula (the
//! Embree peer in `benches/peers/embree_primary.py`) casts the same rays.

use glam::{DVec3, Vec3};

use crate::RenderError;

/// Largest accepted image side, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 32_768;
/// Largest accepted pixel count (so a hostile size cannot ask for a huge allocation).
pub const MAX_PIXELS: u64 = 1 << 28;

/// Checks an image size against the one limit of every front-end (the CLI's `--size`, Python's
/// `render`, the facade, the GPU): at least 1 × 1, at most [`MAX_IMAGE_SIDE`] per side and
/// [`MAX_PIXELS`] in all. Takes `u64` so that a front-end can check what its user typed before
/// narrowing it.
///
/// # Errors
/// [`RenderError::InvalidCamera`] naming the size and the limit.
pub fn check_image_size(width: u64, height: u64) -> Result<(), RenderError> {
    if width == 0 || height == 0 {
        return Err(RenderError::InvalidCamera(format!(
            "image size {width}x{height} is empty"
        )));
    }
    if width > u64::from(MAX_IMAGE_SIDE)
        || height > u64::from(MAX_IMAGE_SIDE)
        || width * height > MAX_PIXELS
    {
        return Err(RenderError::InvalidCamera(format!(
            "image size {width}x{height} is too large (at most {MAX_IMAGE_SIDE} per side and {MAX_PIXELS} pixels)"
        )));
    }
    Ok(())
}

/// A pinhole camera (see the module docs): eye, target, up hint, vertical field of view, image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (normalised frame).
    pub eye: Vec3,
    /// The point the camera looks at.
    pub target: Vec3,
    /// Up hint, +Y by convention (need not be unit or orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y_deg: f32,
    /// Image width in pixels (≥ 1).
    pub width: u32,
    /// Image height in pixels (≥ 1).
    pub height: u32,
}

impl Default for Camera {
    /// Paper view 0 at 1024 × 1024.
    fn default() -> Self {
        Camera::paper_view(0, 1024, 1024)
    }
}

impl Camera {
    /// A camera with the conventional +Y up hint.
    pub fn new(eye: Vec3, target: Vec3, fov_y_deg: f32, width: u32, height: u32) -> Camera {
        Camera {
            eye,
            target,
            up: Vec3::Y,
            fov_y_deg,
            width,
            height,
        }
    }

    /// Paper view `k` (taken modulo 4): eye = 3·(sin θ, 0, cos θ) with θ = 2πk/4, looking at the
    /// origin, +Y up, fov 60°.
    pub fn paper_view(k: u32, width: u32, height: u32) -> Camera {
        let theta = std::f64::consts::TAU * f64::from(k % 4) / 4.0;
        let eye = DVec3::new(3.0 * theta.sin(), 0.0, 3.0 * theta.cos()).as_vec3();
        Camera::new(eye, Vec3::ZERO, 60.0, width, height)
    }

    /// The paper's four views (eye 3·(sin θ, 0, cos θ), θ = 2πk/4, fov 60°), in order k = 0, 1, 2, 3.
    pub fn paper_views(width: u32, height: u32) -> Vec<Camera> {
        (0..4)
            .map(|k| Camera::paper_view(k, width, height))
            .collect()
    }

    /// Checks the camera and computes its frame: finite values, a size of at least 1 × 1 and at
    /// most [`MAX_IMAGE_SIDE`] per side and [`MAX_PIXELS`] in total, a field of view in (0, 180),
    /// an eye distinct from the target, a non-zero up hint.
    pub fn frame(&self) -> Result<CameraFrame, RenderError> {
        let bad = |what: String| Err(RenderError::InvalidCamera(what));
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return bad(format!(
                "eye {}, target {} and up {} must be finite",
                self.eye, self.target, self.up
            ));
        }
        check_image_size(u64::from(self.width), u64::from(self.height))?;
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 180.0) {
            return bad(format!(
                "vertical field of view {}° must lie in (0, 180)",
                self.fov_y_deg
            ));
        }
        if self.eye == self.target {
            return bad(format!("eye and target are the same point {}", self.eye));
        }
        if self.up == Vec3::ZERO {
            return bad("up hint is the zero vector".to_string());
        }
        Ok(self.frame_unchecked())
    }

    /// The frame without validation (non-finite components for a degenerate camera).
    fn frame_unchecked(&self) -> CameraFrame {
        let eye = self.eye.as_dvec3();
        let fwd = (self.target.as_dvec3() - eye).normalize();
        let mut up = self.up.as_dvec3().normalize();
        if is_parallel(fwd, up) {
            up = if is_parallel(fwd, DVec3::Z) {
                DVec3::Y
            } else {
                DVec3::Z
            };
        }
        let right = fwd.cross(up).normalize();
        let up = right.cross(fwd);
        let tan_half = (f64::from(self.fov_y_deg).to_radians() * 0.5).tan();
        CameraFrame {
            eye,
            fwd,
            right,
            up,
            tan_half,
            width: self.width,
            height: self.height,
        }
    }

    /// The primary ray through the centre of pixel (`px`, `py`), `py` from the top: (origin,
    /// unit direction). Pixels outside the image extrapolate the same formula. For a camera that
    /// [`Camera::frame`] rejects the direction is not finite (never a panic).
    pub fn primary_ray(&self, px: u32, py: u32) -> (Vec3, Vec3) {
        self.frame_unchecked().ray(px, py)
    }
}

/// |a × b| below this (unit vectors) counts as parallel for the up-hint rule.
const PARALLEL_EPS: f64 = 1e-9;

fn is_parallel(a: DVec3, b: DVec3) -> bool {
    a.cross(b).length() < PARALLEL_EPS
}

/// A validated camera's orthonormal frame, from [`Camera::frame`]; cheap to cast rays from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFrame {
    /// Eye position.
    pub eye: DVec3,
    /// Unit view direction.
    pub fwd: DVec3,
    /// Unit right vector, normalize(fwd × up hint).
    pub right: DVec3,
    /// Unit up vector, right × fwd.
    pub up: DVec3,
    /// tan(fov_y / 2).
    pub tan_half: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl CameraFrame {
    /// The primary ray through the centre of pixel (`px`, `py`): (origin, unit direction),
    /// `normalize(column(px) + row(py))` rounded to f32.
    #[inline]
    pub fn ray(&self, px: u32, py: u32) -> (Vec3, Vec3) {
        (
            self.eye.as_vec3(),
            Self::direction(self.column(px), self.row(py)),
        )
    }

    /// `fwd + u·right` for pixel column `px` (the renderer caches it per tile).
    #[inline]
    pub fn column(&self, px: u32) -> DVec3 {
        let w = f64::from(self.width);
        let h = f64::from(self.height);
        let u = (2.0 * (f64::from(px) + 0.5) / w - 1.0) * self.tan_half * w / h;
        self.fwd + u * self.right
    }

    /// `v·up'` for pixel row `py` (the renderer caches it per tile).
    #[inline]
    pub fn row(&self, py: u32) -> DVec3 {
        let h = f64::from(self.height);
        let v = (1.0 - 2.0 * (f64::from(py) + 0.5) / h) * self.tan_half;
        v * self.up
    }

    /// Whether no primary ray of the `tw` × `th` pixels from (`x0`, `y0`) can meet the box
    /// `[lo, hi]`: the box lies outside one of the four planes through the eye that bound the
    /// tile's rays (taken a pixel and a half beyond the outermost pixel centres, so rounding
    /// cannot matter), or wholly behind the eye (every ray moves along `fwd`; the four planes
    /// alone keep a box behind the eye that their mirror image meets). Conservative: a tile that
    /// is kept may still miss. The CPU renderer skips such tiles of its occupied box, the GPU
    /// renderer does not dispatch them.
    pub fn tile_misses_box(&self, x0: u32, y0: u32, tw: u32, th: u32, lo: Vec3, hi: Vec3) -> bool {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let dir = |x: f64, y: f64| {
            let u = (2.0 * x / w - 1.0) * self.tan_half * w / h;
            let v = (1.0 - 2.0 * y / h) * self.tan_half;
            self.fwd + u * self.right + v * self.up
        };
        let (xa, xb) = (f64::from(x0) - 1.0, f64::from(x0 + tw) + 1.0);
        let (ya, yb) = (f64::from(y0) - 1.0, f64::from(y0 + th) + 1.0);
        let corners = [dir(xa, ya), dir(xb, ya), dir(xb, yb), dir(xa, yb)];
        let centre = corners[0] + corners[1] + corners[2] + corners[3];
        let (lo, hi) = (lo.as_dvec3() - self.eye, hi.as_dvec3() - self.eye);
        let box_corner = |k: u32| {
            DVec3::new(
                if k & 4 != 0 { hi.x } else { lo.x },
                if k & 2 != 0 { hi.y } else { lo.y },
                if k & 1 != 0 { hi.z } else { lo.z },
            )
        };
        let behind = (0..8).all(|k| box_corner(k).dot(self.fwd) < 0.0);
        behind
            || (0..4).any(|i| {
                let normal = corners[i].cross(corners[(i + 1) % 4]);
                let side = normal.dot(centre);
                side != 0.0 && (0..8).all(|k| normal.dot(box_corner(k)) * side < 0.0)
            })
    }

    /// The unit direction from a cached [`column`](Self::column) and [`row`](Self::row).
    #[inline]
    pub fn direction(column: DVec3, row: DVec3) -> Vec3 {
        (column + row).normalize().as_vec3()
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::Camera;

    /// Tiles of `edge` pixels over the frame: (x0, y0, tw, th).
    fn tiles(width: u32, height: u32, edge: u32) -> Vec<(u32, u32, u32, u32)> {
        (0..height)
            .step_by(edge as usize)
            .flat_map(|y0| {
                (0..width)
                    .step_by(edge as usize)
                    .map(move |x0| (x0, y0, edge.min(width - x0), edge.min(height - y0)))
            })
            .collect()
    }

    #[test]
    fn culled_tiles_hold_no_ray_that_meets_the_box() {
        let boxes = [
            (Vec3::new(-0.9, -0.19, -0.47), Vec3::new(0.9, 0.19, 0.47)),
            (Vec3::new(0.2, 0.3, -0.1), Vec3::new(0.25, 0.9, 0.05)),
            // Around the eye of the first camera, and just behind it.
            (Vec3::new(-0.2, -0.2, 2.9), Vec3::new(0.2, 0.2, 3.1)),
            (Vec3::new(-0.5, -0.5, 3.01), Vec3::new(0.5, 0.5, 4.0)),
        ];
        let cameras = [
            Camera::new(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 60.0, 61, 47),
            Camera::new(Vec3::new(0.3, 1.9, -2.2), Vec3::ZERO, 75.0, 53, 64),
            Camera::new(
                Vec3::new(0.0, 0.0, 3.0),
                Vec3::new(0.0, 0.0, 6.0),
                60.0,
                40,
                40,
            ),
        ];
        let (mut culled, mut kept) = (0, 0);
        for camera in &cameras {
            let frame = camera.frame().unwrap();
            for &(lo, hi) in &boxes {
                for (x0, y0, tw, th) in tiles(frame.width, frame.height, 5) {
                    if !frame.tile_misses_box(x0, y0, tw, th, lo, hi) {
                        kept += 1;
                        continue;
                    }
                    culled += 1;
                    for py in y0..y0 + th {
                        for px in x0..x0 + tw {
                            let (origin, dir) = frame.ray(px, py);
                            let ray = sdfmo_trace::Ray { origin, dir };
                            let meets = sdfmo_trace::ray_meets_box(&ray, lo, hi, 0.0, f32::MAX);
                            assert!(!meets, "{camera:?} {lo} {hi}: ({px},{py})");
                        }
                    }
                }
            }
        }
        assert!(culled > 300 && kept > 300, "{culled} culled, {kept} kept");
    }

    /// Issue 35: a box wholly behind the eye was kept for the tiles whose four bounding planes
    /// its mirror image through the eye meets (the centre of the frame, here the root cube
    /// behind a camera at (0, 0, 3) looking towards +z), so the GPU traced an empty frame.
    #[test]
    fn a_box_behind_the_eye_culls_every_tile() {
        let camera = Camera::new(
            Vec3::new(0.0, 0.0, 3.0),
            Vec3::new(0.0, 0.0, 6.0),
            60.0,
            64,
            64,
        );
        let frame = camera.frame().unwrap();
        for (x0, y0, tw, th) in tiles(64, 64, 8) {
            assert!(frame.tile_misses_box(x0, y0, tw, th, Vec3::splat(-1.0), Vec3::ONE));
        }
        // Straddling the eye's plane: kept where its rays can reach it.
        let near = (Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, 1.0, 3.5));
        assert!(!frame.tile_misses_box(28, 28, 8, 8, near.0, near.1));
    }

    #[test]
    fn one_image_size_limit() {
        for (w, h) in [(1, 1), (16_384, 16_384), (32_768, 8_192), (8_192, 32_768)] {
            assert!(check_image_size(w, h).is_ok(), "{w}x{h}");
        }
        for (w, h) in [
            (0, 5),
            (5, 0),
            (32_769, 1),
            (16_384, 16_385),
            (u64::MAX, u64::MAX),
        ] {
            let e = check_image_size(w, h).unwrap_err().to_string();
            assert!(e.contains(&format!("image size {w}x{h}")), "{e}");
        }
    }

    use super::*;

    fn close(a: Vec3, b: Vec3, eps: f32) -> bool {
        (a - b).abs().max_element() <= eps
    }

    #[test]
    fn centre_pixel_of_odd_image_looks_at_target() {
        let cam = Camera::new(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-1.0, 0.5, 0.0),
            45.0,
            5,
            3,
        );
        let (o, d) = cam.primary_ray(2, 1);
        assert_eq!(o, cam.eye);
        let fwd = (cam.target - cam.eye).normalize();
        assert!(close(d, fwd, 1e-6), "{d} vs {fwd}");
    }

    #[test]
    fn corner_pixels_follow_the_formula() {
        // Paper view 0: eye (0,0,3) looking down −Z, right = +X, up = +Y.
        let cam = Camera::paper_view(0, 4, 2);
        let t = (30f64).to_radians().tan();
        let expect = |px: f64, py: f64| {
            let u = (2.0 * (px + 0.5) / 4.0 - 1.0) * t * 2.0;
            let v = (1.0 - 2.0 * (py + 0.5) / 2.0) * t;
            DVec3::new(u, v, -1.0).normalize().as_vec3()
        };
        for (px, py) in [(0, 0), (3, 0), (0, 1), (3, 1), (1, 0)] {
            let (_, d) = cam.primary_ray(px, py);
            let e = expect(f64::from(px), f64::from(py));
            assert!(close(d, e, 1e-7), "pixel ({px},{py}): {d} vs {e}");
        }
        // top-left looks up and left, bottom-right down and right
        let (_, tl) = cam.primary_ray(0, 0);
        let (_, br) = cam.primary_ray(3, 1);
        assert!(tl.x < 0.0 && tl.y > 0.0 && br.x > 0.0 && br.y < 0.0);
    }

    #[test]
    fn vertical_field_of_view_spans_the_image_height() {
        // The centre of the top row lies at half-angle fov/2 minus half a pixel.
        let cam = Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 90.0, 1, 1000);
        let (_, d) = cam.primary_ray(0, 0);
        let angle = d.y.atan2(-d.z).to_degrees();
        let expect = (0.999f64).atan().to_degrees() as f32; // v = 1 − 1/1000
        assert!((angle - expect).abs() < 1e-4, "{angle} vs {expect}");
    }

    #[test]
    fn up_hint_switches_to_z_when_looking_along_y() {
        for (eye, sign) in [
            (Vec3::new(0.0, 3.0, 0.0), 1.0f32),
            (Vec3::new(0.0, -3.0, 0.0), -1.0),
        ] {
            let cam = Camera::new(eye, Vec3::ZERO, 60.0, 3, 3);
            let f = cam.frame().unwrap();
            assert!(f.right.is_finite() && f.up.is_finite());
            // up' = right × fwd with hint +Z: its z component is positive, its y zero.
            assert!(f.up.z > 0.99 && f.up.y.abs() < 1e-12, "{:?}", f.up);
            assert!((f.fwd.y as f32 - (-sign)).abs() < 1e-12);
            // top pixel ray leans toward +Z
            let (_, d) = cam.primary_ray(1, 0);
            assert!(d.z > 0.0 && d.is_finite());
        }
        // eye above the target: fwd = −Y, right = normalize(−Y × Z) = −X
        let f = Camera::new(Vec3::new(0.0, 3.0, 0.0), Vec3::ZERO, 60.0, 3, 3)
            .frame()
            .unwrap();
        assert!((f.right - DVec3::new(-1.0, 0.0, 0.0)).length() < 1e-12);
    }

    #[test]
    fn frame_is_orthonormal() {
        let cam = Camera::new(
            Vec3::new(0.3, -2.0, 1.7),
            Vec3::new(0.1, 0.2, -0.3),
            35.0,
            7,
            9,
        );
        let f = cam.frame().unwrap();
        for v in [f.fwd, f.right, f.up] {
            assert!((v.length() - 1.0).abs() < 1e-12);
        }
        assert!(f.fwd.dot(f.right).abs() < 1e-12);
        assert!(f.fwd.dot(f.up).abs() < 1e-12);
        assert!(f.right.dot(f.up).abs() < 1e-12);
        assert!(f.up.dot(DVec3::Y) > 0.0, "up' keeps the hint's side");
    }

    #[test]
    fn paper_views_sit_on_the_circle_and_look_at_the_origin() {
        let views = Camera::paper_views(1024, 1024);
        assert_eq!(views.len(), 4);
        let eyes = [
            Vec3::new(0.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -3.0),
            Vec3::new(-3.0, 0.0, 0.0),
        ];
        for (cam, eye) in views.iter().zip(eyes) {
            assert!(close(cam.eye, eye, 1e-6), "{} vs {eye}", cam.eye);
            assert_eq!(cam.target, Vec3::ZERO);
            assert_eq!(cam.up, Vec3::Y);
            assert_eq!(cam.fov_y_deg, 60.0);
            assert_eq!((cam.width, cam.height), (1024, 1024));
            // the four pixels around the image centre straddle the view axis symmetrically
            let (_, a) = cam.primary_ray(511, 511);
            let (_, b) = cam.primary_ray(512, 512);
            assert!(close((a + b).normalize(), -eye / 3.0, 1e-6));
        }
    }

    #[test]
    fn invalid_cameras_are_errors() {
        let ok = Camera::paper_view(0, 8, 8);
        assert!(ok.frame().is_ok());
        let cases = [
            Camera { width: 0, ..ok },
            Camera { height: 0, ..ok },
            Camera {
                width: MAX_IMAGE_SIDE + 1,
                ..ok
            },
            Camera {
                fov_y_deg: 0.0,
                ..ok
            },
            Camera {
                fov_y_deg: 180.0,
                ..ok
            },
            Camera {
                fov_y_deg: f32::NAN,
                ..ok
            },
            Camera {
                target: ok.eye,
                ..ok
            },
            Camera {
                up: Vec3::ZERO,
                ..ok
            },
            Camera {
                eye: Vec3::new(f32::INFINITY, 0.0, 0.0),
                ..ok
            },
        ];
        for cam in cases {
            assert!(
                matches!(cam.frame(), Err(RenderError::InvalidCamera(_))),
                "{cam:?}"
            );
            let _ = cam.primary_ray(0, 0); // never panics
        }
    }
}
