//! `sdfmo.RenderOptions` and the render arguments shared by `Mesh.render` and
//! `Octree.render`: the command-line tool's camera, modes and limits.

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sdf_multioctree::mesh::Normalization;
use sdf_multioctree::render::{
    Camera, Mode, RenderError, RenderSettings, Rendered, MAX_AO_SAMPLES,
};

use crate::arrays;
use crate::errors;
use crate::run;

/// How to render an image, given to ``Mesh.render`` and ``Octree.render`` as ``options=``
/// (the primary way: one object for many calls and images). The same keywords given to
/// ``render`` directly (``render(64, mode="mask")``) make a ``RenderOptions`` of them; not
/// both in one call (``TypeError``).
///
/// The camera is the command-line tool's: one of the paper's four views (``view`` 0..3: eye
/// on a circle of radius 3 in the y = 0 plane of the normalised frame, the root cube
/// [-1, 1]^3, looking at its origin, 60 degrees vertical field of view), with ``eye``,
/// ``target`` (3 numbers each, **in model units**, the mesh's own coordinates, like every
/// point this package takes; ``frame="normalized"`` for the root cube's) and ``fov``
/// (degrees, in (0, 180)) replacing its parts. ``mode``: ``"lambert"`` (the paper's
/// shading), ``"mask"``, ``"depth"`` or ``"normal"``; ``shadows`` and ``ao``
/// (ambient-occlusion rays per pixel, 0..=1024) apply to lambert only. ``None`` for
/// ``mode``, ``shadows`` or ``ao`` is the renderer's default (lambert, no shadows, no
/// occlusion; the getters and ``repr`` give the value).
///
/// Each value is checked here: ``ValueError`` naming the field for a bad value,
/// ``TypeError`` for a value of the wrong type. Immutable; equal when every field is.
#[pyclass(module = "sdfmo", frozen, eq)]
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// `mode`, `shadows` and `ao`.
    settings: RenderSettings,
    /// One of the paper's four cameras.
    view: u32,
    /// The eye, in the frame `normalized` names.
    eye: Option<[f32; 3]>,
    /// The target, in the frame `normalized` names.
    target: Option<[f32; 3]>,
    /// Vertical field of view in degrees; `None`: the view's.
    fov: Option<f32>,
    /// `frame="normalized"`: `eye` and `target` in the root cube's coordinates.
    normalized: bool,
}

#[pymethods]
impl RenderOptions {
    #[new]
    #[pyo3(signature = (
        *, mode = None, view = 0, eye = None, target = None, fov = None, frame = "model",
        shadows = None, ao = None
    ))]
    fn py_new(
        mode: Option<&str>,
        view: i64,
        eye: Option<Vec<f32>>,
        target: Option<Vec<f32>>,
        fov: Option<f32>,
        frame: &str,
        shadows: Option<bool>,
        ao: Option<i64>,
    ) -> PyResult<RenderOptions> {
        // `None`: the renderer's default, its one source (RenderSettings::default()).
        let defaults = RenderSettings::default();
        let shadows = shadows.unwrap_or(defaults.shadows);
        let ao = ao.unwrap_or(i64::from(defaults.ao_samples));
        let mode = match mode {
            None => defaults.mode,
            // Listed in the order of the message (Mode::ALL starts with the mask).
            Some(name) => {
                let modes = [Mode::Lambert, Mode::Mask, Mode::Depth, Mode::Normal];
                errors::choice("mode", name, &modes.map(|m| (m.name(), m)))?
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
        if let Some(f) = fov {
            if !(f > 0.0 && f < 180.0) {
                return Err(PyValueError::new_err(format!(
                    "fov must be in (0, 180) degrees, got {f}"
                )));
            }
        }
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
        Ok(RenderOptions {
            settings: RenderSettings::new(mode)
                .with_shadows(shadows)
                .with_ao_samples(ao as u32),
            view: view as u32,
            eye: point_option(eye, "eye")?,
            target: point_option(target, "target")?,
            fov,
            normalized,
        })
    }

    /// ``"lambert"``, ``"mask"``, ``"depth"`` or ``"normal"``.
    #[getter]
    fn mode(&self) -> &'static str {
        self.settings.mode.name()
    }

    /// One of the paper's four cameras, 0..3.
    #[getter]
    fn view(&self) -> u32 {
        self.view
    }

    /// The eye ``(x, y, z)`` in the frame ``frame`` names, or ``None`` for the view's.
    #[getter]
    fn eye(&self) -> Option<(f32, f32, f32)> {
        self.eye.map(|[x, y, z]| (x, y, z))
    }

    /// The target ``(x, y, z)`` in the frame ``frame`` names, or ``None`` for the view's.
    #[getter]
    fn target(&self) -> Option<(f32, f32, f32)> {
        self.target.map(|[x, y, z]| (x, y, z))
    }

    /// Vertical field of view in degrees, or ``None`` for the view's (60).
    #[getter]
    fn fov(&self) -> Option<f32> {
        self.fov
    }

    /// ``"model"`` or ``"normalized"``: the frame of ``eye`` and ``target``.
    #[getter]
    fn frame(&self) -> &'static str {
        if self.normalized {
            "normalized"
        } else {
            "model"
        }
    }

    /// Shadow rays toward the light (lambert only).
    #[getter]
    fn shadows(&self) -> bool {
        self.settings.shadows
    }

    /// Ambient-occlusion rays per pixel (lambert only; 0: off).
    #[getter]
    fn ao(&self) -> u32 {
        self.settings.ao_samples
    }

    fn __repr__(&self) -> String {
        // Python's spelling of each value, so that the text evaluates to an equal object.
        let point = |p: Option<[f32; 3]>| match p {
            None => "None".to_string(),
            Some([x, y, z]) => format!("({x:?}, {y:?}, {z:?})"),
        };
        format!(
            "RenderOptions(mode='{}', view={}, eye={}, target={}, fov={}, frame='{}', \
             shadows={}, ao={})",
            self.mode(),
            self.view,
            point(self.eye),
            point(self.target),
            self.fov.map_or("None".to_string(), |f| format!("{f:?}")),
            self.frame(),
            if self.settings.shadows {
                "True"
            } else {
                "False"
            },
            self.settings.ao_samples
        )
    }
}

