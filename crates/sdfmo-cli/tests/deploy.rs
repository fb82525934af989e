//! The deploy recipes (deploy/slurm, deploy/k8s, the Dockerfile) checked without a cluster:
//! `submit.sh` run against a stub `sbatch` that records its arguments, the Kubernetes Jobs read
//! for what a restricted security policy requires (issue 32) and for the image the Dockerfile
//! builds. deploy/lint.sh lints the same files and deploy/slurm/ci-test.sh runs the Slurm recipe
//! on a real Slurm.

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
    submit_with(dir, shards, &[], env)
}

fn submit_with(
    dir: &Path,
    shards: &str,
    flags: &[&str],
    env: &[(&str, &str)],
) -> std::process::Output {
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
        .args(flags)
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

/// The sbatch memory request (`SDFMO_MEM_PER_TASK`, sbatch's `--mem`) must hold the sweep's
/// `--max-memory`, which it then requires: without it each build's budget is half the node's
/// memory, whatever Slurm granted. The recipe set `--max-memory` with no `--mem` at all.
#[test]
fn submit_sh_asks_slurm_for_the_memory_the_builds_may_use() {
    let t = tempfile::tempdir().unwrap();
    let calls = t.path().join("calls");
    fn mem(m: &str) -> [(&str, &str); 1] {
        [("SDFMO_MEM_PER_TASK", m)]
    }
    for flags in [&["--max-memory", "6G"][..], &["--max-memory=6GiB"][..]] {
        let o = submit_with(t.path(), "8", flags, &mem("8G"));
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let text = std::fs::read_to_string(&calls).unwrap();
        assert!(text.contains("--mem=8G --array=0-7"), "{text}");
        std::fs::remove_file(&calls).unwrap();
    }
    // The sweep's --max-memory (none: not given), SDFMO_MEM_PER_TASK, and the refusal.
    let not_a_size = "SDFMO_MEM_PER_TASK must be a memory size";
    for (max_memory, m, says) in [
        (Some("6G"), "4G", "is more than SDFMO_MEM_PER_TASK=4G"),
        (Some("6.5G"), "6000", "is more than SDFMO_MEM_PER_TASK=6000"),
        (None, "8G", "needs the sweep's --max-memory"),
        (Some("lots"), "8G", "cannot read --max-memory 'lots'"),
        (Some("1G"), "8 G", not_a_size),
        (Some("1G"), "$(id)", not_a_size),
    ] {
        let flags: Vec<&str> = max_memory
            .iter()
            .flat_map(|&v| ["--max-memory", v])
            .collect();
        let o = submit_with(t.path(), "8", &flags, &mem(m));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flags:?} {m}: {err}");
        assert!(err.contains(says), "{flags:?} {m}: {err}");
        assert!(!calls.exists(), "{flags:?} {m} submitted");
    }
    // Recorded for resubmit.sh: the settings as NUL-separated words, the jobs one a line.
    let o = submit_with(t.path(), "8", &["--max-memory", "6G"], &mem("8G"));
    assert!(o.status.success());
    let args = std::fs::read(t.path().join("root/submit.args")).unwrap();
    let words: Vec<&[u8]> = args.split(|&b| b == 0).collect();
    assert_eq!(&words[1..4], [&b"8"[..], b"", b"8G"]);
    assert_eq!(&words[5..7], [&b"--max-memory"[..], b"6G"]);
    let jobs = std::fs::read_to_string(t.path().join("root/submit.jobs")).unwrap();
    // Three submissions went through; the refused ones recorded nothing.
    assert_eq!(jobs, "array 42 0-7\nmerge 42 afterok:42\n".repeat(3));
}

/// The Kubernetes Jobs run the image the Dockerfile's build command names, as the user the
/// Dockerfile makes, and that image carries the workspace's version (the Jobs pulled an image
/// nothing in the repository built).
#[test]
fn kubernetes_jobs_run_the_image_the_dockerfile_builds() {
    let root = deploy().join("..");
    let dockerfile = std::fs::read_to_string(root.join("Dockerfile")).unwrap();
    let built = dockerfile
        .lines()
        .find_map(|l| l.strip_prefix("#   docker build -t "))
        .and_then(|l| l.split_whitespace().next())
        .expect("the Dockerfile's header names the image it builds");
    let version = std::fs::read_to_string(root.join("Cargo.toml"))
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("version = \""))
        .map(|v| v.trim_end_matches('"').to_owned())
        .unwrap();
    assert!(
        built.ends_with(&format!(":{version}")),
        "{built} is not version {version}"
    );
    assert!(
        dockerfile.contains(&format!("org.opencontainers.image.version=\"{version}\"")),
        "the image's version label is not {version}"
    );
    assert!(dockerfile.contains("\nUSER 65532:65532\n"));
    let text = std::fs::read_to_string(deploy().join("k8s/sweep-indexed-job.yaml")).unwrap();
    let images: Vec<&str> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("image: "))
        .map(|l| l.split_whitespace().next().unwrap())
        .collect();
    assert_eq!(images, [built, built]);
    assert_eq!(text.matches("runAsUser: 65532").count(), 2);
    // Every base image pinned by a tag and a digest.
    for from in dockerfile.lines().filter(|l| l.starts_with("FROM ")) {
        let image = from.split_whitespace().nth(1).unwrap();
        let (tagged, digest) = image.split_once("@sha256:").expect(from);
        assert!(tagged.contains(':') && digest.len() == 64, "{from}");
    }
}
