//! What a front-end asks of the harness ([`SweepOptions`]) and what it gets back to print
//! ([`Outcome`]).

use std::ops::RangeInclusive;
use std::path::PathBuf;

use sdf_multioctree::build::Method;

use crate::error::{HarnessError, Result};
use crate::manifest::Shard;
#[cfg(doc)]
use crate::{error::MergeError, ModelsFailed};

/// A construction method the sweep compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepMethod {
    /// Classic sparse voxel octree: one voxel per leaf (the paper's baseline).
    Svo,
    /// Multi-octree: one voxel per connected component in a leaf, surface voxels.
    Multi,
}

impl SweepMethod {
    /// Every method, in the order the sweep names them.
    pub const ALL: [SweepMethod; 2] = [SweepMethod::Svo, SweepMethod::Multi];

    /// The name used in tables, file names and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SweepMethod::Svo => "svo",
            SweepMethod::Multi => "multi",
        }
    }

    /// The builder's method, with at most `max_voxels` voxels per leaf for the multi-octree.
    pub fn method(self, max_voxels: u8) -> Method {
        match self {
            SweepMethod::Svo => Method::Svo,
            SweepMethod::Multi => Method::Multi { max_voxels },
        }
    }
}

/// Everything one sweep command is given (the `sdfmo sweep` flags of docs/cli.md). Which of
/// the four runs it is follows from the fields, checked in this order: `merge` not empty (merge
/// shard folders), `manifest` (run a shard), `isolated_model` (a shard's model process), else a
/// sweep of `meshes`.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// Mesh files; without any, the built-in demo part.
    pub meshes: Vec<PathBuf>,
    /// Depths, inclusive, within 1..=16.
    pub depths: RangeInclusive<u8>,
    /// Methods, in the order given (a repeated one runs once).
    pub methods: Vec<SweepMethod>,
    /// Image size of each (square) view in pixels.
    pub size: u32,
    /// Most voxels per leaf of the multi-octree, 1..=255.
    pub max_voxels: u8,
    /// Memory budget of each build in bytes (default: the builder's).
    pub max_memory: Option<u64>,
    /// Worker threads for builds and renders (default: all cores).
    pub threads: Option<usize>,
    /// Renders of each view per configuration; the render time is their median.
    pub frames: u16,
    /// One build with levels of detail per model and method, every level scored.
    pub levels: bool,
    /// Rows from another producer merged into the tables, plots and page.
    pub extra_rows: Vec<PathBuf>,
    /// Output directory (created if missing).
    pub output: PathBuf,
    /// Print one JSON object instead of the human summary.
    pub json: bool,
    /// Sweep the models this manifest lists, each in its own process, with a ledger.
    pub manifest: Option<PathBuf>,
    /// With `manifest`: refuse paths outside the manifest's folder.
    pub confine: bool,
    /// With `manifest`: the shard to run (default: from the environment, else the whole).
    pub shard: Option<Shard>,
    /// With `manifest`: wall-time limit of each model in seconds.
    pub model_timeout: Option<f64>,
    /// With `manifest`: run again the models the ledger holds as failed.
    pub retry_failed: bool,
    /// Merge these shard output folders into one dataset report in `output`.
    pub merge: Vec<PathBuf>,
    /// A shard's model process: sweep the one mesh under this model name and print its rows as
    /// one JSON line.
    pub isolated_model: Option<String>,
}

/// What a sweep command leaves for its front-end: the text for stdout, and the error to end
/// with after printing it.
#[derive(Debug)]
pub struct Outcome {
    /// What to print on stdout: the human summary, or one JSON object and a newline.
    pub stdout: String,
    /// The error the command ends with once `stdout` is printed and every file is written: a
    /// shard whose models failed ([`HarnessError::ModelsFailed`] of a [`ModelsFailed`], which
    /// asks for exit code [`crate::EXIT_MODELS_FAILED`]), or a merge with unfinished models
    /// ([`MergeError::Unfinished`]).
    pub error: Option<HarnessError>,
}

impl Outcome {
    /// A human summary.
    pub(crate) fn text(stdout: String) -> Outcome {
        Outcome {
            stdout,
            error: None,
        }
    }

    /// One JSON object on one line.
    pub(crate) fn json(value: &serde_json::Value) -> Result<Outcome> {
        let mut line = serde_json::to_string(value).map_err(|source| HarnessError::Serialise {
            what: "the JSON output",
            source,
        })?;
        line.push('\n');
        Ok(Outcome::text(line))
    }

    /// This outcome, ending with `error` after its output.
    pub(crate) fn then_fail(self, error: HarnessError) -> Outcome {
        Outcome {
            error: Some(error),
            ..self
        }
    }
}
