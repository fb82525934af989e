//! What a render computes: modes, settings, the inspectable [`RenderPlan`] and the [`Counters`]
//! that make the plan observable.

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use crate::RenderError;

/// Default tile edge in pixels (tiles are the unit of parallel work).
pub const DEFAULT_TILE_SIZE: u32 = 32;

/// What the image shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// White where a ray hits, black elsewhere. No normals.
    Mask,
    /// Grey-scale distance along the ray (see [`crate::shading::depth_grey`]); the f32 distances
    /// are kept in [`crate::Rendered::depth`]. No normals.
    Depth,
    /// The viewer-facing unit normal as colour, n·0.5 + 0.5; the f32 normals are kept in
    /// [`crate::Rendered::normals`].
    Normal,
    /// The paper protocol's shading (see [`crate::shading::lambert_value`]), optionally with shadows and
    /// ambient occlusion.
    #[default]
    Lambert,
}

impl Mode {
    /// All modes, in declaration order.
    pub const ALL: [Mode; 4] = [Mode::Mask, Mode::Depth, Mode::Normal, Mode::Lambert];

    /// The lower-case name (`mask`, `depth`, `normal`, `lambert`), as accepted by [`FromStr`].
    pub fn name(self) -> &'static str {
        match self {
            Mode::Mask => "mask",
            Mode::Depth => "depth",
            Mode::Normal => "normal",
            Mode::Lambert => "lambert",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Mode {
    type Err = RenderError;

    fn from_str(s: &str) -> Result<Mode, RenderError> {
        Mode::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                RenderError::InvalidSettings(format!(
                    "unknown render mode {s:?} (expected mask, depth, normal or lambert)"
                ))
            })
    }
}

/// Most ambient-occlusion rays per hit a plan accepts: beyond it a 1024² frame would take
/// minutes for no visible gain (the estimate's noise falls as 1/√n).
pub const MAX_AO_SAMPLES: u32 = 1024;

/// What the caller asks for. Shadows and ambient occlusion only apply to [`Mode::Lambert`].
///
/// `#[non_exhaustive]`: made by [`RenderSettings::new`] (or `default()`, lambert) and the
/// `with_*` setters, so that a setting added later breaks no caller. The renderer runs on the
/// caller's rayon pool (the global one unless the caller `install`s another): the image does not
/// depend on its size.
///
/// ```
/// use sdfmo_render::{Mode, RenderSettings};
/// let s = RenderSettings::new(Mode::Lambert).with_shadows(true).with_ao_samples(16);
/// assert!(s.shadows && s.ao_samples == 16);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct RenderSettings {
    /// Output mode.
    pub mode: Mode,
    /// Cast a shadow ray toward the light from every lit hit (lambert only).
    pub shadows: bool,
    /// Ambient-occlusion rays per hit, 0 = off (lambert only; at most [`MAX_AO_SAMPLES`]).
    pub ao_samples: u32,
}

impl RenderSettings {
    /// `mode` without shadows or occlusion.
    pub fn new(mode: Mode) -> RenderSettings {
        RenderSettings {
            mode,
            ..RenderSettings::default()
        }
    }

    /// The same settings in `mode`.
    pub fn with_mode(self, mode: Mode) -> RenderSettings {
        RenderSettings { mode, ..self }
    }

    /// The same settings with shadow rays on or off.
    pub fn with_shadows(self, shadows: bool) -> RenderSettings {
        RenderSettings { shadows, ..self }
    }

    /// The same settings with `ao_samples` ambient-occlusion rays per hit (0: off).
    pub fn with_ao_samples(self, ao_samples: u32) -> RenderSettings {
        RenderSettings { ao_samples, ..self }
    }
}

/// What a render will compute, decided from [`RenderSettings`] by [`RenderPlan::new`] (and
/// inspectable, or adjustable, before [`RenderRequest::plan`](crate::RenderRequest::plan)).
/// `#[non_exhaustive]`: made by [`RenderPlan::new`], its fields adjusted after.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[non_exhaustive]
pub struct RenderPlan {
    /// Output mode.
    pub mode: Mode,
    /// Whether the scene's normal is evaluated at hits (normal and lambert modes only).
    pub normals: bool,
    /// Whether a shadow ray is cast from hits facing the light (lambert with shadows only).
    pub shadow_rays: bool,
    /// Ambient-occlusion rays per hit (0 unless lambert with `ao_samples` > 0).
    pub ao_samples: u32,
    /// Keep the f32 ray distance of every pixel in [`crate::Rendered::depth`] (depth mode).
    pub keep_depth: bool,
    /// Keep the f32 normal of every pixel in [`crate::Rendered::normals`] (normal mode).
    /// Setting it in another mode also turns on `normals`.
    pub keep_normals: bool,
    /// Tile edge in pixels.
    pub tile_size: u32,
}

