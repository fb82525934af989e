//! `sdfmo.Mesh`: a triangle mesh in model units and the exact queries on it.

use std::path::PathBuf;
use std::sync::OnceLock;

use glam::{DVec3, Vec3};
use numpy::prelude::*;
use numpy::{PyArray2, PyUntypedArray};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use rayon::prelude::*;
use sdf_multioctree::build::{self, BuildSettings, Method};
use sdf_multioctree::distance::{MeshDistance, SignMode, MAX_QUERY_COORDINATE};
use sdf_multioctree::format::ValueBits;
use sdf_multioctree::mesh::{self, Normalization, Topology, TriMesh};
use sdf_multioctree::render::MeshScene;
use sdf_multioctree::DEFAULT_MARGIN;

use crate::arrays::{self, PointsArg, PointsView};
use crate::errors;
use crate::octree::Octree;
use crate::render::{RenderArgs, RenderCall, RenderOptions};
use crate::run::{self, Cancel, Cancelled};

/// Parses a `sign=` argument.
pub fn sign_arg(sign: &str) -> PyResult<SignMode> {
    let modes = [SignMode::Auto, SignMode::PseudoNormal, SignMode::Winding];
    errors::choice("sign", sign, &modes.map(|m| (sign_name(m), m)))
}

/// The name of a resolved sign mode.
pub fn sign_name(mode: SignMode) -> &'static str {
    match mode {
        SignMode::Auto => "auto",
        SignMode::PseudoNormal => "pseudonormal",
        SignMode::Winding => "winding",
    }
}

/// The mesh and everything derived from it, computed once on first use.
pub struct MeshData {
    /// The mesh in model units.
    pub mesh: TriMesh,
    /// Model units → the normalised frame the queries run in (the builder's, margin 0.05).
    pub norm: Normalization,
    topology: OnceLock<Topology>,
    /// What `SignMode::Auto` resolves to on this mesh.
    auto: OnceLock<SignMode>,
    /// The distance structures of the normalised mesh: pseudo-normal and winding sign.
    pseudo: OnceLock<MeshDistance>,
    winding: OnceLock<MeshDistance>,
}

impl MeshData {
    /// Wraps a model-unit mesh.
    pub fn new(mesh: TriMesh) -> MeshData {
        let norm = Normalization::for_bounds(&mesh.bounds(), DEFAULT_MARGIN);
        MeshData {
            mesh,
            norm,
            topology: OnceLock::new(),
            auto: OnceLock::new(),
            pseudo: OnceLock::new(),
            winding: OnceLock::new(),
        }
    }

    /// The mesh in the normalised frame, exactly as `TriMesh::normalized` maps it (the CLI's
    /// and the builder's frame).
    fn normalized(&self) -> TriMesh {
        self.mesh.normalized(DEFAULT_MARGIN).0
    }

    /// The topology (edges, components, watertightness).
    pub fn topology(&self) -> &Topology {
        self.topology.get_or_init(|| self.mesh.topology())
    }

    /// The distance structure with the sign `mode` (Auto resolved from the topology), built on
    /// first use. Call without the GIL: a large mesh takes a while.
    pub fn distance(&self, mode: SignMode) -> PyResult<&MeshDistance> {
        let slot = |m: SignMode| match m {
            SignMode::Winding => &self.winding,
            _ => &self.pseudo,
        };
        let mode = match mode {
            SignMode::Auto => match self.auto.get() {
                Some(m) => *m,
                None => {
                    let d = MeshDistance::new(&self.normalized(), SignMode::Auto)
                        .map_err(|e| errors::distance_error(&e))?;
                    let m = d.sign_mode();
                    let _ = slot(m).set(d);
                    let _ = self.auto.set(m);
                    m
                }
            },
            m => m,
        };
        if let Some(d) = slot(mode).get() {
            return Ok(d);
        }
        let d =
            MeshDistance::new(&self.normalized(), mode).map_err(|e| errors::distance_error(&e))?;
        let _ = slot(mode).set(d);
        Ok(slot(mode).get().expect("set above"))
    }

