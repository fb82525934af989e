//! The Python package `sdfmo` (distribution `sdf-multioctree`): PyO3 bindings of
//! sdf-multioctree's layers, built into an abi3 wheel for CPython >= 3.9 by maturin.
//!
//! This crate is not published on crates.io (`publish = false`): it ships as a wheel. Build and
//! install it with `pip install ./crates/sdfmo-py` or `maturin build -m
//! crates/sdfmo-py/Cargo.toml`; the package's documentation, examples and measured numbers are
//! in `crates/sdfmo-py/README.md` and `docs/results/python.md`.
//!
//! Every function is a thin layer over the Rust crates (no geometry of its own): it checks the
//! numpy arguments, converts model units to the normalised frame and back, and runs the layer's
//! function without the GIL on the requested threads, interruptible by Ctrl-C ([`run`]). Errors
//! map onto Python exceptions in [`errors`].
#![deny(missing_docs)]

mod arrays;
pub mod errors;
mod mesh;
mod octree;
mod render;
pub mod run;

use numpy::prelude::*;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use sdf_multioctree::distance::sample::{
    sdf_training_points_part, TrainingSamples, TRAINING_BLOCK,
};
use sdf_multioctree::io::Naming;
use sdf_multioctree::metrics;
use sdf_multioctree::Vec3;

use crate::mesh::Mesh;
use crate::octree::Octree;

/// PSNR in dB between two uint8 images of shape ``(h, w, 3)``, over all pixels and channels
/// (``inf`` for identical images), as ``sdfmo compare`` computes it. ``ValueError`` when the
/// shapes differ or a dtype is not uint8.
#[pyfunction]
fn psnr(py: Python<'_>, reference: &Bound<'_, PyAny>, test: &Bound<'_, PyAny>) -> PyResult<f64> {
    let a = arrays::image_arg(reference, "reference")?;
    let b = arrays::image_arg(test, "test")?;
    py.detach(|| metrics::psnr(&a, &b))
        .map_err(|e| errors::metrics_error(&e))
}

/// Mean LDR-FLIP (NVIDIA's perceptual difference; 0 = identical) between two uint8 images of
/// shape ``(h, w, 3)``, treated as sRGB at 67 pixels per degree, as ``sdfmo compare`` and
/// NVIDIA's ``flip`` tool compute it. With ``return_map`` also the per-pixel error, float32 of
/// shape ``(h, w)``.
#[pyfunction]
#[pyo3(signature = (reference, test, *, return_map = false))]
fn flip<'py>(
    py: Python<'py>,
    reference: &Bound<'py, PyAny>,
    test: &Bound<'py, PyAny>,
    return_map: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let a = arrays::image_arg(reference, "reference")?;
    let b = arrays::image_arg(test, "test")?;
    let r = py
        .detach(|| metrics::flip(&a, &b))
        .map_err(|e| errors::metrics_error(&e))?;
    let mean = r.mean.into_pyobject(py)?.into_any();
    if !return_map {
        return Ok(mean);
    }
    let map = numpy::PyArray1::from_vec(py, r.map)
        .reshape([r.height as usize, r.width as usize])?
        .into_any();
    Ok(PyTuple::new(py, [mean, map])?.into_any())
}

