//! numpy arguments: points (any float dtype, any layout, shape `(..., 3)`), images, and the
//! arrays the calls return.

use glam::DVec3;
use numpy::ndarray::ArrayView2;
use numpy::prelude::*;
use numpy::{
    Element, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArray,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::type_object::PyTypeCheck;
use pyo3::types::{PyBytes, PyTuple};

use crate::run::{self, Cancel, Cancelled};

/// An `(n, 3)` array of points as numpy holds it: float32 or float64, any strides (C or
/// Fortran order, or a strided view), never copied.
pub enum Points<'py> {
    /// float32 points.
    F32(PyReadonlyArray2<'py, f32>),
    /// float64 points.
    F64(PyReadonlyArray2<'py, f64>),
}

/// A borrowed view of [`Points`] that can cross into the worker threads.
#[derive(Clone, Copy)]
pub enum PointsView<'a> {
    /// float32 points.
    F32(ArrayView2<'a, f32>),
    /// float64 points.
    F64(ArrayView2<'a, f64>),
}

impl PointsView<'_> {
    /// Number of points.
    pub fn len(&self) -> usize {
        match self {
            PointsView::F32(a) => a.nrows(),
            PointsView::F64(a) => a.nrows(),
        }
    }

    /// Point `i` in f64.
    #[inline]
    pub fn get(&self, i: usize) -> DVec3 {
        match self {
            PointsView::F32(a) => DVec3::new(
                f64::from(a[[i, 0]]),
                f64::from(a[[i, 1]]),
                f64::from(a[[i, 2]]),
            ),
            PointsView::F64(a) => DVec3::new(a[[i, 0]], a[[i, 1]], a[[i, 2]]),
        }
    }
}

impl Points<'_> {
    /// The view for the worker threads.
    pub fn view(&self) -> PointsView<'_> {
        match self {
            Points::F32(a) => PointsView::F32(a.as_array()),
            Points::F64(a) => PointsView::F64(a.as_array()),
        }
    }
}

/// A points argument and the shape of its leading dimensions (the shape of per-point results).
pub struct PointsArg<'py> {
    /// The points, `(n, 3)`.
    pub points: Points<'py>,
    /// The argument's shape without its last dimension (`(n,)` for an `(n, 3)` array).
    pub lead: Vec<usize>,
}

/// Reads an array argument named `name` whose last dimension must be `width` (3 for points):
/// numpy arrays of float32 / float64 are used in place; other float dtypes (float16,
/// longdouble) are converted to float64; anything else that is not a numpy array goes through
/// `numpy.asarray(x, dtype=float64)` (lists, tuples, array-likes). Integer, bool, complex and
/// object arrays are refused: a `ValueError` naming the dtype.
pub fn points_arg<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    width: usize,
) -> PyResult<PointsArg<'py>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let arr: Bound<'py, PyUntypedArray> = match obj.cast::<PyUntypedArray>() {
        Ok(a) => a.clone(),
        Err(_) => np
            .call_method1("asarray", (obj, np.getattr("float64")?))
            .map_err(|e| {
                PyValueError::new_err(format!(
                    "{name} must be an array of shape (..., {width}) of floats: {e}"
                ))
            })?
            .cast_into::<PyUntypedArray>()?,
    };
    let kind = arr.dtype().kind();
    let arr = match kind {
        b'f' => {
            let size = arr.dtype().itemsize();
            if size == 4 || size == 8 {
                arr
            } else {
                arr.call_method1("astype", (np.getattr("float64")?,))?
                    .cast_into::<PyUntypedArray>()?
            }
        }
        _ => {
            return Err(PyValueError::new_err(format!(
                "{name} must hold floating-point numbers (float32 or float64; float16 and \
                 longdouble are converted), got dtype {}",
                arr.dtype().str()?
            )))
        }
    };
    let arr = native_order(arr)?;
    let shape = arr.shape().to_vec();
    if shape.is_empty() || shape[shape.len() - 1] != width {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (..., {width}) (one row of {width} coordinates per point), \
             got shape {shape:?}"
        )));
    }
    let lead = shape[..shape.len() - 1].to_vec();
    let arr = if shape.len() == 2 {
        arr
    } else {
        // A view where numpy can (C-ordered input); a copy otherwise.
        arr.call_method1("reshape", ((-1i64, width as i64),))?
            .cast_into::<PyUntypedArray>()?
    };
    let points = if arr.dtype().itemsize() == 4 {
        Points::F32(
            arr.cast::<PyArray2<f32>>()?
                .try_readonly()
                .map_err(borrow_err)?,
        )
    } else {
        Points::F64(
            arr.cast::<PyArray2<f64>>()?
                .try_readonly()
                .map_err(borrow_err)?,
        )
    };
    Ok(PointsArg { points, lead })
}

