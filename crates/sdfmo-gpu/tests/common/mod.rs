//! What the GPU tests share: the renderer, or a skip when there is no adapter.

use sdfmo_gpu::GpuRenderer;

/// The renderer, or `None` (with a message) when there is no adapter and none is required
/// (`SDFMO_REQUIRE_GPU=1` makes a missing adapter a failure).
pub fn gpu() -> Option<GpuRenderer> {
    match GpuRenderer::new() {
        Ok(g) => Some(g),
        Err(e) if std::env::var("SDFMO_REQUIRE_GPU").as_deref() == Ok("1") => {
            panic!("SDFMO_REQUIRE_GPU=1 but no GPU renderer: {e}")
        }
        Err(e) => {
            eprintln!("skipped: no GPU adapter ({e}); set SDFMO_REQUIRE_GPU=1 to fail instead");
            None
        }
    }
}