/// DeepSDF-style training samples of ``mesh``: ``points`` float32 ``(n, 3)`` and their exact
/// signed distances ``sdf`` float32 ``(n,)``, model units, negative inside.
///
/// The first ``round(n * near_fraction)`` points are uniform on the surface (area-weighted)
/// plus isotropic Gaussian noise, alternating between the two standard deviations ``sigmas``
/// (fractions of the bounding-box diagonal; default ``(0.025, 0.0079)``, DeepSDF's variances
/// 0.0025 and 0.00025 for a shape in the unit sphere, which the signature shows as ``...``:
/// PyO3 prints literal defaults only); the rest are uniform in the bounding box grown by
/// ``padding`` times its longest extent on every side. The same ``seed`` gives the same arrays
/// whatever ``threads``; ``sdf`` equals ``mesh.signed_distance(points, sign=sign)`` exactly.
/// Releases the GIL; Ctrl-C raises ``KeyboardInterrupt``.
#[pyfunction]
#[pyo3(signature = (
    mesh, n, *, seed = 0, near_fraction = 0.95, sigmas = (0.025, 0.0079), padding = 0.1,
    sign = "auto", threads = None
))]
fn sample_sdf<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, Mesh>,
    n: i64,
    seed: u64,
    near_fraction: f64,
    sigmas: (f64, f64),
    padding: f64,
    sign: &str,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyTuple>> {
    let mode = mesh::sign_arg(sign)?;
    let threads = run::check_threads(threads)?;
    let n = usize::try_from(n)
        .map_err(|_| PyValueError::new_err(format!("n must be >= 0, got {n}")))?;
    if !(0.0..=1.0).contains(&near_fraction) {
        return Err(PyValueError::new_err(format!(
            "near_fraction must be in [0, 1], got {near_fraction}"
        )));
    }
    // Checked as the float32 the sampler uses: 1e39 is a finite float64 but an infinite
    // float32, which hit the sampler's assertion (a PanicException before issue 32).
    for (name, v) in [
        ("sigmas[0]", sigmas.0),
        ("sigmas[1]", sigmas.1),
        ("padding", padding),
    ] {
        if !((v as f32).is_finite() && v >= 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} must be >= 0 and finite in float32 (at most {:e}), got {v}",
                f32::MAX
            )));
        }
    }
    let data = &mesh.get().data;
    check_sample_reach(data, sigmas.0.max(sigmas.1), padding)?;
    let params = TrainingSamples {
        near_fraction: near_fraction as f32,
        sigmas: [sigmas.0 as f32, sigmas.1 as f32],
        padding: padding as f32,
    };
    // Refused before allocating anything when the arrays cannot fit in this machine's memory
    // (`sample_sdf(m, 10**12)` raised a PanicException before issue 32); then every array is
    // allocated fallibly, so a smaller limit (an address-space limit) is a MemoryError too.
    let need = n as u128 * SAMPLE_BYTES as u128;
    if let Some(total) = sdf_multioctree::build::physical_memory() {
        if need > u128::from(total) {
            return Err(errors::memory_error(format!(
                "sample_sdf of n={n} points needs {need} bytes ({SAMPLE_BYTES} per point), more \
                 than this machine's {total} bytes of memory"
            )));
        }
    }
    let out_p = arrays::new_f32x3(py, n)?;
    let out_d = arrays::new_f32(py, n)?;
    let mut pts: Vec<Vec3> = Vec::new();
    pts.try_reserve_exact(n).map_err(|_| {
        errors::memory_error(format!(
            "cannot allocate the {n} sample points ({need} bytes in all)"
        ))
    })?;
    pts.resize(n, Vec3::ZERO);
    // Safety: fresh arrays that no Python code sees until this function returns.
    let ps = unsafe { out_p.as_slice_mut() }.expect("fresh contiguous array");
    let ds = unsafe { out_d.as_slice_mut() }.expect("fresh contiguous array");
    let result = run::run(py, threads, n.max(run::INLINE_ITEMS), |cancel| {
        // The distance structure and the sign's one-time data are built while the points are
        // drawn: neither needs the other, and on the bunny they are ≈ 0.1 and 0.2 CPU-s of a
        // first call's 1.9 (docs/results/python.md).
        let (dist, ()) = rayon::join(
            || {
                let d = data.distance(mode)?;
                if n >= 256 {
                    d.prepare_sign();
                }
                Ok(d)
            },
            || {
                // In parts of SAMPLE_PART points, so that Ctrl-C stops the drawing too.
                for (i, part) in pts.chunks_mut(SAMPLE_PART).enumerate() {
                    if cancel.is_set() {
                        return;
                    }
                    sdf_training_points_part(&data.mesh, n, i * SAMPLE_PART, part, &params, seed);
                }
            },
        );
        let dist = match dist {
            Ok(d) => d,
            Err(e) => return Ok(Err(e)),
        };
        if cancel.is_set() {
            return Err(run::Cancelled);
        }
        for (o, p) in ps.chunks_exact_mut(3).zip(&pts) {
            o.copy_from_slice(&p.to_array());
        }
        let view = arrays::PointsView::F32(
            numpy::ndarray::ArrayView2::from_shape((n, 3), &*ps).expect("n x 3"),
        );
        mesh::for_chunks(data, view, "points", cancel, |start, chunk| {
            let d = dist.signed_distances(chunk);
            for (o, v) in ds[start..start + chunk.len()].iter_mut().zip(d) {
                *o = data.to_model_length(v);
            }
        })
    })?;
    result?;
    PyTuple::new(py, [out_p.into_any(), out_d.into_any()])
}

