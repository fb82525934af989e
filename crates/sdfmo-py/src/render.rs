//! The render arguments shared by `Mesh.render` and `Octree.render`: the command-line tool's
//! camera, modes and limits.

use glam::Vec3;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sdf_multioctree::mesh::Normalization;
use sdf_multioctree::render::{
    Camera, Mode, RenderError, RenderSettings, Rendered, MAX_AO_SAMPLES,
};

use crate::arrays;
use crate::kwargs::Kwargs;
use crate::run;

/// The keyword-only options of `render`, with their Python defaults.
pub struct RenderOptions {
    mode: String,
    view: i64,
    eye: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    fov: Option<f32>,
    frame: String,
    shadows: bool,
    ao: i64,
    threads: Option<i64>,
}

impl RenderOptions {
    /// Reads the options from the call's keywords (`function` names the call in errors).
    ///
    /// # Errors
    /// `TypeError` for an unknown keyword or a value of the wrong type.
    pub fn from_kwargs(
        function: &'static str,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<RenderOptions> {
        let mut k = Kwargs::new(function, kwargs);
        let options = RenderOptions {
            mode: k.take("mode", "lambert".to_owned())?,
            view: k.take("view", 0)?,
            eye: point_option(&mut k, "eye")?,
            target: point_option(&mut k, "target")?,
            fov: k.take("fov", None)?,
            frame: k.take("frame", "model".to_owned())?,
            shadows: k.take("shadows", false)?,
            ao: k.take("ao", 0)?,
            threads: k.take("threads", None)?,
        };
        k.finish()?;
        Ok(options)
    }
}

/// Bytes a render may hold per pixel at its peak: RGB (3), depth (4) or normals (12) when the
/// mode keeps them, and as much again for the tiles being rendered.
const RENDER_BYTES_PER_PIXEL: u64 = 2 * (3 + 12);

/// An optional point keyword (`eye`, `target`): 3 numbers (finiteness is the camera's check),
/// the error naming the keyword and the length it got (a 2-element `eye` used to be a bare
/// "expected 3 items").
fn point_option(k: &mut Kwargs<'_>, name: &'static str) -> PyResult<Option<[f32; 3]>> {
    let v: Option<Vec<f32>> = k.take(name, None)?;
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

/// Largest image edge (the command-line tool's `--size` limit).
const MAX_IMAGE_EDGE: i64 = 16384;

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
        options: RenderOptions,
        model_frame: &Normalization,
    ) -> PyResult<RenderArgs> {
        let RenderOptions {
            mode,
            view,
            eye,
            target,
            fov,
            frame,
            shadows,
            ao,
            threads,
        } = options;
        let height = height.unwrap_or(width);
        for (name, v) in [("width", width), ("height", height)] {
            if !(1..=MAX_IMAGE_EDGE).contains(&v) {
                return Err(PyValueError::new_err(format!(
                    "{name} must be in 1..={MAX_IMAGE_EDGE}, got {v}"
                )));
            }
        }
        let mode = match mode.as_str() {
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
        let threads = run::check_threads(threads)?;
        let normalized = match frame.as_str() {
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
            settings: RenderSettings {
                mode,
                shadows,
                ao_samples: ao as u32,
                threads: None,
            },
            threads,
        })
    }

    /// Renders with `f` (given the settings, the camera and the cancellation test to pass to
    /// `sdfmo_render::render_cancellable`) without the GIL and returns the image as uint8
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
