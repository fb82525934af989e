//! `sdfmo sweep`: the flags handed to the harness (sdfmo-harness), its output printed.

use sdfmo_harness::{SweepMethod, SweepOptions};

use crate::args::{MethodArg, SweepArgs};
use crate::output::print_text;

impl From<MethodArg> for SweepMethod {
    fn from(m: MethodArg) -> SweepMethod {
        match m {
            MethodArg::Svo => SweepMethod::Svo,
            MethodArg::Multi => SweepMethod::Multi,
        }
    }
}

/// The harness's options from the flags.
fn options(a: &SweepArgs) -> SweepOptions {
    SweepOptions {
        meshes: a.meshes.clone(),
        depths: a.depths.clone(),
        methods: a.methods.iter().map(|&m| m.into()).collect(),
        size: a.size,
        max_voxels: a.max_voxels,
        max_memory: a.max_memory,
        threads: a.threads,
        frames: a.frames,
        levels: a.levels,
        extra_rows: a.extra_rows.clone(),
        output: a.output.clone(),
        json: a.json,
        manifest: a.manifest.clone(),
        confine: a.confine,
        shard: a.shard,
        model_timeout: a.model_timeout,
        retry_failed: a.retry_failed,
        merge: a.merge.clone(),
        isolated_model: a.isolated_model.clone(),
    }
}

/// Runs the sweep, prints its summary, then ends with its error if it has one (a shard's
/// failed models: exit code 3, `main`).
pub fn run(args: &SweepArgs) -> anyhow::Result<()> {
    let outcome = sdfmo_harness::run(&options(args))?;
    print_text(&outcome.stdout)?;
    outcome.error.map_or(Ok(()), Err)
}
