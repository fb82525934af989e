//! The dataset report as Markdown (`dataset.md`, also printed) and HTML (`index.html`).

use std::fmt::Write as _;

use super::{DatasetStats, DepthStats, Distribution, QUANTILES};
use crate::report::Provenance;
use crate::shard::Failure;
use crate::{heatmap_file, image_rel, reference_file, view_file, Model, Row, SweepSettings};

/// A number with `digits` decimals, `∞` for a missing (infinite) value.
fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or("∞".to_owned(), |x| format!("{x:.digits$}"))
}

/// A share as a percentage.
fn pct(v: f64) -> String {
    format!("{:.0} %", v * 100.0)
}

/// The quantile columns' header.
fn quantile_header() -> Vec<String> {
    QUANTILES
        .iter()
        .map(|q| match *q {
            0.0 => "min".to_owned(),
            1.0 => "max".to_owned(),
            0.5 => "median".to_owned(),
            q => format!("p{:.0}", q * 100.0),
        })
        .collect()
}

/// The statistics both pages tabulate over the depths: title, statistic, digits shown.
type Statistic = (&'static str, fn(&DepthStats) -> &Distribution, usize);
const DISTRIBUTIONS: [Statistic; 3] = [
    ("ΔPSNR (dB)", |d| &d.psnr_gain, 2),
    ("ΔFLIP", |d| &d.flip_change, 4),
    ("size ratio multi / SVO", |d| &d.size_ratio, 3),
];

/// The tables of [`DISTRIBUTIONS`], each as (title, header, rows): one row per depth, one column
/// per quantile.
fn distribution_tables(
    stats: &[DepthStats],
) -> impl Iterator<Item = (&'static str, Vec<String>, Vec<Vec<String>>)> + '_ {
    let mut header = vec!["depth".to_owned(), "n".to_owned()];
    header.extend(quantile_header());
    DISTRIBUTIONS.into_iter().map(move |(title, pick, digits)| {
        let rows = stats
            .iter()
            .map(|d| {
                let dist = pick(d);
                let mut row = vec![d.depth.to_string(), dist.n.to_string()];
                row.extend(dist.quantiles.iter().map(|q| num(*q, digits)));
                row
            })
            .collect();
        (title, header.clone(), rows)
    })
}

/// The summary table: per depth, median gain, shares, median size ratio.
fn summary_rows(stats: &[DepthStats]) -> Vec<Vec<String>> {
    stats
        .iter()
        .map(|d| {
            vec![
                d.depth.to_string(),
                d.models.to_string(),
                num(d.psnr_gain.median(), 2),
                num(d.flip_change.median(), 4),
                num(d.size_ratio.median(), 3),
                pct(d.multi_beats_svo),
                pct(d.multi_beats_svo_flip),
                d.multi_beats_deeper_svo.map_or("–".to_owned(), pct),
            ]
        })
        .collect()
}

const SUMMARY_HEADER: [&str; 8] = [
    "depth",
    "models",
    "median ΔPSNR (dB)",
    "median ΔFLIP",
    "median size ×",
    "multi > SVO (PSNR)",
    "multi < SVO (FLIP)",
    "multi d > SVO d+1",
];

/// A Markdown table.
fn md_table(header: &[String], rows: &[Vec<String>]) -> String {
    let mut s = format!(
        "| {} |\n|{}\n",
        header.join(" | "),
        "---|".repeat(header.len())
    );
    for r in rows {
        let _ = writeln!(s, "| {} |", r.join(" | "));
    }
    s
}

/// The Markdown report.
pub fn markdown(
    settings: &SweepSettings,
    stats: &DatasetStats,
    failures: &[Failure],
    _models: &[Model],
    _rows: &[Row],
    unfinished: usize,
) -> String {
    let mut s = format!(
        "# Dataset sweep: {} models ({} done, {} failed{})\n\nDepths {}, {}×{} views ×{}, \
         voxel cap {}. Δ = multi-octree − SVO at the same depth.\n\n",
        stats.manifest_models,
        stats.done,
        stats.failed,
        if unfinished > 0 {
            format!(", {unfinished} not run")
        } else {
            String::new()
        },
        settings
            .depths
            .iter()
            .map(u8::to_string)
            .collect::<Vec<_>>()
            .join(", "),
        settings.size,
        settings.size,
        settings.views,
        settings.max_voxels
    );
    let header: Vec<String> = SUMMARY_HEADER.iter().map(|h| h.to_string()).collect();
    s.push_str(&md_table(&header, &summary_rows(&stats.depths)));
    for (title, header, rows) in distribution_tables(&stats.depths) {
        let _ = write!(s, "\n{title}:\n\n");
        s.push_str(&md_table(&header, &rows));
    }
    if let Some(t) = &stats.time_per_model {
        let _ = write!(
            s,
            "\nTime per model (its process: load, reference, every build, render and compare): \
             mean {:.0} ms over {} models, {:.1} s in all; least squares {:.0} ms + {:.4} ms × \
             triangles.\n",
            t.mean_ms,
            t.models,
            t.total_ms / 1e3,
            t.intercept_ms,
            t.slope_ms_per_triangle
        );
    }
    if !failures.is_empty() {
        let _ = write!(s, "\nFailures ({}):\n\n", failures.len());
        let rows: Vec<Vec<String>> = failures
            .iter()
            .map(|f| {
                vec![
                    f.model.clone(),
                    f.source.clone(),
                    f.error.replace('|', "\\|"),
                ]
            })
            .collect();
        s.push_str(&md_table(
            &["model".into(), "source".into(), "error".into()],
            &rows,
        ));
    }
    s
}

/// HTML-escapes text.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An HTML table.
fn html_table(header: &[String], rows: &[Vec<String>]) -> String {
    let mut s = String::from("<table><tr>");
    for h in header {
        let _ = write!(s, "<th>{}</th>", esc(h));
    }
    s.push_str("</tr>\n");
    for r in rows {
        s.push_str("<tr>");
        for c in r {
            let _ = write!(s, "<td>{}</td>", esc(c));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    s
}

/// What the page shows.
pub struct Page<'a> {
    /// Settings of the run.
    pub settings: &'a SweepSettings,
    /// The statistics.
    pub stats: &'a DatasetStats,
    /// Failed models.
    pub failures: &'a [Failure],
    /// Models with rows.
    pub models: &'a [Model],
    /// The rows.
    pub rows: &'a [Row],
    /// Models whose images were copied (the worst).
    pub shown: &'a [String],
    /// Where and with what the merge ran.
    pub provenance: &'a Provenance,
    /// Shards merged.
    pub shards: usize,
    /// Models in no ledger.
    pub unfinished: usize,
    /// The manifest.
    pub manifest: &'a str,
}

/// The HTML page.
pub fn html(p: &Page) -> String {
    let st = p.stats;
    let mut s = String::from(
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>sdfmo dataset sweep</title><style>\
         body{font-family:sans-serif;margin:2em;max-width:1200px;color:#222}\
         table{border-collapse:collapse;margin:0.5em 0 1.5em}\
         td,th{border:1px solid #ccc;padding:3px 8px;text-align:right;font-size:14px}\
         th{background:#f0f0f0}td:first-child{text-align:left}\
         img.plot{width:100%;max-width:1100px}figure{display:inline-block;margin:4px;text-align:center}\
         figure img{width:160px;image-rendering:pixelated;background:#000}figcaption{font-size:12px}\
         .fail td{text-align:left}</style></head><body>\n",
    );
    let _ = write!(
        s,
        "<h1>Dataset sweep: {} models</h1>\n<p>{} done, {} failed{}, from <code>{}</code> in {} \
         shard(s). Depths {}, {}×{} pixels, {} views, voxel cap {}. Δ is the multi-octree minus \
         the SVO at the same depth; a positive ΔPSNR and a negative ΔFLIP favour the \
         multi-octree.</p>\n",
        st.manifest_models,
        st.done,
        st.failed,
        if p.unfinished > 0 {
            format!(", <b>{} not run</b>", p.unfinished)
        } else {
            String::new()
        },
        esc(p.manifest),
        p.shards,
        p.settings
            .depths
            .iter()
            .map(u8::to_string)
            .collect::<Vec<_>>()
            .join(", "),
        p.settings.size,
        p.settings.size,
        p.settings.views,
        p.settings.max_voxels
    );
    let header: Vec<String> = SUMMARY_HEADER.iter().map(|h| h.to_string()).collect();
    s.push_str("<h2>Per depth</h2>\n");
    s.push_str(&html_table(&header, &summary_rows(&st.depths)));
    s.push_str(
        "<img class=\"plot\" src=\"dataset_psnr_gain_cdf.png\" alt=\"CDF of the PSNR gain per depth\">\n",
    );
    for (title, header, rows) in distribution_tables(&st.depths) {
        // A heading starts with a capital (the Markdown's titles run on in a sentence).
        let mut chars = title.chars();
        let heading: String = chars
            .next()
            .into_iter()
            .flat_map(char::to_uppercase)
            .chain(chars)
            .collect();
        let _ = writeln!(s, "<h3>{}</h3>", esc(&heading));
        s.push_str(&html_table(&header, &rows));
    }
    s.push_str(
        "<img class=\"plot\" src=\"dataset_size_ratio_cdf.png\" alt=\"CDF of the size ratio per depth\">\n\
         <h2>Time against triangles</h2>\n\
         <img class=\"plot\" src=\"dataset_time_vs_triangles.png\" alt=\"build and render time against triangles\">\n",
    );
    if let Some(t) = &st.time_per_model {
        let _ = writeln!(
            s,
            "<p>Wall time per model (its process: load, reference, every build, render and \
             compare): mean {:.0} ms over {} models ({:.1} s in all); least squares {:.0} ms + \
             {:.4} ms × triangles.</p>",
            t.mean_ms,
            t.models,
            t.total_ms / 1e3,
            t.intercept_ms,
            t.slope_ms_per_triangle
        );
    }
    s.push_str("<h2>Worst models</h2>\n<p>Lowest ΔPSNR per depth; view 0: the reference, each method's image and its FLIP map.</p>\n");
    let triangles = |m: &str| {
        p.models
            .iter()
            .find(|x| x.model == m)
            .map_or(0, |x| x.triangles)
    };
    for d in &st.depths {
        let _ = writeln!(s, "<h3>Depth {}</h3>", d.depth);
        for (m, g) in &d.worst {
            if !p.shown.contains(m) {
                continue;
            }
            let _ = writeln!(
                s,
                "<div><b>{}</b> ({} triangles): ΔPSNR {} dB<br>",
                esc(m),
                triangles(m),
                num(*g, 2)
            );
            let fig = |file: String, cap: &str| {
                format!(
                    "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                    esc(&image_rel(m, &file)),
                    esc(cap),
                    esc(cap)
                )
            };
            s.push_str(&fig(reference_file(0), "reference"));
            for method in &p.settings.methods {
                s.push_str(&fig(view_file(method, d.depth, 0), method));
                s.push_str(&fig(
                    heatmap_file(method, d.depth, 0),
                    &format!("{method} FLIP"),
                ));
            }
            s.push_str("</div>\n");
        }
    }
    let _ = writeln!(s, "<h2>Failures ({})</h2>", p.failures.len());
    if p.failures.is_empty() {
        s.push_str("<p>None.</p>\n");
    } else {
        let rows: Vec<Vec<String>> = p
            .failures
            .iter()
            .map(|f| vec![f.model.clone(), f.source.clone(), f.error.clone()])
            .collect();
        s.push_str("<div class=\"fail\">");
        s.push_str(&html_table(
            &["model".into(), "source".into(), "error".into()],
            &rows,
        ));
        s.push_str("</div>");
    }
    let pr = p.provenance;
    let _ = write!(
        s,
        "<h2>Provenance</h2>\n<p>Merged by {} (commit {}) on {} ({} logical CPUs), {}; models \
         run with {} worker thread(s) each. Rows: {}. Data: <a href=\"results.json\">results.json</a>, \
         <a href=\"results.csv\">results.csv</a>, <a href=\"failures.csv\">failures.csv</a>.</p>\n\
         </body></html>\n",
        esc(&pr.program),
        esc(pr.git_commit.as_deref().unwrap_or("unknown")),
        esc(pr.cpu.as_deref().unwrap_or("an unknown CPU")),
        pr.cpus,
        esc(&pr.date),
        pr.threads,
        p.rows.len()
    );
    s
}
