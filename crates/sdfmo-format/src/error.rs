//! The crate's error type.

/// Everything that can go wrong when building, writing or reading a packed octree.
///
/// Building errors name the offending leaf by its coordinates; file errors name the field or
/// section that failed validation, so a corrupt file can be diagnosed from the message alone.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FormatError {
    /// The octree depth is larger than [`MAX_DEPTH`](crate::MAX_DEPTH).
    #[error("octree depth {depth} is not supported (maximum {max})")]
    InvalidDepth {
        /// The depth that was asked for.
        depth: u8,
        /// The largest supported depth.
        max: u8,
    },
    /// The normalisation transform is not usable (non-finite centre, scale not finite and > 0).
    #[error("invalid normalisation transform: center {center:?}, scale {scale}")]
    InvalidTransform {
        /// The centre that was given.
        center: [f32; 3],
        /// The scale that was given.
        scale: f32,
    },
    /// A leaf coordinate lies outside `[0, 2^depth)`.
    #[error("leaf {index} has coordinate {coord:?} outside [0, {side}) for depth {depth}")]
    CoordOutOfRange {
        /// Position of the leaf in the input vector.
        index: usize,
        /// Its coordinate.
        coord: [u32; 3],
        /// The octree depth.
        depth: u8,
        /// `2^depth`.
        side: u64,
    },
    /// Two input leaves have the same coordinate.
    #[error("two leaves have the same coordinate {coord:?}")]
    DuplicateLeaf {
        /// The duplicated coordinate.
        coord: [u32; 3],
    },
    /// A leaf has no voxel or more than [`MAX_VOXELS_PER_LEAF`](crate::MAX_VOXELS_PER_LEAF).
    #[error("leaf at {coord:?} has {count} voxels (must be 1..={max})")]
    VoxelCount {
        /// The leaf's coordinate.
        coord: [u32; 3],
        /// Its number of voxels.
        count: usize,
        /// The largest allowed count.
        max: usize,
    },
    /// Every voxel of a leaf is a clip-only voxel (surface + clip): nothing in it could be hit.
    #[error("leaf at {coord:?} has only clip-only voxels (surface + clip): nothing to hit")]
    ClipOnlyLeaf {
        /// The leaf's coordinate.
        coord: [u32; 3],
    },
    /// A leaf has more than [`MAX_CLIP_VOXELS_PER_LEAF`](crate::MAX_CLIP_VOXELS_PER_LEAF)
    /// voxels with the clip bit (the bound that keeps the clip rule's work per leaf linear).
    #[error("leaf at {coord:?} has {count} clip voxels (at most {max})")]
    ClipCount {
        /// The leaf's coordinate.
        coord: [u32; 3],
        /// Its number of voxels with the clip bit.
        count: usize,
        /// The largest allowed count.
        max: usize,
    },
    /// A corner value is NaN or infinite.
    #[error("leaf at {coord:?}, voxel {voxel}, corner {corner} is not finite ({value})")]
    NonFiniteCorner {
        /// The leaf's coordinate.
        coord: [u32; 3],
        /// Index of the voxel in the leaf.
        voxel: usize,
        /// Corner index (4x + 2y + z).
        corner: usize,
        /// The offending value.
        value: f32,
    },
    /// A count does not fit the format's 32-bit indices.
    #[error("too many {what}: {count} (the format indexes them with 32 bits)")]
    TooLarge {
        /// What overflowed (nodes, leaves, voxels).
        what: &'static str,
        /// How many there were.
        count: u64,
    },
    /// The octree cannot be written in the format asked for (a 3.0 brick file needs depth ≥ 2
    /// and its residual section under 1 GiB).
    #[error("cannot write a version {major}.x .smo file: {reason}")]
    Unrepresentable {
        /// The major version asked for.
        major: u16,
        /// Why not.
        reason: String,
    },
    /// The bytes are shorter than the header or than the size the header declares.
    #[error("truncated .smo data: {len} bytes, need {needed}")]
    Truncated {
        /// Bytes available.
        len: usize,
        /// Bytes needed.
        needed: u64,
    },
    /// A prefix of a file with levels ends inside a level (after its first byte, before its
    /// last): only a whole file, or a prefix cut where a level ends, can be drawn
    /// ([`SmoFile::from_prefix`](crate::SmoFile::from_prefix)).
    #[error(
        "truncated .smo data: {len} bytes end inside level {level} (bytes {start}..{end}); a \
         file with levels is read whole or cut where a level ends"
    )]
    CutInsideLevel {
        /// Bytes available.
        len: u64,
        /// The level the data ends in.
        level: u8,
        /// Where that level starts.
        start: u64,
        /// Where it ends (a prefix of this many bytes holds it).
        end: u64,
    },
    /// The first eight bytes are not the `.smo` magic.
    #[error("not a .smo file (bad magic {found:02x?})")]
    BadMagic {
        /// The bytes found where the magic belongs.
        found: [u8; 8],
    },
    /// The file's major version is not one this reader understands.
    #[error("unsupported .smo version {major}.{minor} (this reader reads {supported}.x)")]
    UnsupportedVersion {
        /// Major version in the file.
        major: u16,
        /// Minor version in the file.
        minor: u16,
        /// The major version this reader supports.
        supported: u16,
    },
    /// The stored CRC-32 does not match the data.
    #[error("checksum mismatch: stored {stored:#010x}, computed {computed:#010x}")]
    ChecksumMismatch {
        /// The checksum in the file.
        stored: u32,
        /// The checksum of the data.
        computed: u32,
    },
    /// A header field or a section is inconsistent (the checksum was valid, the content is not).
    #[error("corrupt .smo {field}: {reason}")]
    Corrupt {
        /// The header field or section that is wrong.
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// Reading or writing a file failed: not found, not a regular file, too large, a refused
    /// destination, a full disk (see [`sdfmo_io::IoError`]).
    #[error(transparent)]
    Io(#[from] sdfmo_io::IoError),
}

impl FormatError {
    pub(crate) fn corrupt(field: &'static str, reason: impl Into<String>) -> Self {
        FormatError::Corrupt {
            field,
            reason: reason.into(),
        }
    }
}

/// `Err(`[`FormatError::Corrupt`]`)` naming the field and why, for the readers' checks.
pub(crate) fn corrupt<T>(field: &'static str, reason: impl Into<String>) -> Result<T> {
    Err(FormatError::corrupt(field, reason))
}

/// Result alias of this crate.
pub type Result<T, E = FormatError> = std::result::Result<T, E>;
