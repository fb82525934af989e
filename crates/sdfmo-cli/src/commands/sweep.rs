//! `sdfmo sweep`: the flags (or a step and its flags) handed to the harness (sdfmo-harness),
//! its output printed.

use std::path::PathBuf;

use sdfmo_harness::{HarnessError, ShardStep, SweepMethod, SweepOptions, SweepStep as Step};

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

/// `step` with these settings into `out`.
fn options_of(
    step: Step,
    settings: &SweepSettingsArgs,
    levels: bool,
    out: &SweepOutputArgs,
) -> SweepOptions {
    SweepOptions {
        step,
        depths: settings.depths.clone(),
        methods: settings.methods.iter().map(|&m| m.into()).collect(),
        size: settings.size,
        max_voxels: settings.max_voxels,
        fit_corners: settings.fit_corners,
        max_memory: settings.max_memory,
        threads: settings.threads,
        frames: settings.frames,
        levels,
        output: out.output.clone(),
        json: out.json,
    }
}

/// The shard step of `manifest` with the dataset flags.
fn shard_step(manifest: PathBuf, dataset: &SweepDatasetArgs) -> Step {
    Step::Shard(ShardStep {
        manifest,
        confine: dataset.confine,
        shard: dataset.shard,
        model_timeout: dataset.model_timeout,
        retry_failed: dataset.retry_failed,
    })
}

/// The harness's options from the flags: a step and the flag form it names give the same. In
/// the flag form the step follows from the flags, in this order: `--merge`, `--manifest`,
/// `--isolated-model` (a shard's model process, which takes exactly one mesh), else a sweep of
/// the meshes.
fn options(a: &SweepArgs) -> anyhow::Result<SweepOptions> {
    let (step, settings, levels, out) = match &a.step {
        None => {
            let step = if !a.merge.is_empty() {
                Step::Merge {
                    shards: a.merge.clone(),
                }
            } else if let Some(m) = &a.manifest {
                shard_step(m.clone(), &a.dataset)
            } else if let Some(name) = &a.isolated_model {
                let [mesh] = a.meshes.as_slice() else {
                    anyhow::bail!(
                        "--isolated-model takes exactly one mesh, not {}",
                        a.meshes.len()
                    );
                };
                Step::Model {
                    name: name.clone(),
                    mesh: mesh.clone(),
                }
            } else {
                Step::Run {
                    meshes: a.meshes.clone(),
                    extra_rows: a.extra_rows.clone(),
                }
            };
            (step, &a.settings, a.levels, &a.out)
        }
        Some(SweepStep::Run(r)) => (
            Step::Run {
                meshes: r.meshes.clone(),
                extra_rows: r.extra_rows.clone(),
            },
            &r.settings,
            r.levels,
            &r.out,
        ),
        Some(SweepStep::Shard(s)) => (
            shard_step(s.manifest.clone(), &s.dataset),
            &s.settings,
            s.levels,
            &s.out,
        ),
        // A merge takes the settings from the shards' folders; `frames` is the default the
        // flag form records in its provenance.
        Some(SweepStep::Merge(m)) => {
            let opts = options_of(
                Step::Merge {
                    shards: m.shards.clone(),
                },
                &merge_settings(),
                false,
                &m.out,
            );
            return Ok(opts);
        }
    };
    Ok(options_of(step, settings, levels, out))
}

/// The settings a merge hands on (unused by it except `frames`): the flags' defaults.
fn merge_settings() -> SweepSettingsArgs {
    SweepSettingsArgs {
        depths: 6..=9,
        methods: vec![MethodArg::Svo, MethodArg::Multi],
        size: 1024,
        max_voxels: 8,
        fit_corners: false,
        max_memory: None,
        threads: None,
        frames: SWEEP_FRAMES,
    }
}

/// Runs the sweep, prints its summary, then ends with its error if it has one (a shard's
/// failed models: exit code 3, `main`).
pub fn run(args: &SweepArgs) -> anyhow::Result<()> {
    let outcome = sdfmo_harness::run(&options(args)?)?;
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
            Command::Sweep(a) => format!("{:?}", options(&a).unwrap()),
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
        // A model's process sweeps exactly one mesh.
        for meshes in [&[][..], &["a.obj", "b.obj"]] {
            let line = [&["sdfmo", "sweep", "--isolated-model=m"][..], meshes].concat();
            let Command::Sweep(a) = Cli::try_parse_from(&line).unwrap().command else {
                panic!("{line:?}");
            };
            let e = options(&a).unwrap_err().to_string();
            assert!(e.contains("takes exactly one mesh"), "{e}");
        }
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
