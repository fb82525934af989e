//! The render arguments shared by `Mesh.render` and `Octree.render`: the command-line tool's
//! camera, modes and limits.

use glam::Vec3;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use sdf_multioctree::mesh::Normalization;
use sdf_multioctree::render::{
    Camera, Mode, RenderError, RenderSettings, Rendered, MAX_AO_SAMPLES,
};

use crate::arrays;
use crate::run;

/// The keyword-only options of `Mesh.render` and `Octree.render` as the call gave them (the
/// PyO3 signatures of both declare their names and defaults), checked by [`RenderArgs::parse`].
pub struct RenderOptions<'a> {
    /// `mode=`: "lambert", "mask", "depth" or "normal".
    pub mode: &'a str,
    /// `view=`: one of the paper's four cameras.
    pub view: i64,
    /// `eye=`: 3 numbers, in the frame `frame` names.
    pub eye: Option<Vec<f32>>,
    /// `target=`: 3 numbers, in the frame `frame` names.
    pub target: Option<Vec<f32>>,
    /// `fov=`: vertical field of view in degrees.
    pub fov: Option<f32>,
    /// `frame=`: "model" or "normalized".
    pub frame: &'a str,
    /// `shadows=`.
    pub shadows: bool,
    /// `ao=`: ambient-occlusion rays per pixel.
    pub ao: i64,
    /// `threads=`.
    pub threads: Option<i64>,
}

/// Bytes a render may hold per pixel at its peak: RGB (3), depth (4) or normals (12) when the
/// mode keeps them, and as much again for the tiles being rendered.
const RENDER_BYTES_PER_PIXEL: u64 = 2 * (3 + 12);

/// An optional point keyword (`eye`, `target`): 3 numbers (finiteness is the camera's check),
/// the error naming the keyword and the length it got (a 2-element `eye` used to be a bare
/// "expected 3 items").
fn point_option(v: Option<Vec<f32>>, name: &'static str) -> PyResult<Option<[f32; 3]>> {
    match v {
        None => Ok(None),
        Some(v) => <[f32; 3]>::try_from(v.as_slice()).map(Some).map_err(|_| {
            PyValueError::new_err(format!(
                "{name} must be 3 numbers (x, y, z), got {} of them",
                v.len()
            ))
        }),
    }
}

/// A checked render request.
pub struct RenderArgs {
    camera: Camera,
    settings: RenderSettings,
    threads: Option<usize>,
}

