//! One module per command, plus what several of them share.

pub mod build;
pub mod compare;
pub mod distance;
pub mod generate;
pub mod info;
pub mod render;
pub mod sweep;

use std::path::Path;

use anyhow::Context;
use sdf_multioctree::build::Method;
use sdf_multioctree::distance::SignMode;
use sdf_multioctree::format::ValueBits;
use sdf_multioctree::mesh::{self, CleanReport, TriMesh};

use crate::args::{BitsArg, MethodArg, SignArg};

/// A mesh read from a file, or the built-in demo part.
pub struct InputMesh {
    /// The mesh in model units.
    pub mesh: TriMesh,
    /// What loading cleaned up (None for the demo part, which is generated clean).
    pub report: Option<CleanReport>,
    /// Where it came from: the path, or `demo`.
    pub source: String,
    /// Short name for tables and file names: the file stem, or `demo`.
    pub name: String,
    /// The format the file was read as (None for the demo part).
    pub format: Option<String>,
    /// Name of each part, where the file gives them.
    pub part_names: Vec<String>,
}

/// Loads `path`, or generates the built-in demo part when it is `None`.
pub fn load_input(path: Option<&Path>) -> anyhow::Result<InputMesh> {
    match path {
        Some(p) => {
            // Every mesh error names the file already.
            let loaded = mesh::load_mesh(p)?;
            let name = mesh::mesh_name(p);
            Ok(InputMesh {
                mesh: loaded.mesh,
                report: Some(loaded.report),
                source: p.display().to_string(),
                name,
                format: Some(format!("{:?}", loaded.format).to_lowercase()),
                part_names: loaded.part_names,
            })
        }
        None => Ok(InputMesh {
            mesh: mesh::procedural::demo_part(),
            report: None,
            source: "demo".to_owned(),
            name: "demo".to_owned(),
            format: None,
            part_names: Vec::new(),
        }),
    }
}

impl SignArg {
    /// The distance layer's sign mode.
    pub fn mode(self) -> SignMode {
        match self {
            SignArg::Auto => SignMode::Auto,
            SignArg::Pseudonormal => SignMode::PseudoNormal,
            SignArg::Winding => SignMode::Winding,
        }
    }
}

/// Name of a resolved sign mode, as the `--sign` flag spells it.
pub fn sign_name(mode: SignMode) -> &'static str {
    match mode {
        SignMode::Auto => "auto",
        SignMode::PseudoNormal => "pseudonormal",
        SignMode::Winding => "winding",
    }
}

impl MethodArg {
    /// The builder's method.
    pub fn method(self, max_voxels: u8) -> Method {
        match self {
            MethodArg::Svo => Method::Svo,
            MethodArg::Multi => Method::Multi { max_voxels },
        }
    }
}

impl BitsArg {
    /// The format's value bits.
    pub fn bits(self) -> ValueBits {
        match self {
            BitsArg::Eight => ValueBits::Eight,
            BitsArg::Sixteen => ValueBits::Sixteen,
        }
    }

    /// Bits as a number.
    pub fn count(self) -> u32 {
        match self {
            BitsArg::Eight => 8,
            BitsArg::Sixteen => 16,
        }
    }
}

/// The memory budget of a build: `--max-memory`, else the builder's default (half the
/// physical memory).
pub fn memory_budget(max_memory: Option<u64>) -> Option<u64> {
    max_memory.or_else(sdf_multioctree::build::default_memory_budget)
}

/// Runs `f` on a rayon pool of `threads` workers, or on the global pool when `None`.
pub fn with_threads<R: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> R + Send,
) -> anyhow::Result<R> {
    sdf_multioctree::render::in_pool(threads, f).context("cannot start worker threads")
}
