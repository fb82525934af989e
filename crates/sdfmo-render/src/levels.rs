//! Which level of a `.smo` file a render draws: the one rule behind `sdfmo render --lod` and
//! `--pixel-error`, Python's `Octree.render(lod=…, pixel_error=…)` and the facade's
//! `Renderer`.

use glam::Vec3;
use sdfmo_format::{BrickOctree, SmoFile, SmoLevel};
use sdfmo_trace::{pixel_angle, LevelChoice};

use crate::{Camera, LodScene, OctreeScene, RenderError};

/// Which level of a `.smo` file ([`SmoFile`]: one octree, or levels of detail, perhaps a prefix
/// of the file) a render draws.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum LevelRequest {
    /// The finest level the data holds (a 1.x file's one level).
    #[default]
    Finest,
    /// This level, which the data must hold.
    Level(u8),
    /// Each ray at the coarsest level held whose voxels project to at most this many pixels at
    /// its hit distance ([`LevelChoice::PixelError`]); a file with levels only.
    PixelError(f32),
}

/// What a [`LevelRequest`] draws of a file for one camera: one level's octree, or the levels
/// held, chosen ray by ray. Render the scene of either arm (both are [`Traceable`](crate::Traceable)).
#[derive(Clone, Copy)]
pub enum LevelScene<'a> {
    /// One level.
    Level(OctreeScene<'a>),
    /// The octree of a 3.0 file, traced in place.
    Bricks(OctreeScene<'a, BrickOctree>),
    /// The levels held, each ray at the level its pixel error needs.
    PixelError(LodScene<'a>),
}

impl LevelRequest {
    /// The scene that draws `file` for `camera` (whose vertical field of view and height give
    /// the angle of a pixel).
    ///
    /// # Errors
    /// [`RenderError::LevelNotHeld`] naming the levels held; [`RenderError::NoLevels`] for a
    /// pixel error on a file without levels; [`RenderError::InvalidSettings`] for a pixel
    /// error that is not finite and > 0.
    pub fn scene<'a>(
        self,
        file: &'a SmoFile,
        camera: &Camera,
    ) -> Result<LevelScene<'a>, RenderError> {
        match self {
            LevelRequest::Finest => Ok(LevelScene::one(file.finest())),
            LevelRequest::Level(level) => match file.level(Some(level)) {
                Some(octree) => Ok(LevelScene::one(octree)),
                None => {
                    let (coarsest, finest) = file.level_range();
                    Err(RenderError::LevelNotHeld {
                        level,
                        coarsest,
                        finest,
                    })
                }
            },
            LevelRequest::PixelError(pixels) => {
                if !(pixels.is_finite() && pixels > 0.0) {
                    return Err(RenderError::InvalidSettings(format!(
                        "the pixel error must be finite and > 0, got {pixels}"
                    )));
                }
                match file {
                    SmoFile::Octree(_) | SmoFile::Bricks(_) => Err(RenderError::NoLevels {
                        depth: file.finest().depth(),
                    }),
                    SmoFile::Levels(lod) => Ok(LevelScene::PixelError(LodScene {
                        lod,
                        choice: LevelChoice::PixelError {
                            pixels,
                            pixel_angle: pixel_angle(camera.fov_y_deg, camera.height),
                        },
                    })),
                }
            }
        }
    }
}

