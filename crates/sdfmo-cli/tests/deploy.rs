//! The deploy recipes (deploy/slurm, deploy/k8s) checked without a cluster: `submit.sh` run
//! against a stub `sbatch` that records its arguments, and the Kubernetes Jobs read for what a
//! restricted security policy requires (issue 32).

use std::path::{Path, PathBuf};
use std::process::Command;

fn deploy() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../deploy")
}

/// A folder with an `sbatch` that appends its arguments to `calls` and prints a job id.
fn stub_sbatch(dir: &Path) -> PathBuf {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let sbatch = bin.join("sbatch");
    std::fs::write(
        &sbatch,
        format!(
            "#!/bin/sh\necho \"$*\" >> '{}'\necho 42\n",
            dir.join("calls").display()
        ),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&sbatch, std::fs::Permissions::from_mode(0o755)).unwrap();
    bin
}

fn submit(dir: &Path, shards: &str, env: &[(&str, &str)]) -> std::process::Output {
    let bin = stub_sbatch(dir);
    let manifest = dir.join("manifest.txt");
    std::fs::write(&manifest, "a.obj\n").unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    Command::new("bash")
        .arg(deploy().join("slurm/submit.sh"))
        .arg(&manifest)
        .arg(dir.join("root"))
        .arg(shards)
        .current_dir(dir)
        .env("PATH", path)
        .envs(env.iter().copied())
        .output()
        .unwrap()
}

/// `submit.sh MANIFEST ROOT SHARDS` put SHARDS into `$((shards - 1))`, where bash evaluates an
/// array subscript's command substitution: `HOME[$(touch PWNED)]` ran `touch`. SHARDS must be
/// digits now, checked before any use.
#[test]
fn submit_sh_runs_nothing_a_shard_count_says() {
    let t = tempfile::tempdir().unwrap();
    for crafted in [
        "HOME[$(touch PWNED)]",
        "0",
        "-3",
        "8 ",
        "1e3",
        "07",
        "2000000",
    ] {
        let o = submit(t.path(), crafted, &[]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{crafted:?}: {err}");
        assert!(
            err.contains("SHARDS must be a number"),
            "{crafted:?}: {err}"
        );
        assert!(
            !t.path().join("PWNED").exists(),
            "{crafted:?} ran a command"
        );
        assert!(!t.path().join("calls").exists(), "{crafted:?} submitted");
    }
    let o = submit(t.path(), "8", &[("SDFMO_CPUS_PER_TASK", "2")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let calls = std::fs::read_to_string(t.path().join("calls")).unwrap();
    assert!(calls.contains("--cpus-per-task=2 --array=0-7"), "{calls}");
    assert!(calls.contains("--dependency=afterok:42"), "{calls}");
    let o = submit(t.path(), "8", &[("SDFMO_CPUS_PER_TASK", "$(id)")]);
    assert_eq!(o.status.code(), Some(2));
}

/// The Kubernetes Jobs ran as root with an `:latest` image and the merge Job without resources.
/// Each Job must now pass the "restricted" Pod Security Standard and pin its image.
#[test]
fn kubernetes_jobs_run_unprivileged_with_a_pinned_image_and_resources() {
    let text = std::fs::read_to_string(deploy().join("k8s/sweep-indexed-job.yaml")).unwrap();
    let docs: Vec<&str> = text.split("\n---\n").collect();
    assert_eq!(docs.len(), 2);
    for doc in docs {
        for needed in [
            "kind: Job",
            "runAsNonRoot: true",
            "runAsUser: 65532",
            "allowPrivilegeEscalation: false",
            "readOnlyRootFilesystem: true",
            "capabilities: { drop: [\"ALL\"] }",
            "seccompProfile: { type: RuntimeDefault }",
            "requests: { cpu:",
            "limits: { cpu:",
        ] {
            assert!(doc.contains(needed), "{needed:?} missing in:\n{doc}");
        }
        let images: Vec<&str> = doc
            .lines()
            .filter_map(|l| l.trim().strip_prefix("image: "))
            .collect();
        assert_eq!(images.len(), 1);
        let image = images[0].split_whitespace().next().unwrap();
        let tag = image.rsplit_once(':').map(|(_, t)| t).unwrap_or("");
        assert!(
            !tag.is_empty() && tag != "latest" && !tag.contains('/'),
            "{image} is not pinned"
        );
    }
}
