//! The crate's error type.

/// Everything that can go wrong on the GPU path. No adapter, a refused device, a file the
/// format rejects and a limit the adapter cannot meet are errors, never panics.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No GPU adapter (Vulkan, Metal or DirectX 12) was found: no driver installed, or none that
    /// wgpu accepts. On Debian, `apt-get install mesa-vulkan-drivers` provides a software one.
    #[error("no GPU adapter found ({reason}); on Debian, mesa-vulkan-drivers provides lavapipe")]
    NoAdapter {
        /// wgpu's reason.
        reason: String,
    },
    /// The adapter refused to open a device with the features and limits asked for.
    #[error("the GPU adapter {adapter} refused a device")]
    RequestDevice {
        /// The adapter's name.
        adapter: String,
        /// wgpu's error.
        #[source]
        source: wgpu::RequestDeviceError,
    },
    /// The octree bytes are not a valid `.smo` file (validated before upload: the kernel trusts
    /// every count and index it reads).
    #[error("invalid octree")]
    Format(#[from] sdfmo_format::FormatError),
    /// A buffer would exceed what the adapter can bind (`max_storage_buffer_binding_size`) or
    /// dispatch.
    #[error("{what} needs {needed} bytes, over the adapter's limit of {limit}")]
    TooLarge {
        /// Which buffer.
        what: &'static str,
        /// Bytes needed.
        needed: u64,
        /// The adapter's limit.
        limit: u64,
    },
    /// The `.smo` file is too long for the kernel's 32-bit section offsets
    /// ([`crate::MAX_GPU_FILE_BYTES`]), whatever the adapter could bind.
    #[error("the octree has {needed} bytes; the GPU kernel reads files of at most {limit} bytes (32-bit section offsets)")]
    FileTooLarge {
        /// The file's length.
        needed: u64,
        /// [`crate::MAX_GPU_FILE_BYTES`].
        limit: u64,
    },
    /// The camera or the settings cannot be rendered: the renderer's own checks
    /// ([`sdfmo_render::Camera::frame`], [`sdfmo_render::RenderPlan::new`]), settings the
    /// kernel does not render (shadows, occlusion), a pixel error that is not finite
    /// and > 0, an image over the adapter's dispatch limit.
    #[error(transparent)]
    Render(#[from] sdfmo_render::RenderError),
    /// The octree was uploaded through another [`crate::GpuRenderer`] (another device).
    #[error("the octree was uploaded to another GPU renderer")]
    ForeignOctree,
    /// wgpu reported an error on the device: shader compilation, validation, out of memory,
    /// a lost device.
    #[error("GPU error: {0}")]
    Device(String),
    /// Reading a result back failed (the buffer could not be mapped).
    #[error("cannot read the GPU's result back")]
    Readback(#[from] wgpu::BufferAsyncError),
    /// The GPU did not finish within the renderer's time-out ([`crate::GpuRenderer::set_timeout`]):
    /// a frame too heavy for the device, or a hung driver. The work may still be running; drop
    /// the renderer.
    #[error("the GPU did not finish within {after:?} (the renderer's time-out); the octree may be too heavy to render on this device")]
    Timeout {
        /// The time waited.
        after: std::time::Duration,
    },
    /// Waiting for the GPU failed (lost device, a bad submission index).
    #[error("waiting for the GPU failed")]
    Poll(#[from] wgpu::PollError),
}

/// `Result` with [`GpuError`].
pub type Result<T> = std::result::Result<T, GpuError>;
