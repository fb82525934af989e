//! The page's zoomed crops: at the depth where two methods' mean FLIP differs most, per view the
//! window where their FLIP maps differ most (the search is `sdfmo-metrics`'
//! [`most_different_window`]), cut from the reference, each method's image and heat map and
//! written as PNGs beside the views. The FLIP maps are recomputed from the saved PNGs: exactly
//! what the page shows.

use std::path::Path;

use sdf_multioctree::metrics::{self, most_different_window, FlipResult, Window};

use super::model::Report;
use super::tables::label;
use crate::error::{error_line, Result};
use crate::{image_rel, reference_file, view_file};

/// An image on the page, linked to itself, with a caption under it.
#[derive(Clone, Debug)]
pub struct ImageCell {
    /// Path relative to the output directory.
    pub src: String,
    /// Caption (also the image's alternative text).
    pub caption: String,
}

/// Where on its view a crop comes from, as percentages of the view's width and height: what
/// the page's marker rectangle on the view's thumbnail is drawn with.
#[derive(Clone, Debug)]
pub struct Marker {
    /// Left edge, % of the width.
    pub left: f64,
    /// Top edge, % of the height.
    pub top: f64,
    /// Width, % of the view's width.
    pub width: f64,
    /// Height, % of the view's height.
    pub height: f64,
}

/// One view's crops.
#[derive(Clone, Debug)]
pub struct CropRow {
    /// The view.
    pub view: usize,
    /// The window in the view's pixels.
    pub window: Window,
    /// The whole view (the reference) with the window marked on it.
    pub thumbnail: ImageCell,
    /// The window on the thumbnail.
    pub marker: Marker,
    /// Reference, method a, method b, FLIP a, FLIP b: each cropped.
    pub cells: Vec<ImageCell>,
    /// Displayed edge of each crop in CSS pixels (twice the window: every pixel a 2×2 block).
    pub shown: u32,
}

/// A model's crop section.
#[derive(Clone, Debug)]
pub enum Crops {
    /// Fewer than two methods, or no depth where both have rows.
    None,
    /// The crops could not be made (an image unreadable); the page says why instead of failing.
    Unavailable(String),
    /// The crops of every view.
    Made {
        /// The depth where the two methods' mean FLIP differs most.
        depth: u8,
        /// The first method's label.
        a: String,
        /// The second method's label.
        b: String,
        /// One row per view.
        rows: Vec<CropRow>,
    },
}

/// Makes (and writes) the crops of `model`; an error becomes [`Crops::Unavailable`].
pub fn crops(out: &Path, report: &Report, model: &str) -> Crops {
    match make(out, report, model) {
        Ok(c) => c,
        Err(e) => Crops::Unavailable(error_line(&e)),
    }
}

fn make(out: &Path, report: &Report, model: &str) -> Result<Crops> {
    let settings = &report.settings;
    let [a, b] = match settings.methods.as_slice() {
        [a, b, ..] => [a, b],
        _ => return Ok(Crops::None),
    };
    let Some(depth) = settings
        .depths
        .iter()
        .filter_map(|&d| {
            let (ra, rb) = (report.find(model, a, d)?, report.find(model, b, d)?);
            Some((d, (ra.flip - rb.flip).abs()))
        })
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(d, _)| d)
    else {
        return Ok(Crops::None);
    };
    let mut rows = Vec::new();
    for view in 0..settings.views {
        let load = |file: String| metrics::load_rgb8(out.join(image_rel(model, &file)));
        let reference = load(reference_file(view))?;
        let (ia, ib) = (
            load(view_file(a, depth, view))?,
            load(view_file(b, depth, view))?,
        );
        let (fa, fb) = (
            metrics::flip(&reference, &ia)?,
            metrics::flip(&reference, &ib)?,
        );
        let (w, h) = reference.dimensions();
        // A tenth of the side: large enough to show the context of an edge, small enough that
        // at twice its size every pixel is visible.
        let size = (w.min(h) / 10).max(8).min(w.min(h));
        let window = most_different_window(&fa, &fb, size);
        let caption = |f: &FlipResult| format!("FLIP {:.4} here", f.window_mean(window));
        let parts = [
            ("reference", reference, "mesh".to_owned()),
            (a.as_str(), ia, label(a).to_owned()),
            (b.as_str(), ib, label(b).to_owned()),
            ("flip_a", metrics::flip_heatmap(&fa), caption(&fa)),
            ("flip_b", metrics::flip_heatmap(&fb), caption(&fb)),
        ];
        let mut cells = Vec::new();
        for (tag, img, caption) in parts {
            let file = format!("crop_d{depth}_{view}_{tag}.png");
            let crop =
                image::imageops::crop_imm(&img, window.x, window.y, window.size, window.size)
                    .to_image();
            crate::files::write_derived_png(&out.join(image_rel(model, &file)), &crop)?;
            cells.push(ImageCell {
                src: image_rel(model, &file),
                caption,
            });
        }
        let pct = |v: u32, of: u32| 100.0 * f64::from(v) / f64::from(of.max(1));
        rows.push(CropRow {
            view,
            window,
            thumbnail: ImageCell {
                src: image_rel(model, &reference_file(view)),
                caption: format!("view {view}"),
            },
            marker: Marker {
                left: pct(window.x, w),
                top: pct(window.y, h),
                width: pct(window.size, w),
                height: pct(window.size, h),
            },
            cells,
            shown: 2 * window.size,
        });
    }
    Ok(Crops::Made {
        depth,
        a: label(a).to_owned(),
        b: label(b).to_owned(),
        rows,
    })
}
