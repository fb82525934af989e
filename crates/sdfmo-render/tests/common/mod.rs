//! Helpers shared by the render crate's integration tests.
#![allow(dead_code)]

use sdfmo_render::{render, Camera, Mode, RenderSettings, Rendered, Traceable};

/// Settings of a test render: `mode`, shadows, `ao` samples.
pub fn settings(mode: Mode, shadows: bool, ao: u32) -> RenderSettings {
    RenderSettings::new(mode)
        .with_shadows(shadows)
        .with_ao_samples(ao)
}

/// `f` run on a pool of `threads` workers (the renderer runs on the caller's pool).
pub fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a pool")
        .install(f)
}

/// `scene` rendered from `camera` with [`settings`] on two threads.
pub fn shot<T: Traceable>(
    scene: &T,
    camera: &Camera,
    mode: Mode,
    shadows: bool,
    ao: u32,
) -> Rendered {
    on_threads(2, || {
        render(scene, camera, &settings(mode, shadows, ao)).unwrap()
    })
}
