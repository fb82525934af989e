//! The crate's one error type.

/// Result alias used throughout the crate.
pub type Result<T, E = MeshError> = std::result::Result<T, E>;

/// Everything that can go wrong when loading or building a mesh.
///
/// Every variant names the file (`file`: the path, or the name given to
/// [`crate::load_mesh_from_bytes`], or `<memory>` for [`crate::TriMesh::new`]) and says what
/// was wrong. Loading never panics and never allocates by an unchecked count from a header.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The file could not be read: missing, not a regular file (a device, FIFO or directory),
    /// larger than [`LoadLimits::max_file_bytes`](crate::LoadLimits), unreadable.
    #[error(transparent)]
    Io(#[from] sdfmo_io::IoError),
    /// An external glTF buffer could not be read: its URI leaves the model's folder, or the
    /// file is missing or not a regular file (the source says which).
    #[error("{file}: external buffer {index}")]
    ExternalBuffer {
        /// The glTF file.
        file: String,
        /// The buffer's index.
        index: usize,
        /// Why it could not be read.
        #[source]
        source: sdfmo_io::IoError,
    },
    /// Neither the extension nor the content identify a supported format.
    #[error("{file}: unknown mesh format ({reason})")]
    UnknownFormat {
        /// The file.
        file: String,
        /// What was seen.
        reason: String,
    },
    /// The file ends before the data it announces.
    #[error("{file}: truncated: {reason}")]
    Truncated {
        /// The file.
        file: String,
        /// What was missing.
        reason: String,
    },
    /// A header or count disagrees with the rest of the file (e.g. a binary STL triangle count
    /// that does not match the file length).
    #[error("{file}: header does not match the data: {reason}")]
    HeaderMismatch {
        /// The file.
        file: String,
        /// The disagreement.
        reason: String,
    },
    /// A count above the loader's limit (see [`crate::LoadLimits`]): refused before allocating.
    #[error("{file}: too large: {what} is {count}, the limit is {limit}")]
    TooLarge {
        /// The file.
        file: String,
        /// What was counted.
        what: String,
        /// The count found or announced.
        count: u64,
        /// The limit in force.
        limit: u64,
    },
    /// Memory for the mesh's arrays could not be allocated (a file whose counts need more than
    /// the process may map, e.g. under an address-space limit): refused, never an abort.
    #[error("{file}: out of memory: cannot allocate {bytes} bytes for {what}")]
    OutOfMemory {
        /// The file.
        file: String,
        /// What was being allocated.
        what: String,
        /// The bytes asked for.
        bytes: u64,
    },
    /// A coordinate is NaN or infinite.
    #[error("{file}: {element} has a non-finite coordinate ({value})")]
    NonFinite {
        /// The file.
        file: String,
        /// The element, e.g. `vertex 12`.
        element: String,
        /// The offending value, as text.
        value: String,
    },
    /// A triangle refers to a vertex that does not exist (out of range or negative).
    #[error("{file}: {element} refers to vertex {index}, but there are {vertex_count} vertices")]
    IndexOutOfRange {
        /// The file.
        file: String,
        /// The element, e.g. `triangle 7`.
        element: String,
        /// The index as written (may be negative).
        index: i64,
        /// Number of vertices available.
        vertex_count: usize,
    },
    /// The file holds no (non-degenerate) triangle.
    #[error("{file}: no triangles ({reason})")]
    NoTriangles {
        /// The file.
        file: String,
        /// Why: empty, only points/lines, or everything degenerate.
        reason: String,
    },
    /// Syntax error in a text format or malformed structure in a binary one.
    #[error("{file}: parse error{}: {reason}", line.map(|l| format!(" at line {l}")).unwrap_or_default())]
    Parse {
        /// The file.
        file: String,
        /// 1-based line number, for text formats when known.
        line: Option<usize>,
        /// What was wrong.
        reason: String,
    },
    /// Valid input using a feature this loader does not support (e.g. an external glTF buffer
    /// when loading from bytes, a URI scheme other than `data:` or a relative path).
    #[error("{file}: unsupported: {reason}")]
    Unsupported {
        /// The file.
        file: String,
        /// The feature.
        reason: String,
    },
    /// Arrays of an in-memory mesh disagree (e.g. part ids vs triangles).
    #[error("{file}: invalid mesh: {reason}")]
    InvalidMesh {
        /// The file (`<memory>` for [`crate::TriMesh::new`]).
        file: String,
        /// What disagrees.
        reason: String,
    },
}

impl MeshError {
    /// The file named by the error.
    pub fn file(&self) -> String {
        match self {
            MeshError::Io(e) => e.path().display().to_string(),
            MeshError::ExternalBuffer { file, .. }
            | MeshError::UnknownFormat { file, .. }
            | MeshError::Truncated { file, .. }
            | MeshError::HeaderMismatch { file, .. }
            | MeshError::TooLarge { file, .. }
            | MeshError::OutOfMemory { file, .. }
            | MeshError::NonFinite { file, .. }
            | MeshError::IndexOutOfRange { file, .. }
            | MeshError::NoTriangles { file, .. }
            | MeshError::Parse { file, .. }
            | MeshError::Unsupported { file, .. }
            | MeshError::InvalidMesh { file, .. } => file.clone(),
        }
    }
}
