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

/// Which step of the sweep to run, with what only that step takes.
#[derive(Clone, Debug)]
pub enum SweepStep {
    /// Sweep meshes in this process and write the tables, plots and page.
    Run {
        /// Mesh files; without any, the built-in demo part.
        meshes: Vec<PathBuf>,
        /// Rows from another producer merged into the tables, plots and page.
        extra_rows: Vec<PathBuf>,
    },
    /// Run one shard of a dataset manifest: each model in its own process, with a ledger.
    Shard(ShardStep),
    /// Merge the output folders of a manifest's shards into one dataset report.
    Merge {
        /// The shards' output folders.
        shards: Vec<PathBuf>,
    },
    /// A shard's model process (`EXE sweep --isolated-model=NAME … -- MESH`): sweep one mesh
    /// under the model name the manifest gave it and print its rows as one JSON line.
    Model {
        /// The model name.
        name: String,
        /// The mesh file.
        mesh: PathBuf,
    },
}

/// What running a shard of a manifest takes.
#[derive(Clone, Debug)]
pub struct ShardStep {
    /// The manifest (docs/scale.md).
    pub manifest: PathBuf,
    /// Refuse paths outside the manifest's folder.
    pub confine: bool,
    /// The shard to run (default: from the environment, else the whole manifest).
    pub shard: Option<Shard>,
    /// Wall-time limit of each model in seconds.
    pub model_timeout: Option<f64>,
    /// Run again the models the ledger holds as failed.
    pub retry_failed: bool,
}

/// Everything one sweep command is given (the `sdfmo sweep` flags of docs/cli.md): the step,
/// and the settings every step shares (a merge reads its settings from the shards' folders and
/// uses only `frames`, `output` and `json`).
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// The step to run.
    pub step: SweepStep,
    /// Depths, inclusive, within 1..=16.
    pub depths: RangeInclusive<u8>,
    /// Methods, in the order given (a repeated one runs once).
    pub methods: Vec<SweepMethod>,
    /// Image size of each (square) view in pixels.
    pub size: u32,
    /// Most voxels per leaf of the multi-octree, 1..=255.
    pub max_voxels: u8,
    /// Corners fitted to the surface in every build (`BuildSettings::fit_corners`).
    pub fit_corners: bool,
    /// Memory budget of each build in bytes (default: the builder's).
    pub max_memory: Option<u64>,
    /// Worker threads for builds and renders (default: all cores).
    pub threads: Option<usize>,
    /// Renders of each view per configuration; the render time is their median.
    pub frames: u16,
    /// One build with levels of detail per model and method, every level scored.
    pub levels: bool,
    /// Output directory (created if missing).
    pub output: PathBuf,
    /// Print one JSON object instead of the human summary.
    pub json: bool,
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
