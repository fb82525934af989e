//! index.html from the template `templates/sweep.html` through askama: the template is checked
//! against [`Page`] when the crate compiles, and every value is HTML-escaped (`&<>"'`) on the
//! way in. Askama rather than a runtime engine: minijinja's HTML escaping also escapes `/`
//! (`images&#x2f;demo&#x2f;…`), which is valid but makes every link unreadable in the source,
//! and a template error would surface only when a sweep ends.

use std::path::Path;

use askama::Template;

use super::crops::{crops, Crops, ImageCell};
use super::markdown::LEVELS_NOTE;
use super::model::{ExtraRows, Provenance, Report};
use super::tables::{
    fmt_psnr, label, levels_table, model_heading, model_table, protocol, shallower_table,
    summary_table, Table,
};
use crate::error::Result;
use crate::files::write_derived;
use crate::{heatmap_file, image_rel, reference_file, view_file};

/// What the page says about the bright outline in the multi-octree's FLIP maps of the demo part,
/// read off the images (docs/report.md, "The outline along the cube's edges", has the pixels).
const SPECKLE: &str = "The multi-octree's FLIP maps of the demo part show a bright one-pixel \
     outline along the cube's silhouette edges. In those pixels (view 0 at depth 9: the columns \
     x = 611 and 806 and the rows y = 333–334 of the front face) the mesh reference hits the lit \
     front face (grey 162) while the multi-octree hits the cube's side face seen edge-on, which \
     the two-sided shading turns away from the light (ambient only, grey 64). At a sharp edge a \
     leaf holds one plane voxel per face, clipped against each other; with 8-bit corners each \
     plane sits within 1/255 of the voxel's diagonal of the mesh's, so the edge they make lies a \
     fraction of a voxel off the mesh's edge, and a face seen exactly edge-on shows any sliver of \
     itself as a whole pixel. The band narrows as the voxels shrink (along the left edge of view \
     0: 9 columns at depth 6, 3 at depth 8, 1 at depth 9) and the edge stays sharp, where the \
     SVO rounds it off over a voxel.";

/// A view's grid: per depth the reference, each method's image, then each method's heat map.
struct Grid {
    view: usize,
    labels: Vec<String>,
    rows: Vec<GridRow>,
}

struct GridRow {
    depth: u8,
    reference: ImageCell,
    /// Each method's image, then each method's heat map (`None`: no row at this depth).
    cells: Vec<Option<ImageCell>>,
}

/// A model's part of the page.
struct Section {
    id: String,
    heading: String,
    table: Table,
    shallower: Option<Table>,
    /// The levels of one file (`sweep --levels`).
    levels: Option<Table>,
    crops: Crops,
    grids: Vec<Grid>,
}

/// Everything the template shows.
#[derive(Template)]
#[template(path = "sweep.html")]
struct Page<'a> {
    demo: bool,
    speckle: &'a str,
    levels_note: &'a str,
    views: usize,
    provenance: &'a Provenance,
    commit: &'a str,
    cpu: &'a str,
    protocol: String,
    extra: &'a [ExtraRows],
    data: Vec<&'a String>,
    summary: Option<Table>,
    plots: Vec<&'a String>,
    sections: Vec<Section>,
}

impl super::crops::Marker {
    /// The CSS placing the marker over the thumbnail.
    fn style(&self) -> String {
        format!(
            "left:{:.2}%;top:{:.2}%;width:{:.2}%;height:{:.2}%",
            self.left, self.top, self.width, self.height
        )
    }
}

/// The image grid of `view` of `model`: the sweep's methods only (other producers' rows have
/// no images here).
fn grid(report: &Report, model: &str, view: usize) -> Grid {
    let methods = &report.settings.methods;
    let mut rows = Vec::new();
    for &depth in &report.settings.depths {
        let found: Vec<_> = methods
            .iter()
            .map(|m| (m, report.find(model, m, depth)))
            .collect();
        if found.iter().all(|(_, r)| r.is_none()) {
            continue;
        }
        let mut cells: Vec<Option<ImageCell>> = found
            .iter()
            .map(|(m, r)| {
                r.map(|r| ImageCell {
                    src: image_rel(model, &view_file(m, depth, view)),
                    caption: format!(
                        "{} d{depth}: {} dB",
                        label(m),
                        fmt_psnr(r.psnr_views.get(view).copied().flatten())
                    ),
                })
            })
            .collect();
        cells.extend(found.iter().map(|(m, r)| {
            r.map(|r| ImageCell {
                src: image_rel(model, &heatmap_file(m, depth, view)),
                caption: format!(
                    "FLIP {:.4}",
                    r.flip_views.get(view).copied().unwrap_or(f64::NAN)
                ),
            })
        }));
        rows.push(GridRow {
            depth,
            reference: ImageCell {
                src: image_rel(model, &reference_file(view)),
                caption: "mesh".into(),
            },
            cells,
        });
    }
    Grid {
        view,
        labels: methods.iter().map(|m| label(m).to_owned()).collect(),
        rows,
    }
}

/// The page's HTML for `report`, whose files (data, then plots) are `files`; writes the crops.
pub fn page(out: &Path, report: &Report, files: &[String]) -> Result<String> {
    let sections = report
        .model_names()
        .into_iter()
        .map(|name| Section {
            heading: model_heading(report, &name),
            table: model_table(report, &name),
            shallower: shallower_table(report, &name),
            levels: levels_table(report, &name),
            crops: crops(out, report, &name),
            grids: (0..report.settings.views)
                .map(|v| grid(report, &name, v))
                .collect(),
            id: name,
        })
        .collect();
    let page = Page {
        demo: report.models.iter().any(|m| m.source == "demo"),
        speckle: SPECKLE,
        levels_note: LEVELS_NOTE,
        views: report.settings.views,
        provenance: &report.provenance,
        commit: report.provenance.git_commit.as_deref().unwrap_or("unknown"),
        cpu: report.provenance.cpu.as_deref().unwrap_or("an unknown CPU"),
        protocol: protocol(report),
        extra: &report.extra_rows,
        data: files.iter().filter(|f| !f.starts_with("plot")).collect(),
        summary: summary_table(report),
        plots: files.iter().filter(|f| f.starts_with("plot")).collect(),
        sections,
    };
    Ok(page.render()?)
}

/// Writes index.html; returns its name.
pub fn write_html(out: &Path, report: &Report, files: &[String]) -> Result<String> {
    write_derived(
        &out.join("index.html"),
        page(out, report, files)?.as_bytes(),
    )?;
    Ok("index.html".to_owned())
}