fn borrow_err(e: numpy::BorrowError) -> PyErr {
    PyValueError::new_err(format!("the array is being written elsewhere: {e}"))
}

/// The first non-finite point of `view[range]`, as a `ValueError` naming its index.
pub fn non_finite_error(name: &str, i: usize, p: DVec3) -> PyErr {
    PyValueError::new_err(format!(
        "{name}[{i}] = ({}, {}, {}) is not finite (NaN or infinite coordinates are refused)",
        p.x, p.y, p.z
    ))
}

/// Runs `each_chunk` over the points of `view`, [`run::chunk_len`] at a time, with the index
/// of the chunk's first point. Every point of a chunk is checked before the chunk is handed
/// on: a non-finite one is a `ValueError` naming `name[i]`, and `check` turns each finite one
/// into what `each_chunk` receives (the query's own frame) or the error to raise. Stops
/// between chunks when `cancel` is set.
pub fn for_checked_chunks<Q>(
    view: PointsView<'_>,
    name: &str,
    cancel: &Cancel,
    mut check: impl FnMut(usize, DVec3) -> PyResult<Q>,
    mut each_chunk: impl FnMut(usize, &[Q]),
) -> Result<PyResult<()>, Cancelled> {
    let n = view.len();
    let chunk = run::chunk_len();
    let mut checked: Vec<Q> = Vec::with_capacity(chunk.min(n));
    let mut start = 0;
    while start < n {
        if cancel.is_set() {
            return Err(Cancelled);
        }
        let end = (start + chunk).min(n);
        checked.clear();
        for i in start..end {
            let p = view.get(i);
            if !p.is_finite() {
                return Ok(Err(non_finite_error(name, i, p)));
            }
            match check(i, p) {
                Ok(q) => checked.push(q),
                Err(e) => return Ok(Err(e)),
            }
        }
        each_chunk(start, &checked);
        start = end;
    }
    Ok(Ok(()))
}

/// `numpy.zeros(shape, dtype)`, C-ordered. numpy's own allocation: a failure is numpy's
/// `MemoryError` ("Unable to allocate … for an array with shape …"), where rust-numpy's
/// constructors panic (a `PanicException` before issue 32).
fn zeros<'py, A: PyTypeCheck>(
    py: Python<'py>,
    shape: &[usize],
    dtype: &str,
) -> PyResult<Bound<'py, A>> {
    let np = py.import("numpy")?;
    let arr = np.call_method1("zeros", (PyTuple::new(py, shape)?, dtype))?;
    Ok(arr.cast_into::<A>()?)
}

/// A new float32 array of `n` values (zeroed), to fill without the GIL.
pub fn new_f32<'py>(py: Python<'py>, n: usize) -> PyResult<Bound<'py, PyArray1<f32>>> {
    zeros(py, &[n], "float32")
}

/// A new int64 array of `n` values.
pub fn new_i64<'py>(py: Python<'py>, n: usize) -> PyResult<Bound<'py, PyArray1<i64>>> {
    zeros(py, &[n], "int64")
}