    /// Any distance structure already built (unsigned queries, winding numbers and rays do
    /// not depend on the sign), else the automatic one.
    pub fn any_distance(&self) -> PyResult<&MeshDistance> {
        match self.pseudo.get().or(self.winding.get()) {
            Some(d) => Ok(d),
            None => self.distance(SignMode::Auto),
        }
    }

    /// A model-unit point in the normalised frame (in f64, rounded once).
    #[inline]
    pub fn to_normalized(&self, p: DVec3) -> Vec3 {
        self.norm.point_to_normalized(p)
    }

    /// A normalised length in model units.
    #[inline]
    pub fn to_model_length(&self, d: f32) -> f32 {
        self.norm.length_to_model(d)
    }

    /// A normalised point in model units.
    #[inline]
    pub fn to_model(&self, p: Vec3) -> [f32; 3] {
        self.norm.point_to_model(p).to_array()
    }
}

/// The `ValueError` of point `name[i]` = `p`, too far from the mesh for the queries.
fn too_far_error(data: &MeshData, name: &str, i: usize, p: DVec3) -> PyErr {
    let limit = f64::from(MAX_QUERY_COORDINATE) / f64::from(data.norm.scale);
    PyValueError::new_err(format!(
        "{name}[{i}] = ({}, {}, {}) is too far from the mesh: farther than {limit:e} model units \
         from its centre ({MAX_QUERY_COORDINATE:e} in the normalised frame), where distances \
         overflow float32",
        p.x, p.y, p.z
    ))
}

/// Runs `f` over the points of `view` chunk by chunk ([`arrays::for_checked_chunks`]), each
/// chunk converted to the normalised frame of `data`: a non-finite point, or one farther than
/// [`MAX_QUERY_COORDINATE`] in the normalised frame, is a `ValueError` naming its index.
pub fn for_chunks(
    data: &MeshData,
    view: PointsView<'_>,
    name: &str,
    cancel: &Cancel,
    f: impl FnMut(usize, &[Vec3]),
) -> Result<PyResult<()>, Cancelled> {
    let normalized = |i: usize, p: DVec3| -> PyResult<Vec3> {
        let q = data.to_normalized(p);
        if q.abs().max_element() > MAX_QUERY_COORDINATE {
            return Err(too_far_error(data, name, i, p));
        }
        Ok(q)
    };
    arrays::for_checked_chunks(view, name, cancel, normalized, f)
}

/// A triangle mesh in model units, with exact distance queries.
///
/// Create one from numpy arrays, ``Mesh(vertices, faces)``, or from a file,
/// ``Mesh.load(path)``. Queries take points in the mesh's own (model) units and return
/// distances in model units. Internally every query runs in the builder's normalised frame
/// (bounding-box centre at the origin, longest extent 1.9), where the f32 arithmetic of the
/// distance layer is calibrated; the conversion is done in float64.
///
/// The distance structures (BVH, pseudo-normals, winding-number tree) are built on the first
/// query that needs them, once per sign method, without holding the GIL.
#[pyclass(module = "sdfmo", frozen)]
pub struct Mesh {
    pub(crate) data: MeshData,
}

impl Mesh {
    /// Wraps a mesh, refusing one with no extent or no area (`ValueError`, the builder's
    /// [`BuildError::DegenerateMesh`](build::BuildError::DegenerateMesh)): its normalisation
    /// has no scale and every query would answer with the distance to a point or a line
    /// (`sample_sdf` returned zeros before issue 37).
    pub fn from_trimesh(mesh: TriMesh) -> PyResult<Mesh> {
        build::check_mesh(&mesh).map_err(|e| errors::build_error(&e))?;
        Ok(Mesh {
            data: MeshData::new(mesh),
        })
    }
}

/// Address space [`Mesh::load`] makes sure of, per byte of the file, before loading: the
/// file's bytes, the arrays the reader fills and those of welding and cleaning.
const LOAD_HEADROOM: u64 = 4;

