//! The paper's protocol in one place (`docs/architecture.md`, "Paper protocol" and "Metrics"):
//! reference renders of the source mesh from the paper's views, then, for each octree, the same
//! views rendered and compared with the references (PSNR and LDR-FLIP), averaged over the views.
//! The CLI's sweep, the examples and the tests call this rather than repeating the loop.

use image::RgbImage;
use rayon::prelude::*;
use sdfmo_distance::{MeshDistance, SignMode};
use sdfmo_mesh::TriMesh;
use sdfmo_metrics::FlipResult;

use crate::{render, Camera, MeshScene, Mode, RenderError, RenderSettings, Traceable};

/// What can go wrong in the protocol: preparing the mesh's ray queries, rendering, comparing.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ProtocolError {
    /// The mesh's ray queries could not be prepared.
    #[error("cannot prepare ray queries on the mesh")]
    Distance(#[source] sdfmo_distance::DistanceError),
    /// A view could not be rendered.
    #[error(transparent)]
    Render(RenderError),
    /// An image could not be compared with its reference.
    #[error(transparent)]
    Metrics(sdfmo_metrics::MetricsError),
}

/// The reference images of the paper's views and the settings they were rendered with.
#[derive(Clone, Debug)]
pub struct PaperProtocol {
    cameras: Vec<Camera>,
    settings: RenderSettings,
    references: Vec<RgbImage>,
    reference_ms: f64,
    /// Renders of each view that [`PaperProtocol::score`] times (at least 1).
    frames: usize,
}

/// One view of an octree under the protocol: its image, render time and scores.
#[derive(Clone, Debug)]
pub struct ViewScore {
    /// The rendered view (8-bit RGB).
    pub image: RgbImage,
    /// Render time (ms): the median over the protocol's [`frames`](PaperProtocol::frames).
    pub render_ms: f64,
    /// PSNR against the reference in dB (`f64::INFINITY` for identical images).
    pub psnr: f64,
    /// LDR-FLIP against the reference (its mean and per-pixel map).
    pub flip: FlipResult,
}

/// Every view of an octree under the protocol, in camera order, and their means.
#[derive(Clone, Debug)]
pub struct Score {
    /// The views, in the order of [`PaperProtocol::cameras`].
    pub views: Vec<ViewScore>,
}

impl Score {
    /// Mean of `f` over the views (0 for none), summed in view order from +0.
    fn mean(&self, f: impl Fn(&ViewScore) -> f64) -> f64 {
        let sum = self.views.iter().map(f).fold(0.0, |a, b| a + b);
        sum / self.views.len().max(1) as f64
    }

    /// Mean PSNR over the views in dB (infinite when a view matches its reference exactly).
    pub fn psnr(&self) -> f64 {
        self.mean(|v| v.psnr)
    }

    /// Mean FLIP over the views.
    pub fn flip(&self) -> f64 {
        self.mean(|v| f64::from(v.flip.mean))
    }

    /// Mean render time of one view (ms).
    pub fn render_ms(&self) -> f64 {
        self.mean(|v| v.render_ms)
    }

    /// The worst view's PSNR in dB.
    pub fn min_psnr(&self) -> f64 {
        self.views
            .iter()
            .map(|v| v.psnr)
            .fold(f64::INFINITY, f64::min)
    }
}

impl PaperProtocol {
    /// The protocol for `mesh` (model units): normalised with `margin` exactly as the builder
    /// does, ray traced from the paper's four views at `size` × `size` in lambert with face
    /// normals, on the caller's rayon pool.
    ///
    /// # Errors
    /// [`ProtocolError::Distance`] if the ray queries cannot be prepared,
    /// [`ProtocolError::Render`] for an invalid size.
    pub fn new(mesh: &TriMesh, margin: f32, size: u32) -> Result<PaperProtocol, ProtocolError> {
        // Only the surface matters for the images: flat fans re-triangulated.
        let reshaped = sdfmo_distance::reshape_fans(mesh);
        let mesh = reshaped.as_ref().map_or(mesh, |r| &r.mesh);
        let (normalized, _) = mesh.normalized(margin);
        let dist =
            MeshDistance::new(&normalized, SignMode::Auto).map_err(ProtocolError::Distance)?;
        PaperProtocol::of_scene(&MeshScene(&dist), size)
    }

    /// The protocol with `reference` (any scene in the normalised frame, for instance another
    /// octree) rendered as the reference images, from the paper's views at `size` × `size`.
    ///
    /// # Errors
    /// [`ProtocolError::Render`] for an invalid size.
    pub fn of_scene<T: Traceable>(
        reference: &T,
        size: u32,
    ) -> Result<PaperProtocol, ProtocolError> {
        let mut protocol = PaperProtocol {
            cameras: Camera::paper_views(size, size),
            settings: RenderSettings::new(Mode::Lambert),
            references: Vec::new(),
            reference_ms: 0.0,
            frames: 1,
        };
        let mut total_ms = 0.0;
        for camera in &protocol.cameras {
            let r = render(reference, camera, &protocol.settings).map_err(ProtocolError::Render)?;
            total_ms += r.render_ms;
            protocol.references.push(r.to_image());
        }
        protocol.reference_ms = total_ms / protocol.cameras.len().max(1) as f64;
        Ok(protocol)
    }

