//! `sdfmo.Octree`: a packed multi-voxel SDF octree (the `.smo` file).

use std::path::PathBuf;

use glam::DVec3;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};
use rayon::prelude::*;
use sdf_multioctree::build::BuildStats;
use sdf_multioctree::format::compressed::{compress_with_level, is_compressed};
use sdf_multioctree::format::{
    is_brick_levels, is_v3, FormatError, LodOctree, PackedOctree, SmoFile, SmoLevel, SmoPrefix,
    ValueBits, FILE_EXTENSION, MAX_DEPTH, MAX_FILE_SIZE,
};
use sdf_multioctree::io::Naming;
use sdf_multioctree::render::LevelRequest;
use sdf_multioctree::OctreeRef as _;
use sdf_multioctree::{Device, Renderer};

use crate::arrays;
use crate::errors;
use crate::render::{RenderArgs, RenderCall, RenderOptions};

/// A sparse octree of trilinear signed-distance voxels (the ``.smo`` format), as built by
/// ``Mesh.build`` or loaded by ``Octree.load``; a loaded file may have levels of detail
/// (``sdfmo build --lod``), all of them or those of a prefix cut where a level ends.
///
/// The octree lives in the normalised frame of its mesh (the root cube [-1, 1]^3); the
/// transform is stored in the file, and ``distance`` takes and returns model units.
#[pyclass(module = "sdfmo", frozen)]
pub struct Octree {
    /// The levels held (one for a file without levels) and those of the whole file.
    data: SmoPrefix,
    stats: Option<BuildStats>,
}

impl Octree {
    /// Wraps an octree and, when it was just built, the builder's statistics.
    pub fn new(octree: PackedOctree, stats: Option<BuildStats>) -> Octree {
        Octree::of_file(SmoFile::Octree(octree), stats)
    }

    /// Wraps levels of detail just built and the statistics of their finest level.
    pub fn from_levels(levels: LodOctree, finest: Option<BuildStats>) -> Octree {
        Octree::of_file(SmoFile::Levels(levels), finest)
    }

    fn of_file(file: SmoFile, stats: Option<BuildStats>) -> Octree {
        let declared = file.level_range();
        Octree {
            data: SmoPrefix { file, declared },
            stats,
        }
    }

    /// A loaded file, whole or a prefix cut where a level ends (a 3.0 file kept as its bricks,
    /// which the queries and the renderer read in place).
    fn loaded(data: SmoPrefix) -> Octree {
        Octree { data, stats: None }
    }

    /// The finest level held: what `distance`, `depth` and `stats` describe.
    fn finest(&self) -> SmoLevel<'_> {
        self.data.file.finest()
    }

    /// The file of the levels held (a prefix's levels as a file of their own).
    fn file_bytes(&self) -> std::borrow::Cow<'_, [u8]> {
        self.data.file.to_bytes()
    }
}

/// The levels `coarsest..=finest` as a Python list of ints (a `Vec<u8>` would become `bytes`).
fn level_list((coarsest, finest): (u8, u8)) -> Vec<u32> {
    (coarsest..=finest).map(u32::from).collect()
}

/// `lod=` and `pixel_error=` of `Octree.render` (the options `Mesh.render` lacks): the
/// `LevelRequest` of `sdfmo render --lod` / `--pixel-error`.
fn level_request(lod: Option<i64>, pixel_error: Option<f64>) -> PyResult<LevelRequest> {
    match (lod, pixel_error) {
        (Some(_), Some(_)) => Err(PyValueError::new_err(
            "lod and pixel_error exclude each other (one level, or each ray's level by pixel error)",
        )),
        (Some(l), None) => match u8::try_from(l) {
            Ok(l) if l <= MAX_DEPTH => Ok(LevelRequest::Level(l)),
            _ => Err(PyValueError::new_err(format!(
                "lod must be a level in 0..={MAX_DEPTH}, got {l}"
            ))),
        },
        // The range check (finite, > 0) is `LevelRequest::scene`'s.
        (None, Some(e)) => Ok(LevelRequest::PixelError(e as f32)),
        (None, None) => Ok(LevelRequest::Finest),
    }
}

/// The GPU renderer of `Octree.render(device="gpu")`, opened at the first such call and kept
/// (an adapter and a compiled kernel take far longer than a small frame); a failed opening is
/// not kept, so a later call tries again.
static GPU: std::sync::Mutex<Option<Renderer>> = std::sync::Mutex::new(None);

