//! `sdfmo sweep`: the flags (or a step and its flags) handed to the harness (sdfmo-harness),
//! its output printed.

use std::path::PathBuf;

use sdfmo_harness::{HarnessError, SweepMethod, SweepOptions};

use crate::args::{
    MethodArg, SweepArgs, SweepDatasetArgs, SweepOutputArgs, SweepSettingsArgs, SweepStep,
    SWEEP_FRAMES,
};
use crate::output::print_text;

impl From<MethodArg> for SweepMethod {
    fn from(m: MethodArg) -> SweepMethod {
        match m {
            MethodArg::Svo => SweepMethod::Svo,
            MethodArg::Multi => SweepMethod::Multi,
        }
    }
}

/// A sweep of `meshes` with these settings into `out`; the other steps start from it.
fn sweep_of(
    meshes: &[PathBuf],
    settings: &SweepSettingsArgs,
    levels: bool,
    out: &SweepOutputArgs,
) -> SweepOptions {
    SweepOptions {
        meshes: meshes.to_vec(),
        depths: settings.depths.clone(),
        methods: settings.methods.iter().map(|&m| m.into()).collect(),
        size: settings.size,
        max_voxels: settings.max_voxels,
        max_memory: settings.max_memory,
        threads: settings.threads,
        frames: settings.frames,
        levels,
        extra_rows: Vec::new(),
        output: out.output.clone(),
        json: out.json,
        manifest: None,
        confine: false,
        shard: None,
        model_timeout: None,
        retry_failed: false,
        merge: Vec::new(),
        isolated_model: None,
    }
}

/// `opts` running shard `dataset` of `manifest`.
fn shard_of(opts: SweepOptions, manifest: PathBuf, dataset: &SweepDatasetArgs) -> SweepOptions {
    SweepOptions {
        manifest: Some(manifest),
        confine: dataset.confine,
        shard: dataset.shard,
        model_timeout: dataset.model_timeout,
        retry_failed: dataset.retry_failed,
        ..opts
    }
}

/// The harness's options from the flags: a step and the flag form it names give the same.
fn options(a: &SweepArgs) -> SweepOptions {
    match &a.step {
        None => {
            let opts = SweepOptions {
                extra_rows: a.extra_rows.clone(),
                merge: a.merge.clone(),
                isolated_model: a.isolated_model.clone(),
                ..sweep_of(&a.meshes, &a.settings, a.levels, &a.out)
            };
            match &a.manifest {
                Some(m) => shard_of(opts, m.clone(), &a.dataset),
                None => opts,
            }
        }
        Some(SweepStep::Run(r)) => SweepOptions {
            extra_rows: r.extra_rows.clone(),
            ..sweep_of(&r.meshes, &r.settings, r.levels, &r.out)
        },
        Some(SweepStep::Shard(s)) => shard_of(
            sweep_of(&[], &s.settings, s.levels, &s.out),
            s.manifest.clone(),
            &s.dataset,
        ),
        // A merge takes the settings from the shards' folders; `frames` is the default the
        // flag form records in its provenance.
        Some(SweepStep::Merge(m)) => SweepOptions {
            merge: m.shards.clone(),
            frames: SWEEP_FRAMES,
            ..sweep_of(&[], &merge_settings(), false, &m.out)
        },
    }
}

/// The settings a merge hands on (unused by it except `frames`): the flags' defaults.
fn merge_settings() -> SweepSettingsArgs {
    SweepSettingsArgs {
        depths: 6..=9,
        methods: vec![MethodArg::Svo, MethodArg::Multi],
        size: 1024,
        max_voxels: 8,
        max_memory: None,
        threads: None,
        frames: SWEEP_FRAMES,
    }
}

/// Runs the sweep, prints its summary, then ends with its error if it has one (a shard's
/// failed models: exit code 3, `main`).
pub fn run(args: &SweepArgs) -> anyhow::Result<()> {
    let outcome = sdfmo_harness::run(&options(args))?;
    print_text(&outcome.stdout)?;
    match outcome.error {
        None => Ok(()),
        // `main` tells failed models (exit 3) from an error of the command by this type.
        Some(HarnessError::ModelsFailed(failed)) => Err(failed.into()),
        Some(e) => Err(e.into()),
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;
    use crate::args::{Cli, Command};

    /// The harness's options of a command line.
    fn parsed(line: &[&str]) -> String {
        let cli = Cli::try_parse_from(line).unwrap_or_else(|e| panic!("{line:?}: {e}"));
        match cli.command {
            Command::Sweep(a) => format!("{:?}", options(&a)),
            other => panic!("parsed as {other:?}"),
        }
    }

    #[test]
    fn each_step_is_its_flag_form() {
        let same = |step: &[&str], flags: &[&str]| assert_eq!(parsed(step), parsed(flags));
        same(
            &[
                "sdfmo", "sweep", "run", "a.obj", "--depths", "3..4", "--levels", "-o", "o",
            ],
            &[
                "sdfmo", "sweep", "a.obj", "--depths", "3..4", "--levels", "-o", "o",
            ],
        );
        // The shard step and `--manifest` share every flag after the manifest.
        let shard_flags = [
            "--shard",
            "1/3",
            "--confine",
            "--retry-failed",
            "--model-timeout",
            "9",
            "--size",
            "64",
            "--json",
            "-o",
            "s",
        ];
        same(
            &[&["sdfmo", "sweep", "shard", "m.csv"][..], &shard_flags].concat(),
            &[&["sdfmo", "sweep", "--manifest", "m.csv"][..], &shard_flags].concat(),
        );
        same(
            &["sdfmo", "sweep", "merge", "s0", "s1", "-o", "r"],
            &["sdfmo", "sweep", "--merge", "s0", "s1", "-o", "r"],
        );
        // A different setting is a different run: the comparison can fail.
        assert_ne!(
            parsed(&["sdfmo", "sweep", "run", "--size", "64"]),
            parsed(&["sdfmo", "sweep", "--size", "65"])
        );
    }

    #[test]
    fn steps_refuse_what_they_do_not_take() {
        for line in [
            &["sdfmo", "sweep", "merge", "-o", "r"][..],
            &["sdfmo", "sweep", "merge", "s0", "--levels"],
            &["sdfmo", "sweep", "shard"],
            &["sdfmo", "sweep", "--confine"],
        ] {
            assert!(Cli::try_parse_from(line).is_err(), "{line:?}");
        }
    }
}
