//! Issue 32: the dataset sweep's shard folders, ledgers and manifests as untrusted input, on the
//! real `sdfmo` binary. One small dataset (four boxes, two shards) is swept once; each case
//! copies its shard folders, tampers with them the way someone who can write a shard folder
//! could, and checks the merge (or a rerun of a shard) refuses in one line with exit 2 and
//! writes nothing outside its output folder, or, for the stale-ledger cases, merges what the
//! manifest now says. docs/hardening.md, "Issue 32", lists every case.

mod common;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

use sdf_multioctree::mesh::{procedural::box_mesh, write::to_obj};
use sdf_multioctree::Vec3;
use serde_json::Value;

use common::{refused, stderr};

/// The sweep's settings in every run here: one depth, tiny views, one frame.
const FLAGS: [&str; 8] = [
    "--depths",
    "3",
    "--size",
    "16",
    "--frames",
    "1",
    "--threads",
    "1",
];

/// [`common::sdfmo`] of arguments of mixed kinds (`&str`, paths).
fn sdfmo(args: &[&dyn AsRef<OsStr>]) -> Output {
    common::sdfmo(args)
}

/// A closed box of `size` as OBJ.
fn box_obj(size: f32) -> String {
    to_obj(&box_mesh(Vec3::ZERO, Vec3::splat(size)))
}

/// The dataset: `a.obj`, `b.obj`, `c.obj`, `-dash.obj` (a name like an option) and
/// `b2.obj`, with `manifest.txt` listing the first four.
fn write_dataset(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    for (name, size) in [
        ("a.obj", 1.0),
        ("b.obj", 2.0),
        ("c.obj", 3.0),
        ("-dash.obj", 4.0),
        ("b2.obj", 5.0),
    ] {
        std::fs::write(dir.join(name), box_obj(size)).unwrap();
    }
    let m = dir.join("manifest.txt");
    std::fs::write(&m, "a.obj\nb.obj\nc.obj\n-dash.obj\n").unwrap();
    m
}

/// The dataset in a fresh folder's `data/`, with a manifest `name` holding `text`; returns the
/// folder and the manifest's path.
fn dataset_with_manifest(name: &str, text: &str) -> (tempfile::TempDir, PathBuf) {
    let t = tempfile::tempdir().unwrap();
    let data = t.path().join("data");
    write_dataset(&data);
    let m = data.join(name);
    std::fs::write(&m, text).unwrap();
    (t, m)
}

/// Runs shard `k` of 2 of `manifest` into `out`.
fn run_shard(manifest: &Path, k: usize, out: &Path) -> Output {
    let shard = format!("{k}/2");
    let mut args: Vec<&dyn AsRef<OsStr>> = vec![
        &"sweep",
        &"--manifest",
        &manifest,
        &"--shard",
        &shard,
        &"--json",
    ];
    for f in &FLAGS {
        args.push(f);
    }
    args.push(&"-o");
    args.push(&out);
    sdfmo(&args)
}