/// A new `(n, 3)` float32 array.
pub fn new_f32x3<'py>(py: Python<'py>, n: usize) -> PyResult<Bound<'py, PyArray2<f32>>> {
    zeros(py, &[n, 3], "float32")
}

/// `arr` in the machine's byte order: a big-endian array on a little-endian machine (or the
/// reverse) is converted (a copy), as rust-numpy reads native arrays only (before issue 32 it
/// was a `TypeError` about the array's type).
pub fn native_order<'py>(arr: Bound<'py, PyUntypedArray>) -> PyResult<Bound<'py, PyUntypedArray>> {
    let dtype = arr.getattr("dtype")?;
    if dtype.getattr("isnative")?.extract::<bool>()? {
        return Ok(arr);
    }
    let native = dtype.call_method1("newbyteorder", ("=",))?;
    Ok(arr
        .call_method1("astype", (native,))?
        .cast_into::<PyUntypedArray>()?)
}

/// The `(n, C)` array of `rows` (a copy).
pub fn rows<'py, T: Element, const C: usize>(
    py: Python<'py>,
    rows: impl IntoIterator<Item = [T; C]>,
) -> Bound<'py, PyArray2<T>> {
    let flat: Vec<T> = rows.into_iter().flatten().collect();
    let n = flat.len() / C;
    PyArray1::from_vec(py, flat)
        .reshape([n, C])
        .expect("n * C values")
}

/// One float32 per point of `points` (shape `(..., 3)`, any float dtype), shaped `(...)`:
/// `fill` writes them without the GIL on `threads` workers ([`run::run`]), given the points'
/// view and the values to fill; it returns `Err(Cancelled)` when it saw the flag and `Ok(Err)`
/// for the error to raise (a non-finite point…).
pub fn f32_per_point<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    threads: Option<i64>,
    fill: impl FnOnce(PointsView<'_>, &mut [f32], &Cancel) -> Result<PyResult<()>, Cancelled> + Send,
) -> PyResult<Bound<'py, PyAny>> {
    let threads = run::check_threads(threads)?;
    let arg = points_arg(points, "points", 3)?;
    let view = arg.points.view();
    let n = view.len();
    let out = new_f32(py, n)?;
    // Safety: the array was just created here and no Python code sees it until this function
    // returns; `fill` is its only writer.
    let values = unsafe { out.as_slice_mut() }.expect("fresh contiguous array");
    run::run(py, threads, n, |cancel| fill(view, values, cancel))??;
    shaped(out.into_any(), &arg.lead, &[])
}

/// `arr` reshaped to `lead + extra` (a view: `arr` is a fresh C-ordered array).
pub fn shaped<'py>(
    arr: Bound<'py, PyAny>,
    lead: &[usize],
    extra: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    if lead.len() == 1 {
        return Ok(arr);
    }
    let dims: Vec<usize> = lead.iter().chain(extra).copied().collect();
    let py = arr.py();
    arr.call_method1("reshape", (PyTuple::new(py, dims)?,))
}

/// A uint8 `(h, w, 3)` image from row-major RGB bytes.
pub fn image_array<'py>(
    py: Python<'py>,
    rgb: Vec<u8>,
    width: u32,
    height: u32,
) -> PyResult<Bound<'py, PyArray3<u8>>> {
    let a = numpy::ndarray::Array3::from_shape_vec((height as usize, width as usize, 3), rgb)
        .map_err(|e| PyValueError::new_err(format!("image buffer: {e}")))?;
    Ok(a.into_pyarray(py))
}