impl RenderOptions {
    /// The options of a `render` call: `options=`, or else its keywords given to `render`
    /// itself (`kwargs`), made into a `RenderOptions` by its own constructor (the defaults
    /// without any).
    fn of_call(
        py: Python<'_>,
        options: Option<&Bound<'_, RenderOptions>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<RenderOptions> {
        match (options, kwargs) {
            (Some(_), Some(k)) if !k.is_empty() => Err(PyTypeError::new_err(format!(
                "render() takes options= or its keywords ({}), not both",
                k.keys()
            ))),
            (Some(o), _) => Ok(o.get().clone()),
            (None, k) => {
                let made = py.get_type::<RenderOptions>().call((), k)?;
                Ok(made.cast::<RenderOptions>()?.get().clone())
            }
        }
    }
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

/// The arguments `Mesh.render` and `Octree.render` share, as the call gave them (both PyO3
/// signatures start `width = 1024, height = None, *, options = None, threads = None`, and
/// end `**kwargs`: `RenderOptions`' keywords).
pub struct RenderCall<'a, 'py> {
    /// `width=`: pixels.
    pub width: i64,
    /// `height=`: pixels, `None` for `width`.
    pub height: Option<i64>,
    /// `options=`.
    pub options: Option<&'a Bound<'py, RenderOptions>>,
    /// `threads=`.
    pub threads: Option<i64>,
    /// The other keywords: `RenderOptions`' given to `render` itself.
    pub kwargs: Option<&'a Bound<'py, PyDict>>,
}

/// A checked render request.
pub struct RenderArgs {
    camera: Camera,
    settings: RenderSettings,
    threads: Option<usize>,
}

impl RenderArgs {
    /// Checks the arguments of a `render` call, the same for `Mesh.render` and
    /// `Octree.render` (see `RenderOptions`); `model_frame` is the source's normalisation,
    /// through which `eye` and `target` in model units are mapped.
    pub fn parse(
        py: Python<'_>,
        call: RenderCall<'_, '_>,
        model_frame: &Normalization,
    ) -> PyResult<RenderArgs> {
        let o = RenderOptions::of_call(py, call.options, call.kwargs)?;
        let (width, height) = (call.width, call.height.unwrap_or(call.width));
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
        let threads = run::check_threads(call.threads)?;
        // The command line's camera (`sdfmo render --eye`): one eye, one image.
        let camera = sdf_multioctree::placed_camera(
            Camera::paper_view(o.view, width as u32, height as u32),
            o.eye,
            o.target,
            o.fov,
            (!o.normalized).then_some(model_frame),
        );
        // An eye on the target, named as the caller gave it (the renderer's message would name
        // the normalised point: eye=(0, 0, 0) in model units read "[-0.95, -0.95, -0.95]").
        // The defaults differ, so at least one of the two was given.
        if camera.eye == camera.target {
            let [x, y, z] = o.eye.or(o.target).unwrap_or(camera.eye.to_array());
            return Err(PyValueError::new_err(format!(
                "invalid camera: eye and target are the same point ({x}, {y}, {z}) \
                 (frame=\"{}\")",
                o.frame()
            )));
        }
        // Non-finite or degenerate cameras: the renderer's own message.
        camera
            .frame()
            .map_err(|e| crate::errors::render_error(&e))?;
        Ok(RenderArgs {
            camera,
            // The renderer runs on the caller's pool: `threads` is ours (`run::run`).
            settings: o.settings,
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