/// The dataset swept once into `shard-0` and `shard-1` (every test copies them).
fn fixture() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let tmp = Path::new(env!("CARGO_TARGET_TMPDIR"));
        // The fixtures of earlier runs, whose process is gone (about 0.4 MB each).
        for e in std::fs::read_dir(tmp).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if let Some(pid) = name.strip_prefix("dataset-hostile-") {
                if !Path::new("/proc").join(pid).exists() {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        let dir = tmp.join(format!("dataset-hostile-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let m = write_dataset(&dir.join("data"));
        for k in 0..2 {
            let o = run_shard(&m, k, &dir.join(format!("shard-{k}")));
            assert!(o.status.success(), "shard {k}: {}", stderr(&o));
        }
        dir
    })
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let t = e.file_type().unwrap();
        if t.is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// A fresh copy of the fixture (data and both shards) in a temporary folder.
fn copy_fixture() -> tempfile::TempDir {
    let t = tempfile::tempdir().unwrap();
    copy_dir(fixture(), t.path());
    t
}

fn merge(root: &Path, out: &Path) -> Output {
    sdfmo(&[
        &"sweep",
        &"--merge",
        &root.join("shard-0"),
        &root.join("shard-1"),
        &"--json",
        &"-o",
        &out,
    ])
}

/// Rewrites every line of `shard/ledger.jsonl` with `edit`.
fn edit_ledger(shard: &Path, edit: impl Fn(&mut Value)) {
    let p = shard.join("ledger.jsonl");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        let mut v: Value = serde_json::from_str(line).unwrap();
        edit(&mut v);
        out.push_str(&serde_json::to_string(&v).unwrap());
        out.push('\n');
    }
    std::fs::write(&p, out).unwrap();
}

fn edit_shard_json(shard: &Path, edit: impl Fn(&mut Value)) {
    let p = shard.join("shard.json");
    let mut v: Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
}

/// Every file under `dir` with its bytes, in path order.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    tree(dir)
        .into_iter()
        .filter(|p| p.is_file())
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect()
}

/// Every path under `dir` (links not followed).
fn tree(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if std::fs::symlink_metadata(&p).unwrap().is_dir() {
                stack.push(p.clone());
            }
            out.push(p);
        }
    }
    out.sort();
    out
}

fn results(out: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap()
}