/// Points `sample_sdf` draws between two checks for Ctrl-C (a multiple of the sampler's block;
/// each part also costs one pass over the triangles).
const SAMPLE_PART: usize = 256 * TRAINING_BLOCK;

/// Bytes `sample_sdf` allocates per point: the float32 points and distances it returns (16)
/// and the points as the sampler writes them (12).
const SAMPLE_BYTES: usize = 28;

/// Refuses `sigmas` (the larger, `sigma`) and `padding` that would put sample points where
/// the distance queries overflow (farther than
/// [`MAX_QUERY_COORDINATE`](sdf_multioctree::distance::MAX_QUERY_COORDINATE) in the
/// normalised frame): the Gaussian noise reaches at most 8.6 standard deviations (Box-Muller
/// from 53-bit uniforms, sqrt(-2 ln 2^-53)), each a fraction `sigma` of the bounding box's
/// diagonal; the uniform points reach `padding` times the longest extent past the box.
fn check_sample_reach(data: &mesh::MeshData, sigma: f64, padding: f64) -> PyResult<()> {
    let b = data.mesh.bounds();
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let half = 0.5 * (hi - lo).max_element();
    let noise = 9.0 * sigma * (hi - lo).length();
    let pad = padding * (hi - lo).max_element();
    // From the box's centre, in the normalised frame.
    let reach = (half + noise.max(pad)) * f64::from(data.norm.scale);
    let limit = f64::from(sdf_multioctree::distance::MAX_QUERY_COORDINATE);
    if reach > limit {
        return Err(PyValueError::new_err(format!(
            "sigmas={sigma:e} or padding={padding:e} would put sample points {reach:e} from the \
             mesh in its normalised frame (more than {limit:e}), where distances overflow \
             float32"
        )));
    }
    Ok(())
}

/// Reads a PNG as uint8 ``(h, w, 3)`` RGB, as ``sdfmo compare`` and NVIDIA's ``flip`` tool read
/// it (16-bit channels keep their high byte, alpha is dropped, grey is replicated). ``OSError``
/// subclasses when the file cannot be read, ``ValueError`` when it is not a valid PNG.
#[pyfunction]
fn load_png<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let img = py
        .detach(|| metrics::load_rgb8(&path))
        .map_err(|e| errors::metrics_error(&e))?;
    let (w, h) = img.dimensions();
    Ok(arrays::image_array(py, img.into_raw(), w, h)?.into_any())
}

/// Writes a uint8 ``(h, w, 3)`` image as an 8-bit RGB PNG, atomically (a temporary file in the
/// same folder, then renamed), creating the folder if needed. ``path`` must end in ``.png``
/// (any case; ``ValueError`` otherwise, as ``sdfmo render -o`` refuses it).
#[pyfunction]
fn save_png(py: Python<'_>, path: std::path::PathBuf, image: &Bound<'_, PyAny>) -> PyResult<()> {
    sdf_multioctree::io::check_output(&path, "path", &["png"], Naming::Given)
        .map_err(|e| errors::io_error(&e))?;
    let img = arrays::image_arg(image, "image")?;
    py.detach(|| metrics::save_png(&img, &path))
        .map_err(|e| errors::metrics_error(&e))
}

/// The extension module `sdfmo._sdfmo`; `sdfmo/__init__.py` re-exports its names.
#[pymodule]
fn _sdfmo(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<Mesh>()?;
    m.add_class::<Octree>()?;
    m.add_class::<render::RenderOptions>()?;
    m.add_function(wrap_pyfunction!(sample_sdf, m)?)?;
    m.add_function(wrap_pyfunction!(psnr, m)?)?;
    m.add_function(wrap_pyfunction!(flip, m)?)?;
    m.add_function(wrap_pyfunction!(load_png, m)?)?;
    m.add_function(wrap_pyfunction!(save_png, m)?)?;
    m.add("FormatError", py.get_type::<errors::FormatError>())?;
    m.add("MeshError", py.get_type::<errors::MeshError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
