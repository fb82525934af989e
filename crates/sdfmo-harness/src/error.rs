//! The harness's errors: one enum, [`HarnessError`], a variant per concern, each naming what was
//! wrong (the mesh, the configuration, the file, the shard folder); the concerns with several
//! cases have their own enums ([`ManifestError`], [`ShardError`], [`MergeError`],
//! [`ExtraRowsError`]). A front-end prints the chain on one line (`sdfmo: error: …`, exit 2);
//! [`HarnessError::ModelsFailed`] is the one that is not an error of the command (exit 3).

use std::path::PathBuf;

use sdf_multioctree::build::BuildError;
use sdf_multioctree::io::IoError;
use sdf_multioctree::mesh::MeshError;
use sdf_multioctree::metrics::MetricsError;
use sdf_multioctree::render::ProtocolError;

pub use crate::report::extra::ExtraRowsError;
use crate::Shard;

/// The harness's result.
pub type Result<T> = std::result::Result<T, HarnessError>;

/// What went wrong in a sweep, a shard or a merge.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HarnessError {
    /// A file could not be read or written (the path is in the message).
    #[error(transparent)]
    Io(#[from] IoError),
    /// A mesh could not be loaded (the file is in the message).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A build of the sweep would exceed the memory budget, checked before any work.
    #[error("cannot sweep {method} {mesh}")]
    OverBudget {
        /// The method.
        method: &'static str,
        /// The mesh, as given.
        mesh: String,
        /// The builder's refusal.
        #[source]
        source: Box<BuildError>,
    },
    /// A build failed.
    #[error("cannot build {method} {depths} of {mesh}")]
    Build {
        /// The method.
        method: &'static str,
        /// `depth D`, or `with levels A..=B`.
        depths: String,
        /// The mesh, as given.
        mesh: String,
        /// The builder's error.
        #[source]
        source: Box<BuildError>,
    },
    /// The reference images of a mesh could not be rendered.
    #[error("cannot render the reference of {mesh}")]
    Reference {
        /// The mesh, as given.
        mesh: String,
        /// The protocol's error.
        #[source]
        source: Box<ProtocolError>,
    },
    /// An octree of the sweep could not be rendered and scored.
    #[error("cannot render {method} depth {depth}")]
    Score {
        /// The method.
        method: &'static str,
        /// The depth.
        depth: u8,
        /// The protocol's error.
        #[source]
        source: Box<ProtocolError>,
    },
    /// The worker pool of `threads` could not be started.
    #[error("cannot start {threads} worker threads")]
    Threads {
        /// The workers asked for.
        threads: usize,
        /// Rayon's error.
        #[source]
        source: rayon::ThreadPoolBuildError,
    },
    /// An image of the report could not be encoded as PNG.
    #[error("cannot encode {}", path.display())]
    Png {
        /// The file it was for.
        path: PathBuf,
        /// The encoder's error.
        #[source]
        source: Box<image::ImageError>,
    },
    /// An image of the report could not be read back or compared (the zoomed crops).
    #[error(transparent)]
    Metrics(#[from] MetricsError),
    /// A plot could not be drawn.
    #[error("cannot draw {plot}: {reason}")]
    Plot {
        /// The plot's file.
        plot: String,
        /// The plotting library's error.
        reason: String,
    },
    /// The font embedded for the plots does not parse.
    #[error("the embedded plot font cannot be parsed")]
    PlotFont,
    /// The CSV writer failed.
    #[error("cannot write CSV")]
    Csv(#[from] csv::Error),
    /// A report template (table.md, dataset.md, a page) failed to render.
    #[error("cannot render a report template")]
    Template(#[from] askama::Error),
    /// Something the harness writes as JSON could not be serialised.
    #[error("cannot serialise {what}")]
    Serialise {
        /// What it was.
        what: &'static str,
        /// The serialiser's error.
        #[source]
        source: serde_json::Error,
    },
    /// A file of rows from another producer (`--extra-rows`) was refused.
    #[error(transparent)]
    ExtraRows(#[from] ExtraRowsError),
    /// The manifest of a dataset sweep was refused.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// The shard to run could not be told, or its output folder holds another one.
    #[error(transparent)]
    Shard(#[from] ShardError),
    /// Shard folders cannot be merged.
    #[error(transparent)]
    Merge(#[from] MergeError),
    /// A shard's `shard.json` does not parse.
    #[error("{} is not a shard description", path.display())]
    NotShardDescription {
        /// The file.
        path: PathBuf,
        /// The parser's error.
        #[source]
        source: serde_json::Error,
    },
    /// The running executable, which a shard runs each model in, cannot be found.
    #[error("cannot find the sdfmo binary to run a model in")]
    NoExecutable(#[source] std::io::Error),
    /// A model's process could not be started.
    #[error("cannot start a model's process")]
    Spawn(#[source] std::io::Error),
    /// A shard ran every model, recorded them and wrote its outputs, but some models failed:
    /// not an error of the command (exit code [`crate::EXIT_MODELS_FAILED`]).
    #[error(transparent)]
    ModelsFailed(#[from] ModelsFailed),
}

/// The error a shard ends with when some of its models failed: every model was tried and
/// recorded, the outputs are written, and the exit code ([`crate::EXIT_MODELS_FAILED`]) tells a
/// job scheduler apart from an error of the shard itself (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{failed} of {total} models failed (recorded in the ledger and shard.json)")]
pub struct ModelsFailed {
    /// Failed models.
    pub failed: usize,
    /// Models of the shard.
    pub total: usize,
}

/// Why a manifest was refused as a whole (a problem of one line is a failure of that model).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ManifestError {
    /// The file could not be read (missing, not regular, over the size limit, not UTF-8).
    #[error("cannot read the manifest (split manifests over {limit} bytes)")]
    Read {
        /// The size limit.
        limit: u64,
        /// The read's error, naming the file.
        #[source]
        source: IoError,
    },
    /// A `.csv` manifest is not CSV.
    #[error("{}: not a CSV manifest", path.display())]
    Csv {
        /// The manifest.
        path: PathBuf,
        /// The CSV reader's error.
        #[source]
        source: csv::Error,
    },
    /// More entries than a manifest may hold.
    #[error("{}: {entries} entries, more than {max}: split the manifest", path.display())]
    TooManyEntries {
        /// The manifest.
        path: PathBuf,
        /// Entries found.
        entries: usize,
        /// The limit.
        max: usize,
    },
    /// No entry at all.
    #[error("{}: the manifest lists no model", path.display())]
    Empty {
        /// The manifest.
        path: PathBuf,
    },
    /// Two lines of one id: ledgers and the merge know a model by its id.
    #[error(
        "{}: line {line}: the id {id:?} is given twice (first on line {first}); ids must be \
         unique, the ledgers know a model by its id",
        path.display()
    )]
    DuplicateId {
        /// The manifest.
        path: PathBuf,
        /// The second line.
        line: usize,
        /// The id (shortened to 120 characters).
        id: String,
        /// The first line.
        first: usize,
    },
}

/// Why the shard to run could not be told, or cannot run into its folder.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ShardError {
    /// Not `0 <= K < N <= MAX`.
    #[error("shard {index}/{count}: need 0 <= K < N <= {max}")]
    OutOfRange {
        /// K.
        index: usize,
        /// N.
        count: usize,
        /// The most shards.
        max: usize,
    },
    /// An environment variable of the job array is not a count.
    #[error("{var}={value:?} is not a count")]
    NotACount {
        /// The variable.
        var: &'static str,
        /// Its value.
        value: String,
        /// The parser's error.
        #[source]
        source: std::num::ParseIntError,
    },
    /// One variable of a pair is set without the other.
    #[error("{set} is set but {missing} is not{hint}")]
    Unpaired {
        /// The variable set.
        set: &'static str,
        /// The one missing.
        missing: &'static str,
        /// What to set it to.
        hint: &'static str,
    },
    /// A Slurm array task that is not one of `count` contiguous shards.
    #[error(
        "array task {id} (first {min}, {count} tasks) is not one of {count} contiguous shards: \
         submit the array as --array=0-{} (or give --shard K/N)",
        count.saturating_sub(1)
    )]
    ArrayTask {
        /// `SLURM_ARRAY_TASK_ID`.
        id: usize,
        /// `SLURM_ARRAY_TASK_MIN`.
        min: usize,
        /// `SLURM_ARRAY_TASK_COUNT`.
        count: usize,
    },
    /// The output folder holds another shard (or a shard of another manifest).
    #[error(
        "{} holds shard {held} of a manifest of {held_entries} models; this is shard {shard} of \
         {entries} models: give each shard its own -o folder",
        out.display()
    )]
    OtherShardsFolder {
        /// The output folder.
        out: PathBuf,
        /// The shard its shard.json names.
        held: Shard,
        /// Entries of that shard's manifest.
        held_entries: usize,
        /// The shard this run is.
        shard: Shard,
        /// Entries of this run's manifest.
        entries: usize,
    },
}

/// Why shard folders cannot be merged into `OUT`. Each names the folder or file and what is
/// wrong.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MergeError {
    /// `OUT` is one of the shard folders, or inside one: the merge would overwrite its input.
    #[error(
        "-o {} is inside the shard folder {}: merge into a folder of its own",
        out.display(),
        shard.display()
    )]
    OutputInsideInput {
        /// The output folder as given.
        out: PathBuf,
        /// The shard folder it is in.
        shard: PathBuf,
    },
    /// `OUT` cannot be placed: `..` after a folder that does not exist yet.
    #[error("-o {}: cannot tell where it lands (`..` after a folder that does not exist)", out.display())]
    OutputUnresolved {
        /// The output folder as given.
        out: PathBuf,
    },
    /// A shard folder cannot be resolved to compare it with `OUT`.
    #[error("cannot resolve {}", dir.display())]
    Unresolvable {
        /// The folder.
        dir: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A folder has no readable `shard.json`.
    #[error("{} is not the output folder of a manifest sweep", dir.display())]
    NotShardFolder {
        /// The folder.
        dir: PathBuf,
        /// Why its `shard.json` could not be read.
        #[source]
        source: IoError,
    },
    /// `shard.json` says what no sweep writes.
    #[error("{}: {reason}", path.display())]
    BadShardFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A current ledger record says what no sweep writes.
    #[error("{}: the record of {id:?} (manifest entry {index}): {reason}", path.display())]
    BadRecord {
        /// The ledger.
        path: PathBuf,
        /// The record's manifest position.
        index: usize,
        /// Its id (shortened to 120 characters).
        id: String,
        /// What is wrong.
        reason: String,
    },
    /// Two folders ran with other settings.
    #[error(
        "{} ran with other settings than {} (settings {} against {}): merge shards of one run",
        .0.dir.display(),
        .0.first.display(),
        .0.hash,
        .0.first_hash
    )]
    OtherSettings(HashPair),
    /// Two folders are shards of manifests of other lengths or other shard counts.
    #[error(
        "{} is shard {shard} of a manifest of {entries} models, {} is shard {first_shard} of \
         {first_entries}: merge shards of one run",
        dir.display(),
        first.display()
    )]
    OtherRun {
        /// The folder.
        dir: PathBuf,
        /// Its shard.
        shard: Shard,
        /// Its manifest's entries.
        entries: usize,
        /// The first folder.
        first: PathBuf,
        /// The first folder's shard.
        first_shard: Shard,
        /// The first folder's manifest's entries.
        first_entries: usize,
    },
    /// Two folders ran on other versions of the manifest.
    #[error(
        "{} and {} ran on different versions of the manifest (fingerprints {} and {}): rerun the \
         older shard with the current manifest",
        .0.dir.display(),
        .0.first.display(),
        .0.hash,
        .0.first_hash
    )]
    ManifestVersions(HashPair),
    /// A shard is given twice.
    #[error("shard {shard} is given twice ({} and {})", first.display(), second.display())]
    ShardTwice {
        /// The shard.
        shard: Shard,
        /// Its first folder.
        first: PathBuf,
        /// Its second folder.
        second: PathBuf,
    },
    /// Some shards are missing.
    #[error("shards {} are missing: give every shard's folder", missing.join(", "))]
    ShardsMissing {
        /// The missing shards, as `K/N`.
        missing: Vec<String>,
    },
    /// The shards' entry fingerprints make another manifest than the one they name.
    #[error(
        "the shards' entry fingerprints make the manifest {whole}, not the {named} their \
         shard.json files name: merge shards of one run"
    )]
    Fingerprints {
        /// The manifest fingerprint of the shards' entries.
        whole: String,
        /// The one their shard.json files name.
        named: String,
    },
    /// Entries of the manifest have no current ledger record: the merge wrote its report
    /// without them and ends with this.
    #[error(
        "{unfinished} of {total} models have no current ledger record (manifest entries \
         {}{}): a shard did not finish, or ran before the manifest was edited (rerun it, then \
         merge again)",
        first.iter().map(usize::to_string).collect::<Vec<_>>().join(", "),
        if *unfinished > first.len() { ", …" } else { "" }
    )]
    Unfinished {
        /// Entries without a record.
        unfinished: usize,
        /// Entries of the manifest.
        total: usize,
        /// The first few of them.
        first: Vec<usize>,
    },
}

/// An error and its sources on one line, `a: b: c` (the facade's
/// [`sdf_multioctree::error_chain`]), for the error texts the harness keeps: a manifest line's
/// problem, the crops' note on the page.
pub use sdf_multioctree::error_chain as error_line;

/// A fingerprint that differs between two shard folders ([`MergeError::OtherSettings`],
/// [`MergeError::ManifestVersions`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HashPair {
    /// The folder.
    pub dir: PathBuf,
    /// The first folder.
    pub first: PathBuf,
    /// Its fingerprint.
    pub hash: String,
    /// The first folder's.
    pub first_hash: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_line_holds_each_cause_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let e = HarnessError::Spawn(io);
        assert_eq!(
            error_line(&e),
            "cannot start a model's process: no such file"
        );
        let e = HarnessError::from(ManifestError::Empty {
            path: "m.txt".into(),
        });
        assert_eq!(error_line(&e), "m.txt: the manifest lists no model");
    }
}