fn model_sources(out: &Path) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = results(out)["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["model"].as_str().unwrap().to_owned(),
                m["source"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    v.sort();
    v
}

/// The untampered shards merge, every model with its rows; the model whose file name starts
/// with `-` among them (it was passed to its process as an option: "unexpected argument
/// '-d'", recorded as failed).
#[test]
fn the_clean_dataset_merges_and_a_dash_named_model_runs() {
    let t = copy_fixture();
    let out = t.path().join("report");
    let o = merge(t.path(), &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let names: Vec<String> = model_sources(&out).into_iter().map(|(m, _)| m).collect();
    assert_eq!(names, ["-dash", "a", "b", "c"]);
    assert!(results(&out)["failures"].as_array().unwrap().is_empty());
}

/// Model names from a ledger and method names from shard.json became path components of the
/// merge's output unchecked: `../` names wrote outside OUT. Now they must be names the sweep
/// itself writes.
#[test]
fn merged_names_never_leave_the_output_folder() {
    for (what, needle, tamper) in [
        ("model ../../escape", "model name \"../../escape\"", 0),
        ("absolute model name", "model name \"/tmp/sdfmo-escape\"", 1),
        ("method ../m in shard.json", "settings.methods", 2),
        (
            "method in a row only",
            "method \"../m\" is not one of the settings'",
            3,
        ),
    ] {
        let t = copy_fixture();
        let s1 = t.path().join("shard-1");
        match tamper {
            0 | 1 => {
                let name = if tamper == 0 {
                    "../../escape"
                } else {
                    "/tmp/sdfmo-escape"
                };
                edit_ledger(&s1, |r| {
                    if r["id"] == "b.obj" {
                        r["name"] = name.into();
                        r["model"]["model"] = name.into();
                        for row in r["rows"].as_array_mut().unwrap() {
                            row["model"] = name.into();
                        }
                    }
                });
            }
            2 => {
                for k in 0..2 {
                    edit_shard_json(&t.path().join(format!("shard-{k}")), |v| {
                        v["settings"]["methods"] = serde_json::json!(["svo", "../m"]);
                    });
                }
            }
            _ => edit_ledger(&s1, |r| {
                for row in r["rows"].as_array_mut().unwrap() {
                    row["method"] = "../m".into();
                }
            }),
        }
        let before = tree(t.path());
        let out = t.path().join("deep/report");
        let o = merge(t.path(), &out);
        refused(&o, needle, what);
        let after: Vec<PathBuf> = tree(t.path())
            .into_iter()
            .filter(|p| !p.starts_with(&out))
            .collect();
        let new: Vec<&PathBuf> = after.iter().filter(|p| !before.contains(p)).collect();
        assert!(
            new.iter().all(|p| out.starts_with(p)),
            "{what}: wrote {new:?}"
        );
        assert!(!Path::new("/tmp/sdfmo-escape").exists());
    }
}

/// Images (and shard.json, the ledger) inside a shard folder were read through symbolic
/// links: a link to a 0600 file outside put that file into the report, readable by all. No
/// link below a shard folder is followed now.
#[test]
fn the_merge_follows_no_link_inside_a_shard_folder() {
    use std::os::unix::fs::{symlink, PermissionsExt};
    for (what, plant) in [
        ("an image", "images/a/svo_d3_0.png"),
        ("an image folder", "images/a"),
        ("the images folder", "images"),
        ("the ledger", "ledger.jsonl"),
        ("shard.json", "shard.json"),
    ] {
        let t = copy_fixture();
        let s0 = t.path().join("shard-0");
        let secret = t.path().join("secret");
        // The planted target: the real file or folder moved aside (so the content would be
        // valid), or for an image a private file.
        let target = t.path().join("moved");
        std::fs::rename(s0.join(plant), &target).unwrap();
        if what == "an image" {
            std::fs::write(&secret, b"\x89PNG private").unwrap();
            std::fs::set_permissions(&secret, std::fs::Permissions::from_mode(0o600)).unwrap();
            symlink(&secret, s0.join(plant)).unwrap();
        } else {
            symlink(&target, s0.join(plant)).unwrap();
        }
        let out = t.path().join("report");
        let o = merge(t.path(), &out);
        refused(&o, "is a symbolic link", what);
        if out.exists() {
            for p in tree(&out) {
                if p.is_file() {
                    let bytes = std::fs::read(&p).unwrap();
                    assert!(
                        !bytes.windows(7).any(|w| w == b"private"),
                        "{what}: {} holds the secret",
                        p.display()
                    );
                }
            }
        }
    }
}

/// A hard-linked ledger.jsonl was truncated (its torn last line cut) and appended to, changing
/// the file at its other name; O_NOFOLLOW does not stop hard links.
#[test]
fn a_hard_linked_ledger_is_not_modified() {
    let t = copy_fixture();
    let s0 = t.path().join("shard-0");
    let victim = t.path().join("victim.jsonl");
    let mut text = std::fs::read(s0.join("ledger.jsonl")).unwrap();
    text.extend_from_slice(b"{\"torn\":");
    std::fs::write(&victim, &text).unwrap();
    std::fs::remove_file(s0.join("ledger.jsonl")).unwrap();
    std::fs::hard_link(&victim, s0.join("ledger.jsonl")).unwrap();
    let o = run_shard(&t.path().join("data/manifest.txt"), 0, &s0);
    refused(&o, "has 2 hard links", "hard-linked ledger");
    assert_eq!(std::fs::read(&victim).unwrap(), text);
}

/// Numbers of a shard folder were merged unchecked: a shard count of 0 panicked (exit 70),
/// counts underflowed ("18446744073709551613 of 1 models"), depth 255, a negative FLIP and an
/// absurd PSNR were merged.
#[test]
fn shard_numbers_are_range_checked() {
    type Tamper = fn(&Path);
    let cases: [(&str, &str, Tamper); 8] = [
        ("shard count 0", "need 0 <= K < N", |s| {
            edit_shard_json(s, |v| v["shard"]["count"] = 0.into())
        }),
        ("manifest of 1 entry", "owns 1 of them", |s| {
            for k in 0..2 {
                edit_shard_json(&s.with_file_name(format!("shard-{k}")), |v| {
                    v["manifest_entries"] = 1.into()
                });
            }
        }),
        ("depth 255", "depth 255 is not one of the settings'", |s| {
            edit_ledger(s, |r| r["rows"][0]["depth"] = 255.into())
        }),
        ("settings depth 255", "settings.depths", |s| {
            for k in 0..2 {
                edit_shard_json(&s.with_file_name(format!("shard-{k}")), |v| {
                    v["settings"]["depths"] = serde_json::json!([3, 255])
                });
            }
        }),
        ("negative FLIP", "flip -0.5 must be within 0..=1", |s| {
            edit_ledger(s, |r| r["rows"][0]["flip"] = (-0.5).into())
        }),
        ("absurd PSNR", "is above 200 dB", |s| {
            edit_ledger(s, |r| r["rows"][0]["psnr"] = 1e300.into())
        }),
        ("negative wall time", "wall_ms -1 must be finite", |s| {
            edit_ledger(s, |r| r["wall_ms"] = (-1.0).into())
        }),
        ("a row of another model", "its model is \"zzz\"", |s| {
            edit_ledger(s, |r| r["rows"][0]["model"] = "zzz".into())
        }),
    ];
    for (what, needle, tamper) in cases {
        let t = copy_fixture();
        tamper(&t.path().join("shard-1"));
        let o = merge(t.path(), &t.path().join("report"));
        refused(&o, needle, what);
        assert!(!stderr(&o).contains("1844674407"), "{what}: {}", stderr(&o));
    }
}

/// `-o` naming a shard folder (or a folder inside one) overwrote that shard's results.json and
/// tables with the merged ones.
#[test]
fn merging_into_an_input_folder_is_refused() {
    let t = copy_fixture();
    let s0 = t.path().join("shard-0");
    let before = files(&s0);
    for out in [s0.clone(), s0.join("report"), s0.join("images/../new")] {
        let o = merge(t.path(), &out);
        refused(&o, "is inside the shard folder", &out.display().to_string());
    }
    let after = files(&s0);
    assert_eq!(before, after);
}

/// Ledgers matched records by id only: when a CSV manifest's id `b` named b.obj on the first
/// run and b2.obj after an edit, the rerun skipped `b` and the merge reported b.obj's rows.
/// A record counts only for the entry it ran (position, id, name and path) now.
#[test]
fn a_stale_record_of_an_edited_manifest_does_not_count() {
    let (t, m) = dataset_with_manifest("manifest.csv", "id,path\na,a.obj\nb,b.obj\n");
    let shard = |k: usize| t.path().join(format!("shard-{k}"));
    for k in 0..2 {
        assert!(run_shard(&m, k, &shard(k)).status.success());
    }
    std::fs::write(&m, "id,path\na,a.obj\nb,b2.obj\n").unwrap();
    let o = run_shard(&m, 1, &shard(1));
    assert!(o.status.success(), "{}", stderr(&o));
    let j: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["shard"]["ran"], 1, "the edited entry runs again");
    // Shard 0 has not seen the edit yet: the merge says so rather than mixing versions.
    let o = merge(t.path(), &t.path().join("early"));
    refused(
        &o,
        "different versions of the manifest",
        "shard 0 not rerun",
    );
    let o = run_shard(&m, 0, &shard(0));
    let j: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["shard"]["ran"], 0, "its entry did not change");
    let out = t.path().join("report");
    let o = merge(t.path(), &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let sources = model_sources(&out);
    assert_eq!(sources[1].0, "b");
    assert!(sources[1].1.ends_with("b2.obj"), "{sources:?}");
}

/// A record whose index was wrong counted as long as its id was unique: the merge exited 0
/// with the record at a position of the manifest that is not its own. It is stale now: the
/// merge names the entry with no current record and exits 2, and a rerun of the shard sweeps
/// the model again.
#[test]
fn a_wrong_index_is_named_and_the_model_runs_again() {
    let t = copy_fixture();
    let s1 = t.path().join("shard-1");
    edit_ledger(&s1, |r| {
        if r["id"] == "b.obj" {
            r["index"] = 5.into();
        }
    });
    let o = merge(t.path(), &t.path().join("report"));
    refused(&o, "manifest entries 1)", "wrong index");
    assert!(stderr(&o).contains("1 of 4 models have no current ledger record"));
    let o = run_shard(&t.path().join("data/manifest.txt"), 1, &s1);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["shard"]["ran"], 1);
    let o = merge(t.path(), &t.path().join("report2"));
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A manifest reordered after a run moved models between shards; each shard's rerun swept the
/// models it now owns, the old shard kept its record, and every merge failed with "model … is
/// in two shards' ledgers", forever. Records of a moved entry are stale now.
#[test]
fn a_reordered_manifest_after_a_resume_merges() {
    let t = copy_fixture();
    let m = t.path().join("data/manifest.txt");
    std::fs::write(&m, "b.obj\na.obj\nc.obj\n-dash.obj\n").unwrap();
    for k in 0..2 {
        let o = run_shard(&m, k, &t.path().join(format!("shard-{k}")));
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let out = t.path().join("report");
    let o = merge(t.path(), &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let names: Vec<String> = model_sources(&out).into_iter().map(|(m, _)| m).collect();
    assert_eq!(names, ["-dash", "a", "b", "c"]);
    // Shards of the old and the new order do not mix.
    let t2 = copy_fixture();
    std::fs::remove_dir_all(t2.path().join("shard-1")).unwrap();
    copy_dir(&t.path().join("shard-1"), &t2.path().join("shard-1"));
    let o = merge(t2.path(), &t2.path().join("report"));
    refused(
        &o,
        "different versions of the manifest",
        "old and new shards",
    );
}

/// A duplicate id in the manifest was kept as a failure of the same id, which the ledger (one
/// record per id) then dropped. It is an error of the manifest now, naming the id and lines.
#[test]
fn a_duplicate_id_in_the_manifest_is_named() {
    let (t, m) = dataset_with_manifest("dup.csv", "id,path\nx,a.obj\ny,b.obj\nx,c.obj\n");
    let o = run_shard(&m, 0, &t.path().join("out"));
    refused(
        &o,
        "line 4: the id \"x\" is given twice (first on line 2)",
        "duplicate id",
    );
    assert!(!t.path().join("out").exists());
}

/// `generate-parts --first 18446744073709551615 -n 2` said it wrote 2 parts and wrote none (the
/// range end saturated).
#[test]
fn generate_parts_refuses_indices_past_the_last() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("parts");
    let o = sdfmo(&[
        &"generate-parts",
        &"--first",
        &"18446744073709551615",
        &"-n",
        &"2",
        &"-o",
        &out,
    ]);
    refused(
        &o,
        "--first 18446744073709551615 -n 2",
        "first past the end",
    );
    assert!(!out.exists());
}

/// The default address-space cap of a model's process (twice half the RAM, plus 1 GiB) was
/// above the machine's memory and above a lower inherited hard limit: a user without the right
/// to raise it got every model's process refused ("Operation not permitted"). The cap is
/// clamped to the inherited limit now. Run as root, the test drops CAP_SYS_RESOURCE from the
/// shard's process so it is bound by its hard limit like any user.
#[test]
fn shards_run_under_a_lower_inherited_address_space_limit() {
    use std::os::unix::process::CommandExt;
    let (t, m) = dataset_with_manifest("one.txt", "a.obj\n");
    // 8 GiB: below the default cap on any machine with more than 7 GiB.
    let limit: u64 = 8 << 30;
    let mut cmd = std::process::Command::new(common::SDFMO);
    cmd.args(["sweep", "--manifest"])
        .arg(&m)
        .args(FLAGS)
        .args(["--json", "-o"])
        .arg(t.path().join("out"))
        .stdin(std::process::Stdio::null());
    // SAFETY: prctl and `limit_address_space` (setrlimit) are async-signal-safe and allocate
    // nothing.
    unsafe {
        cmd.pre_exec(move || {
            // CAP_SYS_RESOURCE is 24; failing to drop it (not root) is fine.
            libc::prctl(libc::PR_CAPBSET_DROP, 24, 0, 0, 0);
            sdfmo_harness::limit_address_space(limit)
        });
    }
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let j: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["shard"]["done"], 1, "{j}");
}
