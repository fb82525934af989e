//! `sdfmo.Octree`: a packed multi-voxel SDF octree (the `.smo` file).

use std::path::PathBuf;

use glam::Vec3;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};
use rayon::prelude::*;
use sdf_multioctree::build::BuildStats;
use sdf_multioctree::format::{PackedOctree, ValueBits};
use sdf_multioctree::render::OctreeScene;
use sdf_multioctree::trace::distance_at;

use crate::arrays;
use crate::errors;
use crate::render::{RenderArgs, RenderOptions};
use crate::run::{self, Cancelled};

/// A sparse octree of trilinear signed-distance voxels (the ``.smo`` format), as built by
/// ``Mesh.build`` or loaded by ``Octree.load``.
///
/// The octree lives in the normalised frame of its mesh (the root cube [-1, 1]^3); the
/// transform is stored in the file, and ``distance`` takes and returns model units.
#[pyclass(module = "sdfmo", frozen)]
pub struct Octree {
    octree: PackedOctree,
    stats: Option<BuildStats>,
}

impl Octree {
    /// Wraps an octree and, when it was just built, the builder's statistics.
    pub fn new(octree: PackedOctree, stats: Option<BuildStats>) -> Octree {
        Octree { octree, stats }
    }
}

#[pymethods]
impl Octree {
    /// Octree.load(path) -> Octree
    ///
    /// Loads and validates a ``.smo`` file (header, sizes, checksum, every node and voxel).
    /// Raises ``FileNotFoundError`` / ``PermissionError`` / ``IsADirectoryError`` /
    /// ``OSError`` when the file cannot be read and ``sdfmo.FormatError`` when its bytes are
    /// not a valid octree.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Octree> {
        let octree = py
            .detach(|| PackedOctree::load(&path))
            .map_err(|e| errors::format_error(&e))?;
        Ok(Octree::new(octree, None))
    }

    /// Octree.from_bytes(data) -> Octree
    ///
    /// An octree from the bytes of a ``.smo`` file, validated as ``Octree.load`` validates a
    /// file (``sdfmo.FormatError`` when they are not a valid octree).
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Octree> {
        let octree = py
            .detach(|| PackedOctree::from_bytes(data))
            .map_err(|e| errors::format_error(&e))?;
        Ok(Octree::new(octree, None))
    }

    /// save(path)
    ///
    /// Writes the ``.smo`` file atomically (a temporary file in the same folder, synced, then
    /// renamed): the destination is either the old file or the whole new one. A destination
    /// that is a directory, a device or a FIFO is refused (``OSError``).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| self.octree.save(&path))
            .map_err(|e| errors::format_error(&e))
    }

    /// to_bytes() -> bytes
    ///
    /// The bytes of the ``.smo`` file (what ``save`` writes).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, self.octree.as_bytes())
    }

    /// Depth of the leaves (edge 2/2^depth in the normalised frame).
    #[getter]
    fn depth(&self) -> u8 {
        self.octree.depth()
    }

    /// Size of the ``.smo`` file in bytes.
    #[getter]
    fn nbytes(&self) -> usize {
        self.octree.byte_size()
    }

    /// stats -> dict
    ///
    /// ``depth``, ``bits``, ``nodes``, ``leaves``, ``voxels``, ``surface_voxels``, ``bytes``,
    /// ``center`` and ``scale`` (the transform: normalised = (model - center) * scale) of any
    /// octree; for one built in this process also the builder's ``build_ms``, ``phases`` (a
    /// list of (name, ms)), ``voxels_per_leaf`` (histogram: index = voxel count) and
    /// ``cap_hits`` (leaves whose components exceeded ``max_voxels``), as ``sdfmo build
    /// --json`` prints them.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let o = &self.octree;
        let d = PyDict::new(py);
        let meta = o.meta();
        d.set_item("depth", o.depth())?;
        d.set_item(
            "bits",
            match meta.bits {
                ValueBits::Eight => 8,
                ValueBits::Sixteen => 16,
            },
        )?;
        d.set_item("nodes", o.node_count())?;
        d.set_item("leaves", o.leaf_count())?;
        d.set_item("voxels", o.voxel_count())?;
        d.set_item("surface_voxels", o.surface_voxel_count())?;
        d.set_item("bytes", o.byte_size())?;
        d.set_item("center", meta.center.to_array().to_vec())?;
        d.set_item("scale", meta.scale)?;
        if let Some(s) = &self.stats {
            d.set_item("build_ms", s.build_ms)?;
            let phases = PyList::empty(py);
            for (name, ms) in &s.phases {
                phases.append((name.as_str(), *ms))?;
            }
            d.set_item("phases", phases)?;
            d.set_item("voxels_per_leaf", s.voxels_per_leaf.clone())?;
            d.set_item("cap_hits", s.cap_hits)?;
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "sdfmo.Octree(depth {}, {} leaves, {} voxels, {} bytes)",
            self.octree.depth(),
            self.octree.leaf_count(),
            self.octree.voxel_count(),
            self.octree.byte_size()
        )
    }

    /// distance(points, *, threads=None)
    ///
    /// The signed distance the octree stores at each point (model units in and out): the
    /// trilinear value of the leaf's voxels (their minimum in a multi-voxel leaf; surface
    /// voxels unsigned), as the ray tracer sees it. ``NaN`` where the point lies outside the
    /// root cube or in a cell with no stored leaf (the builder stores only the cells the
    /// surface passes through). float32 of shape ``(...)`` for points of shape ``(..., 3)``.
    #[pyo3(signature = (points, *, threads = None))]
    fn distance<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<i64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let frame = sdf_multioctree::octree_frame(&self.octree);
        let octree = &self.octree;
        arrays::f32_per_point(py, points, threads, |view, d, cancel| {
            let n = view.len();
            let chunk = run::chunk_len();
            for start in (0..n).step_by(chunk) {
                if cancel.is_set() {
                    return Err(Cancelled);
                }
                let end = (start + chunk).min(n);
                for i in start..end {
                    let p = view.get(i);
                    if !p.is_finite() {
                        return Ok(Err(arrays::non_finite_error("points", i, p)));
                    }
                }
                d[start..end]
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(256)
                    .for_each(|(k, o)| {
                        let p: Vec3 = frame.point_to_normalized(view.get(start + k));
                        *o = match distance_at(octree, p) {
                            Some(s) => frame.length_to_model(s.distance),
                            None => f32::NAN,
                        };
                    });
            }
            Ok(Ok(()))
        })
    }

    /// render(width=1024, height=None, *, mode="lambert", view=0, eye=None, target=None, fov=None, frame="model", shadows=False, ao=0, threads=None)
    ///
    /// Ray traces the octree as ``sdfmo render`` does; returns uint8 of shape
    /// ``(height, width, 3)`` (``height`` defaults to ``width``).
    ///
    /// The camera is the command-line tool's: one of the paper's four views (``view`` 0..3:
    /// eye on a circle of radius 3 in the y = 0 plane of the normalised frame, the root cube
    /// [-1, 1]^3, looking at its origin, 60 degrees vertical field of view), with ``eye``,
    /// ``target`` (3 floats each, **in model units**, the mesh's own coordinates, like every
    /// point this package takes; ``frame="normalized"`` for the root cube's) and ``fov``
    /// (degrees) replacing its parts. ``mode``: ``"lambert"`` (the paper's shading),
    /// ``"mask"``, ``"depth"`` or ``"normal"``; ``shadows`` and ``ao`` (ambient-occlusion
    /// rays per pixel, 0..=1024) apply to lambert only. The image is the same for any
    /// ``threads``. Releases the GIL; Ctrl-C raises ``KeyboardInterrupt`` (checked before each
    /// tile of 32 x 32 pixels).
    #[pyo3(signature = (width = 1024, height = None, **options), text_signature = "($self, width=1024, height=None, *, mode='lambert', view=0, eye=None, target=None, fov=None, frame='model', shadows=False, ao=0, threads=None)")]
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: i64,
        height: Option<i64>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let options = RenderOptions::from_kwargs("render", options)?;
        let args = RenderArgs::parse(
            width,
            height,
            options,
            &sdf_multioctree::octree_frame(&self.octree),
        )?;
        let octree = &self.octree;
        args.render(py, |settings, camera, cancel| {
            Ok(sdf_multioctree::render::render_cancellable(
                &OctreeScene(octree),
                camera,
                settings,
                cancel,
            ))
        })
    }
}