    /// The paper's views.
    pub fn cameras(&self) -> &[Camera] {
        &self.cameras
    }

    /// The reference image of each view.
    pub fn references(&self) -> &[RgbImage] {
        &self.references
    }

    /// Mean render time of one reference view (ms; one frame each).
    pub fn reference_ms(&self) -> f64 {
        self.reference_ms
    }

    /// The protocol timing each view of [`score`](PaperProtocol::score) as the median of
    /// `frames` renders (at least 1; 1 by default). One frame's time on a loaded machine is
    /// noise: a sweep of three unseen meshes showed a render ratio of 0.65 between two methods
    /// whose kernels do the same work. The images of a scene are identical frame after frame
    /// (tested in `render`), so the first frame's image is the one scored.
    pub fn with_frames(mut self, frames: usize) -> PaperProtocol {
        self.frames = frames.max(1);
        self
    }

    /// Renders per view whose median time [`score`](PaperProtocol::score) reports.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Renders `scene` (an octree, in the normalised frame) from every view and compares each
    /// image with its reference. The views are rendered one after the other (each render uses
    /// every worker), each [`frames`](PaperProtocol::frames) times for its median time, then
    /// compared in parallel (FLIP is single-threaded).
    ///
    /// # Errors
    /// [`ProtocolError::Render`], [`ProtocolError::Metrics`].
    pub fn score<T: Traceable>(&self, scene: &T) -> Result<Score, ProtocolError> {
        let mut rendered = Vec::with_capacity(self.cameras.len());
        for camera in &self.cameras {
            let r = render(scene, camera, &self.settings).map_err(ProtocolError::Render)?;
            let mut times = vec![r.render_ms];
            for _ in 1..self.frames {
                let again = render(scene, camera, &self.settings).map_err(ProtocolError::Render)?;
                times.push(again.render_ms);
            }
            let median_ms = sdfmo_metrics::median(times).unwrap_or(r.render_ms);
            rendered.push((r.to_image(), median_ms));
        }
        let views = rendered
            .into_par_iter()
            .zip(self.references.par_iter())
            .map(|((image, render_ms), reference)| {
                let psnr = sdfmo_metrics::psnr(reference, &image)?;
                let flip = sdfmo_metrics::flip(reference, &image)?;
                Ok(ViewScore {
                    image,
                    render_ms,
                    psnr,
                    flip,
                })
            })
            .collect::<Result<Vec<_>, sdfmo_metrics::MetricsError>>()
            .map_err(ProtocolError::Metrics)?;
        Ok(Score { views })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Spheres;
    use glam::Vec3;

    #[test]
    fn a_scene_scores_infinite_against_itself_and_finite_against_another() {
        let one = Spheres::one(Vec3::ZERO, 0.5);
        let protocol = PaperProtocol::of_scene(&one, 32).unwrap();
        assert_eq!(protocol.cameras().len(), 4);
        assert_eq!(protocol.references().len(), 4);
        let same = protocol.score(&one).unwrap();
        assert_eq!(same.views.len(), 4);
        assert!(same.psnr().is_infinite() && same.min_psnr().is_infinite());
        assert_eq!(same.flip(), 0.0);
        let other = protocol.score(&Spheres::one(Vec3::ZERO, 0.4)).unwrap();
        let psnr = other.psnr();
        assert!(psnr.is_finite() && psnr > 0.0, "{psnr}");
        assert!(other.min_psnr() <= psnr && other.flip() > 0.0);
    }

    #[test]
    fn several_frames_score_the_same_images() {
        let one = Spheres::one(Vec3::ZERO, 0.5);
        let other = Spheres::one(Vec3::ZERO, 0.4);
        let protocol = PaperProtocol::of_scene(&one, 24).unwrap();
        assert_eq!(protocol.frames(), 1);
        let single = protocol.score(&other).unwrap();
        let protocol = protocol.with_frames(3);
        assert_eq!(protocol.frames(), 3);
        let median = protocol.score(&other).unwrap();
        assert_eq!(median.psnr(), single.psnr());
        for (a, b) in median.views.iter().zip(&single.views) {
            assert_eq!(a.image, b.image);
            assert!(a.render_ms.is_finite() && a.render_ms >= 0.0);
        }
        assert_eq!(protocol.with_frames(0).frames(), 1);
    }
}