#[pymethods]
impl Octree {
    /// Loads and validates a ``.smo`` file (header, sizes, checksum, every node and voxel):
    /// one octree, or levels of detail (``sdfmo build --lod``), whole or cut where a level ends
    /// (a download in progress; ``levels`` and ``file_levels`` say what it holds). A 3.0 file
    /// (``sdfmo build --format 3``, plain or compressed) is kept as its bricks, which
    /// ``distance`` and ``render`` read in place (a third to a half of the 1.x octree's
    /// memory): the same distances and images as the 1.x file; ``to_bytes`` and ``save`` give
    /// the 3.0 file (decompressed), ``stats`` the same counts as the 1.x octree's. Raises
    /// ``FileNotFoundError`` / ``PermissionError`` / ``IsADirectoryError`` / ``OSError`` when
    /// the file cannot be read and ``sdfmo.FormatError`` when its bytes are not a valid octree
    /// (a file cut inside a level included).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Octree> {
        let data = py
            .detach(|| SmoFile::load_prefix(&path, MAX_FILE_SIZE))
            .map_err(|e| errors::format_error(&e))?;
        Ok(Octree::loaded(data))
    }

    /// An octree from the bytes of a ``.smo`` file, validated as ``Octree.load`` validates a
    /// file (``sdfmo.FormatError`` when they are not a valid octree). ``data``: any bytes-like
    /// object (``bytes``, ``bytearray``, ``memoryview``, a C-contiguous numpy array such as a
    /// uint8 one), read in place; a writable one (``bytearray``, an array) is copied first, so
    /// that no other thread can change the bytes while they are validated. ``TypeError`` for
    /// anything else.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &Bound<'_, PyAny>) -> PyResult<Octree> {
        let data = arrays::bytes_arg(data, "data")?;
        let data = match data {
            // A 1.x file keeps the copy as its buffer (no second one).
            arrays::BytesArg::Copied(v)
                if !SmoFile::has_levels(&v)
                    && !is_compressed(&v)
                    && !is_v3(&v)
                    && !is_brick_levels(&v) =>
            {
                py.detach(|| PackedOctree::from_vec(v))
                    .map(|o| Octree::new(o, None).data)
            }
            borrowed => {
                let bytes = borrowed.as_slice();
                py.detach(|| SmoFile::from_prefix(bytes))
            }
        }
        .map_err(|e| errors::format_error(&e))?;
        Ok(Octree::loaded(data))
    }

    /// Writes the ``.smo`` file atomically (a temporary file in the same folder, synced, then
    /// renamed): the destination is either the old file or the whole new one. ``path`` must end
    /// in ``.smo`` (any case; ``ValueError`` otherwise, as ``sdfmo build -o`` refuses it). A
    /// destination that is a directory, a device or a FIFO is refused (``OSError``). A file
    /// with levels is written with the levels held (a prefix's as the file of those levels).
    /// ``compress``: a zstd level 1..=22 writes the compressed container (``sdfmo build
    /// --compress``: about a tenth of the bytes, read back by ``Octree.load`` as the same
    /// octree); ``ValueError`` for another level.
    #[pyo3(signature = (path, *, compress = None))]
    fn save(&self, py: Python<'_>, path: PathBuf, compress: Option<i32>) -> PyResult<()> {
        if let Some(level) = compress.filter(|l| !(1..=22).contains(l)) {
            return Err(PyValueError::new_err(format!(
                "compress must be a zstd level 1..=22, got {level}"
            )));
        }
        sdf_multioctree::io::check_output(&path, "path", &[FILE_EXTENSION], Naming::Given)
            .map_err(|e| errors::io_error(&e))?;
        let Some(level) = compress else {
            return py
                .detach(|| match &self.data.file {
                    SmoFile::Octree(o) => o.save(&path),
                    SmoFile::Levels(l) => l.save(&path),
                    SmoFile::Bricks(b) => sdf_multioctree::io::write_atomic(&path, b.as_bytes())
                        .map_err(FormatError::from),
                })
                .map_err(|e| errors::format_error(&e));
        };
        let bytes = self.file_bytes();
        py.detach(|| {
            let packed = compress_with_level(&bytes, level)?;
            sdf_multioctree::io::write_atomic(&path, packed).map_err(FormatError::from)
        })
        .map_err(|e| errors::format_error(&e))
    }

    /// The bytes of the ``.smo`` file (what ``save`` writes).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.file_bytes())
    }

    /// Depth of the leaves (edge 2/2^depth in the normalised frame): of a file with levels,
    /// the finest level held.
    #[getter]
    fn depth(&self) -> u8 {
        self.finest().depth()
    }

    /// Edge of a leaf cell in model units: ``2 / (2**depth * scale)`` (the root cube's edge,
    /// 2 in the normalised frame, halved ``depth`` times). ``distance`` is NaN farther than
    /// 1.78 of it from the surface. Of a file with levels: the finest level held's.
    #[getter]
    fn cell_size(&self) -> f64 {
        let meta = self.finest().meta();
        f64::from(sdf_multioctree::format::cell_size(meta.depth)) / f64::from(meta.scale)
    }

    /// The levels held, coarsest first: ``[depth]`` without levels of detail; of a file cut
    /// where a level ends, those before the cut. ``render(lod=...)`` draws one of them.
    #[getter]
    fn levels(&self) -> Vec<u32> {
        level_list(self.data.held())
    }

    /// The levels of the whole file, coarsest first: ``levels`` and, when the data is a
    /// prefix of the file, the levels it lacks after them.
    #[getter]
    fn file_levels(&self) -> Vec<u32> {
        level_list(self.data.declared)
    }

    /// Size of the ``.smo`` file in bytes (what ``save`` writes).
    #[getter]
    fn nbytes(&self) -> usize {
        match &self.data.file {
            SmoFile::Octree(o) => o.byte_size(),
            SmoFile::Levels(l) => l.byte_size() as usize,
            SmoFile::Bricks(b) => b.as_bytes().len(),
        }
    }

    /// stats -> dict
    ///
    /// ``depth``, ``bits``, ``nodes``, ``leaves``, ``voxels``, ``surface_voxels``, ``bytes``,
    /// ``center`` and ``scale`` (the transform: normalised = (model - center) * scale) of any
    /// octree (of a file with levels: of the finest level held, ``bytes`` that level's);
    /// for one built in this process also the builder's ``build_ms``, ``phases`` (a
    /// list of (name, ms)), ``voxels_per_leaf`` (histogram: index = voxel count) and
    /// ``cap_hits`` (leaves whose components exceeded ``max_voxels``), as ``sdfmo build
    /// --json`` prints them.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let o = self.finest();
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
        let o = self.finest();
        let (c, f) = self.data.held();
        let (dc, df) = self.data.declared;
        let levels = if !self.data.is_complete() && c == f {
            format!("level {c} of {dc}-{df}, ")
        } else if !self.data.is_complete() {
            format!("levels {c}-{f} of {dc}-{df}, ")
        } else if c != f {
            format!("levels {c}-{f}, ")
        } else {
            String::new()
        };
        format!(
            "sdfmo.Octree({levels}depth {}, {} leaves, {} voxels, {} bytes)",
            o.depth(),
            o.leaf_count(),
            o.voxel_count(),
            self.nbytes()
        )
    }

    /// The signed distance the octree stores at each point (model units in and out): the
    /// trilinear value of the leaf's voxels (their minimum in a multi-voxel leaf; surface
    /// voxels unsigned), as the ray tracer sees it. float32 of shape ``(...)`` for points of
    /// shape ``(..., 3)``.
    ///
    /// ``NaN`` where the point lies outside the root cube or in a leaf cell (edge
    /// ``cell_size``) that is not stored. The builder stores only cells that the surface
    /// touches within one corner quantisation step and whose stored field crosses zero, so the
    /// field is a narrow band: **every point farther than 1.78 × cell_size from the surface is
    /// NaN** (the cell's diagonal, √3, grown by a quantisation step on each side: √3 · (1 +
    /// 2√3/127) = 1.7793 at 8 bits, 1.7324 at 16). Nearer, a point is finite where its cell is
    /// stored: measured on the teapot at depths 6 and 7, 99.7 % of the points within
    /// 0.1 × cell_size of the surface, 85 % at 0.25-0.5, 31-33 % at 0.75-1, 1 % at 1.25-1.5
    /// and none beyond 1.7; on the CAD part abc5 86 % (depth 6) and 94 % (depth 7) of the
    /// surface's own points (cells the surface crosses whose stored field does not). Test for
    /// NaN (``numpy.isnan``) and fall back on ``Mesh.signed_distance`` where the band ends.
    /// Of a file with levels, the finest level held.
    #[pyo3(signature = (points, *, threads = None))]
    fn distance<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<i64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let frame = sdf_multioctree::octree_frame(self.finest());
        let octree = self.finest();
        arrays::f32_per_point(py, points, threads, |view, d, cancel| {
            let normalized = |_, p: DVec3| Ok(frame.point_to_normalized(p));
            arrays::for_checked_chunks(view, "points", cancel, normalized, |start, pts| {
                d[start..start + pts.len()]
                    .par_iter_mut()
                    .zip(pts)
                    .with_min_len(256)
                    .for_each(|(o, &p)| {
                        *o = match octree.stored_distance(p) {
                            Some(d) => frame.length_to_model(d),
                            None => f32::NAN,
                        };
                    });
            })
        })
    }

    /// Ray traces the octree as ``sdfmo render`` does; returns uint8 of shape
    /// ``(height, width, 3)``, numpy's order (``render(640, 480).shape == (480, 640, 3)``;
    /// ``height`` defaults to ``width``).
    ///
    /// ``options``: a ``RenderOptions`` (the camera, ``mode``, ``shadows``, ``ao``; the
    /// primary way), or its keywords given here (``render(64, mode="mask")``), not both. The
    /// image is the same for any ``threads``. Releases the GIL; Ctrl-C raises
    /// ``KeyboardInterrupt`` (checked before each tile of 32 x 32 pixels).
    ///
    /// Levels of detail, as ``sdfmo render --lod`` / ``--pixel-error``: by default the finest
    /// level held is drawn; ``lod`` draws one level of ``levels`` (another is a ``ValueError``
    /// naming those held); ``pixel_error`` (pixels, > 0; a file with levels only) traces each
    /// ray at the coarsest level held whose voxels project to at most that many pixels at its
    /// hit distance, for this camera's field of view and height. Not both.
    ///
    /// ``device="gpu"``: the same image traced by the GPU kernel, as ``sdfmo render --device
    /// gpu`` (the first adapter wgpu finds; ``RuntimeError`` naming the cause when there is
    /// none): primary rays only (``shadows``, ``ao`` and ``threads`` are a ``ValueError``),
    /// hits within a few ulps of the CPU's, levels and ``pixel_error`` included.
    #[pyo3(signature = (
        width = 1024, height = None, *, options = None, lod = None, pixel_error = None,
        device = "cpu", threads = None, **kwargs
    ))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: i64,
        height: Option<i64>,
        options: Option<&Bound<'py, RenderOptions>>,
        lod: Option<i64>,
        pixel_error: Option<f64>,
        device: &str,
        threads: Option<i64>,
        kwargs: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let request = level_request(lod, pixel_error)?;
        let device = errors::choice(
            "device",
            device,
            &[("cpu", Device::Cpu), ("gpu", Device::Gpu)],
        )?;
        let call = RenderCall {
            width,
            height,
            options,
            threads,
            kwargs,
        };
        let args = RenderArgs::parse(py, call, &sdf_multioctree::octree_frame(self.finest()))?;
        if device == Device::Gpu && args.threads().is_some() {
            return Err(PyValueError::new_err(
                "threads applies to device=\"cpu\" only (the GPU renders a frame in one dispatch)",
            ));
        }
        let file = &self.data.file;
        args.render(py, |settings, camera, cancel| {
            let render = |renderer: &mut Renderer| {
                renderer
                    .prepare(file, request)?
                    .render_with(camera, settings, None, Some(cancel))
            };
            let result = match device {
                Device::Cpu => Renderer::new(Device::Cpu).and_then(|mut r| render(&mut r)),
                Device::Gpu => {
                    let mut slot = GPU.lock().unwrap_or_else(|e| e.into_inner());
                    let mut renderer = match slot.take() {
                        Some(r) => r,
                        None => Renderer::new(Device::Gpu).map_err(|e| errors::facade_error(&e))?,
                    };
                    let result = render(&mut renderer);
                    *slot = Some(renderer);
                    result
                }
            };
            match result {
                Ok(r) => Ok(Ok(r)),
                Err(sdf_multioctree::Error::Render(e)) => Ok(Err(e)),
                Err(e) => Err(errors::facade_error(&e)),
            }
        })
    }
}