/// Reads the `faces` argument: integers of shape `(m, 3)`, each in `[0, vertex_count)`.
fn faces_arg(obj: &Bound<'_, PyAny>, vertex_count: usize) -> PyResult<Vec<[u32; 3]>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let arr = match obj.cast::<PyUntypedArray>() {
        Ok(a) => a.clone(),
        Err(_) => np
            .call_method1("asarray", (obj,))
            .map_err(|e| PyValueError::new_err(format!("faces must be an integer array: {e}")))?
            .cast_into::<PyUntypedArray>()?,
    };
    let kind = arr.dtype().kind();
    if kind != b'i' && kind != b'u' {
        return Err(PyValueError::new_err(format!(
            "faces must hold integers (vertex indices), got dtype {}",
            arr.dtype().str()?
        )));
    }
    let shape = arr.shape().to_vec();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "faces must have shape (m, 3) (three vertex indices per triangle), got shape {shape:?}"
        )));
    }
    if shape[0] == 0 {
        return Err(PyValueError::new_err(
            "faces is empty: a mesh needs at least one triangle",
        ));
    }
    let mut out = Vec::new();
    out.try_reserve_exact(shape[0])
        .map_err(|_| errors::memory_error(format!("cannot allocate {} triangles", shape[0])))?;
    let out_of_range = |t: usize, k: usize, v: &dyn std::fmt::Display| {
        PyValueError::new_err(format!(
            "faces[{t}, {k}] = {v} is out of range: there are {vertex_count} vertices \
             (indices 0..{vertex_count}, negative indices are refused)"
        ))
    };
    // Unsigned indices are read as uint64 and signed ones as int64 (native byte order either
    // way): before issue 32 every dtype went through int64, and a uint64 index of 2^64 - 1 was
    // reported as -1.
    if kind == b'u' {
        let as_u64 = arr.call_method1("astype", (np.getattr("uint64")?,))?;
        let a = as_u64.cast::<PyArray2<u64>>()?.readonly();
        for (t, row) in a.as_array().rows().into_iter().enumerate() {
            let mut tri = [0u32; 3];
            for (k, &v) in row.iter().enumerate() {
                if v >= vertex_count as u64 {
                    return Err(out_of_range(t, k, &v));
                }
                tri[k] = v as u32;
            }
            out.push(tri);
        }
        return Ok(out);
    }
    let as_i64 = arr.call_method1("astype", (np.getattr("int64")?,))?;
    let a = as_i64.cast::<PyArray2<i64>>()?.readonly();
    for (t, row) in a.as_array().rows().into_iter().enumerate() {
        let mut tri = [0u32; 3];
        for (k, &v) in row.iter().enumerate() {
            if v < 0 || v as u64 >= vertex_count as u64 {
                return Err(out_of_range(t, k, &v));
            }
            tri[k] = v as u32;
        }
        out.push(tri);
    }
    Ok(out)
}