/// Reads a uint8 `(h, w, 3)` image argument into an `image::RgbImage` (a copy).
pub fn image_arg(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<image::RgbImage> {
    let arr = obj.cast::<PyUntypedArray>().map_err(|_| {
        PyValueError::new_err(format!(
            "{name} must be a numpy uint8 array of shape (h, w, 3), got {}",
            obj.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        ))
    })?;
    let shape = arr.shape().to_vec();
    if arr.dtype().kind() != b'u' || arr.dtype().itemsize() != 1 {
        return Err(PyValueError::new_err(format!(
            "{name} must have dtype uint8 (8-bit RGB), got {}",
            arr.dtype().str()?
        )));
    }
    if shape.len() != 3 || shape[2] != 3 || shape[0] == 0 || shape[1] == 0 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (h, w, 3) with h, w >= 1, got {shape:?}"
        )));
    }
    let a = arr
        .cast::<PyArray3<u8>>()?
        .try_readonly()
        .map_err(borrow_err)?;
    let (h, w) = (shape[0], shape[1]);
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(PyValueError::new_err(format!(
            "{name} is too large: {shape:?}"
        )));
    };
    let bytes: Vec<u8> = a.as_array().iter().copied().collect();
    image::RgbImage::from_raw(w32, h32, bytes)
        .ok_or_else(|| PyValueError::new_err(format!("{name}: inconsistent image buffer")))
}

/// The bytes of a bytes-like argument (anything with the buffer protocol), read in place where
/// nothing else can change them.
pub enum BytesArg<'py> {
    /// A `bytes` object (immutable), read in place.
    Bytes(Bound<'py, PyBytes>),
    /// A read-only buffer (a `memoryview` of `bytes`, a read-only array), read in place.
    ReadOnly(PyReadonlyArray1<'py, u8>),
    /// A writable buffer (`bytearray`, a numpy array), copied once while the GIL is held:
    /// another thread could write to it while the bytes are validated without the GIL.
    Copied(Vec<u8>),
}

impl BytesArg<'_> {
    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        match self {
            BytesArg::Bytes(b) => b.as_bytes(),
            BytesArg::ReadOnly(a) => a.as_slice().expect("numpy.frombuffer is contiguous"),
            BytesArg::Copied(v) => v,
        }
    }
}

/// Reads a bytes-like argument named `name`: `bytes`, `bytearray`, `memoryview` or any
/// C-contiguous buffer (a numpy array of any dtype gives its raw bytes, as `bytes(a)` does),
/// through `numpy.frombuffer` (a view, no copy). Anything else is a `TypeError` naming the
/// type.
pub fn bytes_arg<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<BytesArg<'py>> {
    if let Ok(b) = obj.cast::<PyBytes>() {
        return Ok(BytesArg::Bytes(b.clone()));
    }
    let py = obj.py();
    let np = py.import("numpy")?;
    let view = np
        .call_method1("frombuffer", (obj, np.getattr("uint8")?))
        .map_err(|e| {
            let type_name = obj
                .get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default();
            // numpy's reason only where it adds to the type (a strided array, not a str).
            let why = if e.is_instance_of::<PyTypeError>(py) {
                String::new()
            } else {
                format!(" ({})", e.value(py))
            };
            PyTypeError::new_err(format!(
                "{name} must be a bytes-like object (bytes, bytearray, memoryview, a \
                 C-contiguous numpy array), got {type_name}{why}"
            ))
        })?
        .cast_into::<PyArray1<u8>>()?;
    let writeable: bool = view.getattr("flags")?.getattr("writeable")?.extract()?;
    let view = view.try_readonly().map_err(borrow_err)?;
    if !writeable {
        return Ok(BytesArg::ReadOnly(view));
    }
    let bytes = view.as_slice().expect("numpy.frombuffer is contiguous");
    let mut copy = Vec::new();
    copy.try_reserve_exact(bytes.len()).map_err(|_| {
        crate::errors::memory_error(format!(
            "cannot allocate {} bytes to copy {name}",
            bytes.len()
        ))
    })?;
    copy.extend_from_slice(bytes);
    Ok(BytesArg::Copied(copy))
}
