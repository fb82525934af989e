//! docs/architecture.md draws the crate graph; this test reads the drawing and compares it, edge
//! by edge, with what `cargo metadata` says the manifests declare, so the page cannot drift
//! from the code (issue 36: it missed `sdfmo-distance → sdfmo-io`, `sdfmo-build → sdfmo-mesh`,
//! `sdfmo-py` and the benches).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

use serde_json::Value;

/// An edge of the graph: (package, dependency, the feature that turns it on if optional).
type Edge = (String, String, Option<String>);

/// The packages and edges of the ```mermaid block of docs/architecture.md: nodes `id[name]`,
/// edges `a --> b` (normal) and `a -.->|feature| b` (optional).
fn drawn(doc: &str) -> (BTreeSet<String>, BTreeSet<Edge>) {
    let block = doc
        .split("```mermaid\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("docs/architecture.md has a ```mermaid block");
    let mut names: BTreeMap<&str, &str> = BTreeMap::new();
    let mut edges = Vec::new();
    for line in block.lines().map(str::trim) {
        if line.is_empty() || line.starts_with("flowchart") {
            continue;
        }
        if let Some((id, rest)) = line.split_once('[') {
            let name = rest
                .strip_suffix(']')
                .unwrap_or_else(|| panic!("node {line:?}"));
            assert!(names.insert(id, name).is_none(), "node {id} drawn twice");
        } else if let Some((from, to)) = line.split_once(" --> ") {
            edges.push((from, to.trim(), None));
        } else if let Some((from, rest)) = line.split_once(" -.->|") {
            let (feature, to) = rest
                .split_once("| ")
                .unwrap_or_else(|| panic!("edge {line:?}"));
            edges.push((from, to.trim(), Some(feature.to_owned())));
        } else {
            panic!("neither a node nor an edge: {line:?}");
        }
    }
    let name = |id: &str| -> String {
        names
            .get(id)
            .unwrap_or_else(|| panic!("edge to the undeclared node {id}"))
            .to_string()
    };
    let edges = edges
        .into_iter()
        .map(|(from, to, feature)| (name(from), name(to), feature))
        .collect();
    (names.values().map(|n| n.to_string()).collect(), edges)
}

/// The workspace's packages and the normal dependencies between them, from `cargo metadata`.
fn declared(root: &Path) -> (BTreeSet<String>, BTreeSet<Edge>) {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--no-deps"])
        .current_dir(root)
        .output()
        .expect("cannot run cargo metadata");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = meta["packages"].as_array().unwrap();
    let names: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_owned())
        .collect();
    let mut edges = BTreeSet::new();
    for p in packages {
        let features = p["features"].as_object().unwrap();
        for d in p["dependencies"].as_array().unwrap() {
            let dep = d["name"].as_str().unwrap();
            // `kind` is null for a normal dependency ("dev", "build" otherwise).
            if !names.contains(dep) || !d["kind"].is_null() {
                continue;
            }
            let feature = d["optional"].as_bool().unwrap().then(|| {
                // The feature naming `dep:NAME`, else the implicit feature of the same name.
                let wanted = format!("dep:{dep}");
                features
                    .iter()
                    .find(|(_, v)| v.as_array().unwrap().iter().any(|x| x == &wanted))
                    .map_or(dep.to_owned(), |(f, _)| f.clone())
            });
            edges.insert((
                p["name"].as_str().unwrap().to_owned(),
                dep.to_owned(),
                feature,
            ));
        }
    }
    (names, edges)
}

#[test]
fn the_drawn_crate_graph_is_the_manifests_graph() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("docs/architecture.md")).unwrap();
    let (doc_names, doc_edges) = drawn(&doc);
    let (names, edges) = declared(root);
    assert_eq!(
        doc_names, names,
        "the packages drawn in docs/architecture.md against the workspace's"
    );
    let missing: Vec<&Edge> = edges.difference(&doc_edges).collect();
    let extra: Vec<&Edge> = doc_edges.difference(&edges).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "docs/architecture.md's graph lacks {missing:?} and draws {extra:?}, which no manifest \
         declares"
    );
}

#[test]
fn the_parser_reads_both_kinds_of_edge_and_refuses_an_undeclared_node() {
    let doc =
        "x\n```mermaid\nflowchart BT\n  a[pkg-a]\n  b[pkg-b]\n  a --> b\n  b -.->|feat| a\n```\n";
    let (names, edges) = drawn(doc);
    assert_eq!(names.len(), 2);
    assert!(edges.contains(&("pkg-a".into(), "pkg-b".into(), None)));
    assert!(edges.contains(&("pkg-b".into(), "pkg-a".into(), Some("feat".into()))));
    let bad = "```mermaid\n  a[pkg-a]\n  a --> c\n```\n";
    assert!(std::panic::catch_unwind(|| drawn(bad)).is_err());
}