impl RenderArgs {
    /// Checks the arguments of a `render` call (see `Octree.render`); `model_frame` is the
    /// source's normalisation, through which `eye` and `target` in model units are mapped.
    pub fn parse(
        width: i64,
        height: Option<i64>,
        o: RenderOptions<'_>,
        model_frame: &Normalization,
    ) -> PyResult<RenderArgs> {
        let (mode, view, fov, frame, shadows, ao) =
            (o.mode, o.view, o.fov, o.frame, o.shadows, o.ao);
        let eye = point_option(o.eye, "eye")?;
        let target = point_option(o.target, "target")?;
        let height = height.unwrap_or(width);
        for (name, v) in [("width", width), ("height", height)] {
            if v < 1 {
                return Err(PyValueError::new_err(format!(
                    "{name} must be at least 1, got {v}"
                )));
            }
        }
        // Both ≥ 1 here: the renderer's one image-size limit (as the CLI's `--size`).
        sdf_multioctree::render::check_image_size(width as u64, height as u64)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let mode = match mode {
            "lambert" => Mode::Lambert,
            "mask" => Mode::Mask,
            "depth" => Mode::Depth,
            "normal" => Mode::Normal,
            other => {
                return Err(PyValueError::new_err(format!(
                    "mode must be \"lambert\", \"mask\", \"depth\" or \"normal\", got {other:?}"
                )))
            }
        };
        if !(0..=3).contains(&view) {
            return Err(PyValueError::new_err(format!(
                "view must be 0, 1, 2 or 3 (the paper's four cameras), got {view}"
            )));
        }
        if mode != Mode::Lambert && (shadows || ao != 0) {
            return Err(PyValueError::new_err(
                "shadows and ao apply to mode=\"lambert\" only (the other modes cast no light rays)",
            ));
        }
        if !(0..=i64::from(MAX_AO_SAMPLES)).contains(&ao) {
            return Err(PyValueError::new_err(format!(
                "ao must be in 0..={MAX_AO_SAMPLES} rays per pixel, got {ao}"
            )));
        }
        let threads = run::check_threads(o.threads)?;
        let normalized = match frame {
            "model" => false,
            "normalized" => true,
            other => {
                return Err(PyValueError::new_err(format!(
                "frame must be \"model\" (eye and target in the mesh's units) or \"normalized\" \
                     (in the root cube [-1, 1]^3), got {other:?}"
            )))
            }
        };
        // The command line's conversion (`sdfmo render --eye`): one eye, one image.
        let place = |p: [f32; 3]| {
            if normalized {
                Vec3::from_array(p)
            } else {
                model_frame.point_to_normalized(Vec3::from_array(p).as_dvec3())
            }
        };
        let mut camera = Camera::paper_view(view as u32, width as u32, height as u32);
        if let Some(e) = eye {
            camera.eye = place(e);
        }
        if let Some(t) = target {
            camera.target = place(t);
        }
        if let Some(f) = fov {
            if !(f > 0.0 && f < 180.0) {
                return Err(PyValueError::new_err(format!(
                    "fov must be in (0, 180) degrees, got {f}"
                )));
            }
            camera.fov_y_deg = f;
        }
        // An eye on the target, named as the caller gave it (the renderer's message would name
        // the normalised point: eye=(0, 0, 0) in model units read "[-0.95, -0.95, -0.95]").
        // The defaults differ, so at least one of the two was given.
        if camera.eye == camera.target {
            let [x, y, z] = eye.or(target).unwrap_or(camera.eye.to_array());
            return Err(PyValueError::new_err(format!(
                "invalid camera: eye and target are the same point ({x}, {y}, {z}) \
                 (frame=\"{frame}\")"
            )));
        }
        // Non-finite or degenerate cameras: the renderer's own message.
        camera
            .frame()
            .map_err(|e| crate::errors::render_error(&e))?;
        Ok(RenderArgs {
            camera,
            // The renderer runs on the caller's pool: `threads` is ours (`run::run`).
            settings: RenderSettings::new(mode)
                .with_shadows(shadows)
                .with_ao_samples(ao as u32),
            threads,
        })
    }

    /// The thread count asked for (`threads=`), `None` for all cores.
    pub fn threads(&self) -> Option<usize> {
        self.threads
    }

    /// Renders with `f` (given the settings, the camera and the cancellation test to pass to
    /// `sdfmo_render::RenderRequest::cancel`) without the GIL and returns the image as uint8
    /// `(h, w, 3)`. Ctrl-C stops the render within about a tile's time
    /// (`KeyboardInterrupt`).
    pub fn render<'py>(
        &self,
        py: Python<'py>,
        f: impl FnOnce(
                &RenderSettings,
                &Camera,
                &(dyn Fn() -> bool + Sync),
            ) -> PyResult<Result<Rendered, RenderError>>
            + Send,
    ) -> PyResult<Bound<'py, PyAny>> {
        let pixels = (self.camera.width as usize) * (self.camera.height as usize);
        // The image, its depth or normals when the mode keeps them, and the tiles in flight:
        // allocatable now, or a MemoryError instead of an abort in the renderer.
        run::ensure_headroom(
            pixels as u64 * RENDER_BYTES_PER_PIXEL,
            &format!(
                "a render of height {} and width {}",
                self.camera.height, self.camera.width
            ),
        )?;
        let r = run::run(py, self.threads, pixels, |cancel| {
            match f(&self.settings, &self.camera, &|| cancel.is_set()) {
                Ok(Err(RenderError::Cancelled)) => Err(run::Cancelled),
                Ok(Err(e)) => Ok(Err(crate::errors::render_error(&e))),
                Ok(Ok(r)) => Ok(Ok(r)),
                Err(e) => Ok(Err(e)),
            }
        })??;
        Ok(arrays::image_array(py, r.rgb, r.width, r.height)?.into_any())
    }
}