impl<'a> LevelScene<'a> {
    /// The scene of one octree, in its layout.
    fn one(level: SmoLevel<'a>) -> LevelScene<'a> {
        match level {
            SmoLevel::Octree(o) => LevelScene::Level(OctreeScene(o)),
            SmoLevel::Bricks(b) => LevelScene::Bricks(OctreeScene(b)),
        }
    }

    /// The levels the rays from `eye` (a camera's, normalised frame) are drawn at, `(coarsest,
    /// finest)`: the one level, or by pixel error [`LodScene::levels`].
    pub fn levels(&self, eye: Vec3) -> (u8, u8) {
        match self {
            LevelScene::Level(s) => (s.0.depth(), s.0.depth()),
            LevelScene::Bricks(s) => (s.0.depth(), s.0.depth()),
            LevelScene::PixelError(s) => s.levels(eye),
        }
    }
}

/// "it holds levels 6..=8" (or "level 8 only"), for [`RenderError::LevelNotHeld`].
pub(crate) fn held_levels(coarsest: u8, finest: u8) -> String {
    if coarsest == finest {
        format!("it holds level {coarsest} only")
    } else {
        format!("it holds levels {coarsest}..={finest}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{render, Mode, RenderSettings};
    use sdfmo_format::testing::sphere_leaves;
    use sdfmo_format::{LodOctree, OctreeMeta, PackedOctree, ValueBits};

    fn sphere(depth: u8) -> PackedOctree {
        let meta = OctreeMeta::unit(depth, ValueBits::Eight);
        PackedOctree::from_leaves(meta, sphere_leaves(depth, 0.6)).unwrap()
    }

    /// Each request draws what it names (a level: that level's octree, the same image as
    /// rendering it alone), and refuses what the data cannot draw.
    #[test]
    fn requests_draw_the_level_they_name_or_say_what_is_held() {
        let lod = SmoFile::Levels(LodOctree::from_levels((2..=5).map(sphere).collect()).unwrap());
        let one = SmoFile::Octree(sphere(4));
        let cam = Camera::paper_view(0, 48, 32);
        let settings = RenderSettings::new(Mode::Depth);
        for (request, want) in [
            (LevelRequest::Finest, 5),
            (LevelRequest::Level(2), 2),
            (LevelRequest::Level(4), 4),
        ] {
            let scene = request.scene(&lod, &cam).unwrap();
            assert_eq!(scene.levels(cam.eye), (want, want));
            let LevelScene::Level(s) = scene else {
                panic!("{request:?}: not one level")
            };
            let alone = sphere(want);
            let a = render(&s, &cam, &settings).unwrap();
            let b = render(&OctreeScene(&alone), &cam, &settings).unwrap();
            assert_eq!((a.rgb, a.depth), (b.rgb, b.depth), "{request:?}");
        }
        // From radius 3 at 32 pixels high, one pixel covers about 0.05 units there: the
        // coarse levels do, level 5 (edge 0.0625) at most.
        let scene = LevelRequest::PixelError(1.0).scene(&lod, &cam).unwrap();
        let (coarse, fine) = scene.levels(cam.eye);
        assert!(
            2 <= coarse && coarse <= fine && fine <= 5,
            "{coarse}..={fine}"
        );
        assert!(matches!(scene, LevelScene::PixelError(_)));
        let Err(e) = LevelRequest::Level(6).scene(&lod, &cam) else {
            panic!("level 6 drawn")
        };
        assert!(matches!(
            e,
            RenderError::LevelNotHeld {
                level: 6,
                coarsest: 2,
                finest: 5
            }
        ));
        assert_eq!(
            e.to_string(),
            "level 6 is not in the data: it holds levels 2..=5"
        );
        let Err(e) = LevelRequest::Level(3).scene(&one, &cam) else {
            panic!("level 3 of a depth-4 file drawn")
        };
        assert!(e.to_string().ends_with("it holds level 4 only"), "{e}");
        assert!(matches!(
            LevelRequest::PixelError(1.0).scene(&one, &cam),
            Err(RenderError::NoLevels { depth: 4 })
        ));
        for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                LevelRequest::PixelError(bad).scene(&lod, &cam),
                Err(RenderError::InvalidSettings(_))
            ));
        }
        assert_eq!(
            LevelRequest::Finest
                .scene(&one, &cam)
                .unwrap()
                .levels(cam.eye),
            (4, 4)
        );
    }

    /// Primary rays are culled by the box of the levels the eye's distances choose: from far,
    /// one level's (here each level a sphere of another radius, so the boxes differ), and the
    /// render's depths are still every pixel's ray traced alone without any box.
    #[test]
    fn primary_rays_are_culled_by_the_box_of_the_levels_they_reach() {
        use crate::Traceable;
        let ball = |depth: u8| {
            let meta = OctreeMeta::unit(depth, ValueBits::Eight);
            let radius = 0.3 + 0.15 * f32::from(depth - 2);
            PackedOctree::from_leaves(meta, sphere_leaves(depth, radius)).unwrap()
        };
        let lod = LodOctree::from_levels((2..=5).map(ball).collect()).unwrap();
        let file = SmoFile::Levels(lod.clone());
        let settings = RenderSettings::new(Mode::Depth);
        let mut one_level = 0;
        for radius in [1.5f32, 3.0, 6.0, 12.0] {
            let cam = Camera::new(Vec3::new(0.3, 0.2, radius), Vec3::ZERO, 40.0, 48, 32);
            let LevelScene::PixelError(scene) =
                LevelRequest::PixelError(1.0).scene(&file, &cam).unwrap()
            else {
                panic!("not by pixel error")
            };
            let (coarsest, finest) = scene.levels(cam.eye);
            let (lo, hi) = scene.primary_bounds(cam.eye).unwrap();
            if coarsest == finest {
                let alone = OctreeScene(lod.level(coarsest).unwrap()).occupied_bounds();
                assert_eq!(Some((lo, hi)), alone, "radius {radius}");
                if coarsest < lod.depth() {
                    // Smaller than the finest level's sphere, which the union holds.
                    one_level += 1;
                    assert_ne!(scene.occupied_bounds(), alone, "radius {radius}");
                }
            }
            let image = render(&scene, &cam, &settings).unwrap();
            let depth = image.depth.unwrap();
            for py in 0..cam.height {
                for px in 0..cam.width {
                    let (o, d) = cam.primary_ray(px, py);
                    let t = scene.first_hit(o, d, 0.0, f32::INFINITY).map(|h| h.hit.t);
                    let at = depth[(py * cam.width + px) as usize];
                    assert_eq!(
                        t.unwrap_or(f32::INFINITY),
                        at,
                        "radius {radius} ({px},{py})"
                    );
                    if let Some(t) = t {
                        let p = o + d * t;
                        assert!(p.cmpge(lo - 1e-3).all() && p.cmple(hi + 1e-3).all());
                    }
                }
            }
        }
        assert!(one_level >= 1, "{one_level} eyes drew one coarse level");
    }
}