/// The `vertices` argument: floats of shape `(n, 3)`, finite, stored as float32.
fn vertices_arg(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Vec3>> {
    let PointsArg { points, lead } = arrays::points_arg(obj, "vertices", 3)?;
    if lead.len() != 1 {
        return Err(PyValueError::new_err(format!(
            "vertices must have shape (n, 3), got leading dimensions {lead:?}"
        )));
    }
    let view = points.view();
    let mut out = Vec::new();
    out.try_reserve_exact(view.len())
        .map_err(|_| errors::memory_error(format!("cannot allocate {} vertices", view.len())))?;
    for i in 0..view.len() {
        let p = view.get(i);
        let q = p.as_vec3();
        if !q.is_finite() {
            return Err(arrays::non_finite_error("vertices", i, p));
        }
        out.push(q);
    }
    if out.len() > u32::MAX as usize {
        return Err(PyValueError::new_err("more than 2^32 - 1 vertices"));
    }
    Ok(out)
}

impl Mesh {
    /// Signed (`sign: Some`) or unsigned distances of a batch, with closest points and faces
    /// when asked.
    fn distance_batch<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        sign: Option<SignMode>,
        return_closest: bool,
        return_face: bool,
        threads: Option<i64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let threads = run::check_threads(threads)?;
        let arg = arrays::points_arg(points, "points", 3)?;
        let view = arg.points.view();
        let n = view.len();
        let out_d = arrays::new_f32(py, n)?;
        let out_c = return_closest
            .then(|| arrays::new_f32x3(py, n))
            .transpose()?;
        let out_f = return_face.then(|| arrays::new_i64(py, n)).transpose()?;
        // Safety: the arrays were just created here and no Python code sees them until this
        // function returns; the GIL-free work below is their only writer.
        let d = unsafe { out_d.as_slice_mut() }.expect("fresh contiguous array");
        let mut c = out_c
            .as_ref()
            .map(|a| unsafe { a.as_slice_mut() }.expect("fresh contiguous array"));
        let mut f = out_f
            .as_ref()
            .map(|a| unsafe { a.as_slice_mut() }.expect("fresh contiguous array"));
        let data = &self.data;
        let result = run::run(py, threads, n, |cancel| {
            let dist = match sign {
                Some(mode) => data.distance(mode),
                None => data.any_distance(),
            };
            let dist = match dist {
                Ok(d) => d,
                Err(e) => return Ok(Err(e)),
            };
            let plain = !return_closest && !return_face;
            for_chunks(data, view, "points", cancel, |start, pts| {
                let end = start + pts.len();
                if plain && sign.is_some() {
                    // Morton-ordered batch of the distance layer.
                    let ds = dist.signed_distances(pts);
                    for (o, v) in d[start..end].iter_mut().zip(ds) {
                        *o = data.to_model_length(v);
                    }
                    return;
                }
                // Morton-ordered like the batch above (up to 2× per point on shuffled points).
                let res: Vec<(f32, Vec3, u32)> = dist.map_points(pts, |dist, p| {
                    let cp = dist.closest_point(p);
                    let v = match sign {
                        Some(_) => dist.sign_closest(p, &cp),
                        None => cp.distance,
                    };
                    (v, cp.point, cp.triangle)
                });
                for (k, (v, q, t)) in res.into_iter().enumerate() {
                    let i = start + k;
                    d[i] = data.to_model_length(v);
                    if let Some(c) = c.as_deref_mut() {
                        c[3 * i..3 * i + 3].copy_from_slice(&data.to_model(q));
                    }
                    if let Some(f) = f.as_deref_mut() {
                        f[i] = i64::from(t);
                    }
                }
            })
        })?;
        result?;
        let lead = &arg.lead;
        let d_out = arrays::shaped(out_d.into_any(), lead, &[])?;
        if !return_closest && !return_face {
            return Ok(d_out);
        }
        let mut items = vec![d_out];
        if let Some(c) = out_c {
            items.push(arrays::shaped(c.into_any(), lead, &[3])?);
        }
        if let Some(f) = out_f {
            items.push(arrays::shaped(f.into_any(), lead, &[])?);
        }
        Ok(PyTuple::new(py, items)?.into_any())
    }
}

#[pymethods]
impl Mesh {
    /// A mesh from numpy arrays: ``vertices`` of shape ``(n, 3)`` (any float dtype, stored as
    /// float32, model units) and ``faces`` of shape ``(m, 3)`` (any integer dtype, indices into
    /// ``vertices``). Raises ``ValueError`` for a wrong shape or dtype, a NaN or infinite
    /// coordinate, or an index out of range (each naming the element), and for a degenerate
    /// mesh: every vertex the same point (zero extent) or every triangle of zero area (no
    /// surface to measure a signed distance to; ``build`` refuses the same meshes).
    ///
    /// With ``clean=True`` bit-identical vertices are welded and degenerate and duplicate
    /// triangles are dropped, as ``Mesh.load`` does (then ``faces`` and the face indices the
    /// queries return refer to the cleaned triangles). Triangle soups (every triangle with its
    /// own three vertices, as STL stores them) need it for the topology to see shared edges.
    #[new]
    #[pyo3(signature = (vertices, faces, *, clean = false))]
    fn py_new(
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        clean: bool,
    ) -> PyResult<Self> {
        let positions = vertices_arg(vertices)?;
        let triangles = faces_arg(faces, positions.len())?;
        let parts = vec![0; triangles.len()];
        let mesh =
            TriMesh::new(positions, triangles, parts).map_err(|e| errors::array_mesh_error(&e))?;
        let mesh = if clean {
            mesh.cleaned().map_err(|e| errors::array_mesh_error(&e))?.0
        } else {
            mesh
        };
        Mesh::from_trimesh(mesh)
    }

