//! Helpers shared by the render crate's integration tests.
#![allow(dead_code)]

use sdfmo_render::{render, Camera, Mode, RenderSettings, Rendered, Traceable};

/// Settings of a test render: `mode`, shadows, `ao` samples, on `threads` workers.
pub fn settings(mode: Mode, shadows: bool, ao: u32, threads: usize) -> RenderSettings {
    RenderSettings {
        mode,
        shadows,
        ao_samples: ao,
        threads: Some(threads),
    }
}

/// `scene` rendered from `camera` with [`settings`] on two threads.
pub fn shot<T: Traceable>(
    scene: &T,
    camera: &Camera,
    mode: Mode,
    shadows: bool,
    ao: u32,
) -> Rendered {
    render(scene, camera, &settings(mode, shadows, ao, 2)).unwrap()
}