impl RenderPlan {
    /// Plans the minimum work for `settings`.
    ///
    /// # Errors
    /// [`RenderError::InvalidSettings`] for more than [`MAX_AO_SAMPLES`] occlusion rays.
    pub fn new(settings: &RenderSettings) -> Result<RenderPlan, RenderError> {
        let lambert = settings.mode == Mode::Lambert;
        let plan = RenderPlan {
            mode: settings.mode,
            normals: matches!(settings.mode, Mode::Normal | Mode::Lambert),
            shadow_rays: lambert && settings.shadows,
            ao_samples: if lambert { settings.ao_samples } else { 0 },
            keep_depth: settings.mode == Mode::Depth,
            keep_normals: settings.mode == Mode::Normal,
            tile_size: DEFAULT_TILE_SIZE,
        };
        plan.validate()?;
        Ok(plan)
    }

    /// The plan with tiles of `tile_size` × `tile_size` pixels (the image is the same for
    /// every size ≥ 1; [`RenderPlan::validate`] refuses 0).
    pub fn with_tile_size(self, tile_size: u32) -> RenderPlan {
        RenderPlan { tile_size, ..self }
    }

    /// Checks the plan: at most [`MAX_AO_SAMPLES`] occlusion rays, tile size ≥ 1, normals
    /// evaluated whenever lambert, normal mode, shadows, occlusion or kept normals need them.
    ///
    /// # Errors
    /// [`RenderError::InvalidSettings`] naming what is inconsistent.
    pub fn validate(&self) -> Result<(), RenderError> {
        if self.ao_samples > MAX_AO_SAMPLES {
            return Err(RenderError::InvalidSettings(format!(
                "{} ambient-occlusion rays per hit is more than the limit of {MAX_AO_SAMPLES}",
                self.ao_samples
            )));
        }
        if self.tile_size == 0 {
            return Err(RenderError::InvalidSettings(
                "tile size must be at least 1".into(),
            ));
        }
        let need_normals = matches!(self.mode, Mode::Normal | Mode::Lambert)
            || self.shadow_rays
            || self.ao_samples > 0
            || self.keep_normals;
        if need_normals && !self.normals {
            return Err(RenderError::InvalidSettings(format!(
                "plan for {} mode (shadows {}, {} occlusion rays, keep normals {}) needs normals",
                self.mode, self.shadow_rays, self.ao_samples, self.keep_normals
            )));
        }
        Ok(())
    }
}

/// Work done by one render: the sum of per-tile counts (no atomics in the hot loop).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    /// Primary rays cast (one per pixel).
    pub rays: u64,
    /// Evaluations of the scene's normal at a hit.
    pub normal_evals: u64,
    /// Shadow rays cast toward the light.
    pub shadow_rays: u64,
    /// Ambient-occlusion rays cast.
    pub ao_rays: u64,
    /// Primary rays that hit the scene (pixels that are not background).
    pub hits: u64,
}

impl std::ops::AddAssign for Counters {
    fn add_assign(&mut self, o: Counters) {
        self.rays += o.rays;
        self.normal_evals += o.normal_evals;
        self.shadow_rays += o.shadow_rays;
        self.ao_rays += o.ao_rays;
        self.hits += o.hits;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mask_and_depth_plan_no_normals_shadows_or_occlusion() {
        for mode in [Mode::Mask, Mode::Depth] {
            let s = RenderSettings::new(mode)
                .with_shadows(true)
                .with_ao_samples(16);
            let p = RenderPlan::new(&s).unwrap();
            assert!(!p.normals && !p.shadow_rays && p.ao_samples == 0 && !p.keep_normals);
            assert_eq!(p.keep_depth, mode == Mode::Depth);
        }
    }

    #[test]
    fn lambert_plans_only_what_is_asked() {
        let p = RenderPlan::new(&RenderSettings::new(Mode::Lambert)).unwrap();
        assert!(p.normals && !p.shadow_rays && p.ao_samples == 0 && !p.keep_depth);
        let p = RenderPlan::new(
            &RenderSettings::new(Mode::Lambert)
                .with_shadows(true)
                .with_ao_samples(3),
        )
        .unwrap();
        assert!(p.normals && p.shadow_rays && p.ao_samples == 3);
        let p = RenderPlan::new(&RenderSettings::new(Mode::Normal)).unwrap();
        assert!(p.normals && p.keep_normals && !p.shadow_rays);
    }

    #[test]
    fn too_many_occlusion_rays_and_inconsistent_plans_are_errors() {
        let ao = RenderSettings::new(Mode::Lambert).with_ao_samples(MAX_AO_SAMPLES + 1);
        assert!(RenderPlan::new(&ao).is_err());
        assert!(RenderPlan::new(&ao.with_ao_samples(MAX_AO_SAMPLES)).is_ok());
        let mut p = RenderPlan::new(&RenderSettings::new(Mode::Lambert)).unwrap();
        p.normals = false;
        assert!(p.validate().is_err());
        let mut p = RenderPlan::new(&RenderSettings::new(Mode::Mask)).unwrap();
        p.tile_size = 0;
        assert!(p.validate().is_err());
    }

    #[test]
    fn modes_parse_from_their_names() {
        for m in Mode::ALL {
            assert_eq!(m.name().parse::<Mode>().unwrap(), m);
            assert_eq!(m.to_string().to_uppercase().parse::<Mode>().unwrap(), m);
        }
        assert!("phong".parse::<Mode>().is_err());
    }
}