    /// Loads an OBJ, glTF/GLB or STL file (binary or ASCII; the format from the extension,
    /// confirmed by the content), welding bit-identical vertices and dropping degenerate and
    /// duplicate triangles, with the command-line tool's rules: regular files only, at most
    /// 4 GiB and 2^26 triangles, glTF buffers only from the model's own folder. Raises
    /// ``FileNotFoundError`` / ``PermissionError`` / ``IsADirectoryError`` / ``OSError`` when
    /// the file cannot be read and ``sdfmo.MeshError`` (a ``ValueError``) when its content is
    /// not a valid mesh.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Mesh> {
        if let Ok(meta) = std::fs::metadata(&path) {
            if meta.is_file() {
                run::ensure_headroom(
                    meta.len().saturating_mul(LOAD_HEADROOM),
                    &format!("loading {}", path.display()),
                )?;
            }
        }
        let loaded = py
            .detach(|| mesh::load_mesh(&path))
            .map_err(|e| errors::mesh_error(&e))?;
        Mesh::from_trimesh(loaded.mesh)
    }

    /// The vertices, float32 of shape ``(n, 3)``, model units (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        arrays::rows(py, self.data.mesh.positions().iter().map(|p| p.to_array()))
    }

    /// The triangles, int64 of shape ``(m, 3)``: indices into ``vertices`` (a copy).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        arrays::rows(
            py,
            self.data.mesh.triangles().iter().map(|t| t.map(i64::from)),
        )
    }

    /// The axis-aligned bounding box, float32 of shape ``(2, 3)``: ``[min, max]``, model units.
    #[getter]
    fn bounds<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        let b = self.data.mesh.bounds();
        arrays::rows(py, [b.min.to_array(), b.max.to_array()])
    }

    /// Whether every edge has exactly two triangles (no boundary, no non-manifold edge).
    #[getter]
    fn is_watertight(&self, py: Python<'_>) -> bool {
        py.detach(|| self.data.topology().watertight)
    }

    /// Number of connected components (triangles connected through shared edges).
    #[getter]
    fn component_count(&self, py: Python<'_>) -> usize {
        py.detach(|| self.data.topology().component_count)
    }

    /// Number of vertices.
    #[getter]
    fn vertex_count(&self) -> usize {
        self.data.mesh.vertex_count()
    }

    /// Number of triangles.
    #[getter]
    fn face_count(&self) -> usize {
        self.data.mesh.triangle_count()
    }

    /// The sign method ``sign="auto"`` uses on this mesh: ``"pseudonormal"`` for a watertight,
    /// consistently oriented mesh, ``"winding"`` (generalised winding number) otherwise.
    #[getter]
    fn auto_sign(&self, py: Python<'_>) -> PyResult<&'static str> {
        let data = &self.data;
        let d = py.detach(|| data.distance(SignMode::Auto))?;
        Ok(sign_name(d.sign_mode()))
    }

    fn __repr__(&self) -> String {
        let b = self.data.mesh.bounds();
        format!(
            "sdfmo.Mesh({} vertices, {} faces, bounds {:?}..{:?})",
            self.data.mesh.vertex_count(),
            self.data.mesh.triangle_count(),
            b.min.to_array(),
            b.max.to_array()
        )
    }

    /// Exact signed distance from each point to the mesh, negative inside, in model units.
    ///
    /// ``points``: shape ``(..., 3)``, any float dtype, C or Fortran order (float32 and
    /// float64 arrays are read in place, not copied). Returns float32 of shape ``(...)``; with
    /// ``return_closest`` also the closest points (float32, ``(..., 3)``), with
    /// ``return_face`` also the index of the closest triangle (int64, ``(...)``), as a tuple
    /// in that order.
    ///
    /// ``sign``: ``"auto"`` (pseudo-normals on a watertight, consistently oriented mesh, the
    /// generalised winding number otherwise), ``"pseudonormal"`` (angle-weighted
    /// pseudo-normal of the closest feature; exact for closed manifolds) or ``"winding"``
    /// (winding number > 1/2 is inside; robust on open, non-manifold and self-intersecting
    /// meshes). ``threads``: worker threads (``None``: all cores; more than the cores available
    /// is clamped to them); the values are the same for any count. Releases the GIL; Ctrl-C raises ``KeyboardInterrupt``. A NaN or infinite
    /// point is a ``ValueError`` naming its index.
    #[pyo3(signature = (points, *, sign = "auto", return_closest = false, return_face = false, threads = None))]
    fn signed_distance<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        sign: &str,
        return_closest: bool,
        return_face: bool,
        threads: Option<i64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mode = sign_arg(sign)?;
        self.distance_batch(py, points, Some(mode), return_closest, return_face, threads)
    }

    /// Exact distance from each point to the nearest point of the mesh (never negative), in
    /// model units. Arguments and results as ``signed_distance``.
    #[pyo3(signature = (points, *, return_closest = false, return_face = false, threads = None))]
    fn unsigned_distance<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        return_closest: bool,
        return_face: bool,
        threads: Option<i64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.distance_batch(py, points, None, return_closest, return_face, threads)
    }

    /// Generalised winding number of the mesh at each point (Jacobson et al. 2013, with the
    /// hierarchical approximation of Barill et al. 2018): about 1 inside a closed outward
    /// surface, 0 outside, fractional near the holes of an open one. float32 of shape
    /// ``(...)`` for points of shape ``(..., 3)``.
    #[pyo3(signature = (points, *, threads = None))]
    fn winding_number<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<i64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let data = &self.data;
        arrays::f32_per_point(py, points, threads, |view, w, cancel| {
            let dist = match data.any_distance() {
                Ok(d) => d,
                Err(e) => return Ok(Err(e)),
            };
            for_chunks(data, view, "points", cancel, |start, pts| {
                let ws = dist.map_points(pts, |dist, p| dist.winding_number(p));
                w[start..start + pts.len()].copy_from_slice(&ws);
            })
        })
    }

    /// Whether each point lies inside the mesh: ``signed_distance(points, sign=sign) < 0``
    /// (the same sign decision). bool of shape ``(...)``.
    #[pyo3(signature = (points, *, sign = "auto", threads = None))]
    fn contains<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        sign: &str,
        threads: Option<i64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mode = sign_arg(sign)?;
        let d = self.distance_batch(py, points, Some(mode), false, false, threads)?;
        d.call_method1("__lt__", (0.0f32,))
    }

    /// First hit of each ray ``origin + t * direction`` (t >= 0) on the mesh, with the
    /// watertight ray-triangle test (a ray through an edge or a vertex never slips through).
    /// ``origins`` and ``directions``: shape ``(..., 3)``, the same shape, model units; the
    /// directions need not be unit length (t is in units of the direction) but must be
    /// non-zero. Returns ``t`` (float32, ``inf`` on a miss) and ``face`` (int64, -1 on a miss).
    #[pyo3(signature = (origins, directions, *, t_max = f64::INFINITY, threads = None))]
    fn ray_intersect<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        t_max: f64,
        threads: Option<i64>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let threads = run::check_threads(threads)?;
        if t_max.is_nan() || t_max < 0.0 {
            return Err(PyValueError::new_err(format!(
                "t_max must be >= 0 (inf for no limit), got {t_max}"
            )));
        }
        let o = arrays::points_arg(origins, "origins", 3)?;
        let d = arrays::points_arg(directions, "directions", 3)?;
        if o.lead != d.lead {
            return Err(PyValueError::new_err(format!(
                "origins and directions must have the same shape, got {:?} and {:?}",
                o.lead, d.lead
            )));
        }
        let (ov, dv) = (o.points.view(), d.points.view());
        let n = ov.len();
        for i in 0..n {
            let v = dv.get(i);
            if !v.is_finite() {
                return Err(arrays::non_finite_error("directions", i, v));
            }
            if v.as_vec3() == Vec3::ZERO {
                return Err(PyValueError::new_err(format!(
                    "directions[{i}] is zero: a ray needs a direction"
                )));
            }
        }
        let out_t = arrays::new_f32(py, n)?;
        let out_f = arrays::new_i64(py, n)?;
        // Safety: as in `distance_batch`.
        let ts = unsafe { out_t.as_slice_mut() }.expect("fresh contiguous array");
        let fs = unsafe { out_f.as_slice_mut() }.expect("fresh contiguous array");
        let data = &self.data;
        let scale = f64::from(data.norm.scale);
        let t_max_n = (t_max * scale).min(f64::from(f32::MAX)) as f32;
        let t_max_n = if t_max.is_infinite() {
            f32::INFINITY
        } else {
            t_max_n
        };
        let result = run::run(py, threads, n, |cancel| {
            let dist = match data.any_distance() {
                Ok(d) => d,
                Err(e) => return Ok(Err(e)),
            };
            for_chunks(data, ov, "origins", cancel, |start, pts| {
                let end = start + pts.len();
                ts[start..end]
                    .par_iter_mut()
                    .zip(fs[start..end].par_iter_mut())
                    .enumerate()
                    .with_min_len(64)
                    .for_each(|(k, (t, f))| {
                        let dir = dv.get(start + k).as_vec3();
                        match dist.ray_hit(pts[k], dir, 0.0, t_max_n) {
                            Some(h) => {
                                *t = (f64::from(h.t) / scale) as f32;
                                *f = i64::from(h.triangle);
                            }
                            None => {
                                *t = f32::INFINITY;
                                *f = -1;
                            }
                        }
                    });
            })
        })?;
        result?;
        let t = arrays::shaped(out_t.into_any(), &o.lead, &[])?;
        let f = arrays::shaped(out_f.into_any(), &o.lead, &[])?;
        PyTuple::new(py, [t, f])
    }

    /// Builds the sparse octree of trilinear signed-distance voxels, as ``sdfmo build`` does:
    /// ``method`` ``"multi"`` (the multi-octree: up to ``max_voxels`` voxels per leaf, one per
    /// component) or ``"svo"`` (the classic sparse voxel octree); leaves at ``depth`` (1..=16;
    /// edge 2/2^depth of the normalised root cube); corners quantised to ``bits`` (8 or 16).
    /// ``fit_corners``: the shared corner values fitted to the surface instead of the exact
    /// distances (``sdfmo build --fit-corners``: the same leaves, voxels and bytes, about +1 dB
    /// at depth 9, a build 1.5–3.5× as long). ``coarsest``: levels of detail ``coarsest..=depth``
    /// (``sdfmo build --lod --coarsest``; ``levels``, ``save`` and ``render(lod=...)`` see them
    /// all, ``distance`` and ``stats`` the finest). The output is the same for any ``threads``. The build is refused with ``MemoryError``
    /// when its predicted peak memory exceeds ``max_memory`` bytes (default: half the physical
    /// memory, the command-line tool's default). Releases the GIL; Ctrl-C stops it between
    /// phases and chunks of corners and leaves (the subdivision phase runs to its end).
    #[pyo3(signature = (
        depth, *, method = "multi", max_voxels = 8, bits = 8, sign = "auto",
        fit_corners = false, coarsest = None, threads = None, max_memory = None
    ))]
    fn build(
        slf: &Bound<'_, Self>,
        depth: i64,
        method: &str,
        max_voxels: i64,
        bits: i64,
        sign: &str,
        fit_corners: bool,
        coarsest: Option<i64>,
        threads: Option<i64>,
        max_memory: Option<u64>,
    ) -> PyResult<Octree> {
        let threads = run::check_threads(threads)?;
        let depth = u8::try_from(depth)
            .ok()
            .filter(|d| (build::MIN_DEPTH..=sdf_multioctree::format::MAX_DEPTH).contains(d))
            .ok_or_else(|| {
                PyValueError::new_err(format!(
                    "depth must be in {}..={}, got {depth}",
                    build::MIN_DEPTH,
                    sdf_multioctree::format::MAX_DEPTH
                ))
            })?;
        let coarsest = coarsest
            .map(|c| {
                u8::try_from(c)
                    .ok()
                    .filter(|c| (build::MIN_DEPTH..=depth).contains(c))
                    .ok_or_else(|| {
                        PyValueError::new_err(format!(
                            "coarsest must be in {}..={depth} (the depth), got {c}",
                            build::MIN_DEPTH
                        ))
                    })
            })
            .transpose()?;
        let method = match method {
            "multi" => Method::Multi {
                max_voxels: u8::try_from(max_voxels)
                    .ok()
                    .filter(|&m| m >= 1)
                    .ok_or_else(|| {
                        PyValueError::new_err(format!(
                            "max_voxels must be in 1..=255, got {max_voxels}"
                        ))
                    })?,
            },
            "svo" => Method::Svo,
            other => return Err(errors::choice_error("method", &["multi", "svo"], other)),
        };
        let bits = match bits {
            8 => ValueBits::Eight,
            16 => ValueBits::Sixteen,
            other => {
                return Err(PyValueError::new_err(format!(
                    "bits must be 8 or 16, got {other}"
                )))
            }
        };
        // The builder runs on the caller's pool: ours (`run::run`, cancellation and reuse).
        let settings = BuildSettings::new(depth, method)
            .with_bits(bits)
            .with_margin(DEFAULT_MARGIN)
            .with_sign(sign_arg(sign)?)
            .with_fit_corners(fit_corners);
        let budget = max_memory.or_else(build::default_memory_budget);
        let (py, mesh) = (slf.py(), &slf.get().data.mesh);
        // The build's predicted peak must also be allocatable now (an address-space limit below
        // the budget): a MemoryError here, not an abort halfway through the build.
        let estimate = build::estimate_memory(mesh, &settings).bytes;
        if budget.is_none_or(|b| estimate <= b) {
            run::ensure_headroom(estimate, &format!("a depth-{depth} build"))?;
        }
        let built = run::run(py, threads, usize::MAX, |cancel| {
            let stop = || cancel.is_set();
            let request = build::BuildRequest::new(mesh, settings)
                .memory_budget(budget)
                .cancel(&stop);
            let built = match coarsest {
                None => request
                    .octree()
                    .map(|(octree, stats)| Octree::new(octree, Some(stats))),
                Some(c) => request
                    .levels(c)
                    .map(|(levels, stats)| Octree::from_levels(levels, stats.last().cloned())),
            };
            match built {
                Err(build::BuildError::Cancelled) => Err(Cancelled),
                r => Ok(r),
            }
        })?;
        built.map_err(|e| errors::build_error(&e))
    }

    /// Ray traces the mesh as ``sdfmo render-mesh`` does (the reference image of the paper's
    /// protocol): normalised exactly as the builder normalises it, so the images line up with
    /// ``Octree.render``'s, face normals, the same camera and shading. Returns uint8 of shape
    /// ``(height, width, 3)``, numpy's order (``render(640, 480).shape == (480, 640, 3)``;
    /// ``height`` defaults to ``width``). ``options``: a ``RenderOptions`` (the camera, mode
    /// and shading), or its keywords given here; see ``Octree.render``.
    #[pyo3(signature = (width = 1024, height = None, *, options = None, threads = None, **kwargs))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: i64,
        height: Option<i64>,
        options: Option<&Bound<'py, RenderOptions>>,
        threads: Option<i64>,
        kwargs: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let call = RenderCall {
            width,
            height,
            options,
            threads,
            kwargs,
        };
        let args = RenderArgs::parse(py, call, &self.data.norm)?;
        let data = &self.data;
        args.render(py, |settings, camera, cancel| {
            let dist = data.distance(SignMode::Auto)?;
            Ok(
                sdf_multioctree::render::RenderRequest::new(&MeshScene(dist), camera, settings)
                    .cancel(cancel)
                    .render(),
            )
        })
    }
}
