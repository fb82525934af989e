//! The report's tables as text cells, laid out once for both table.md and the page: per model a
//! row per depth (the paper's Tables 1–2), the multi-octree against the SVO one level deeper,
//! and the summary over the models.

use serde::Serialize;

use super::model::{psnr_gain, Report, Row};

/// A table of text cells (unescaped: each renderer escapes for its own format).
#[derive(Clone, Debug, Serialize)]
pub struct Table {
    /// Column headings.
    pub header: Vec<String>,
    /// Rows of cells, each as long as the header.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// The table as GitHub Markdown, numbers right-aligned; a `|` in a cell is escaped and a
    /// line break becomes a space (a failure's error line read from a ledger may hold either).
    pub fn markdown(&self) -> String {
        let cell = |c: &String| c.replace('|', "\\|").replace(['\n', '\r'], " ");
        let line = |cells: &[String]| {
            let cells: Vec<String> = cells.iter().map(cell).collect();
            format!("| {} |\n", cells.join(" | "))
        };
        let mut s = line(&self.header);
        s.push('|');
        s.push_str(&"---:|".repeat(self.header.len()));
        s.push('\n');
        for r in &self.rows {
            s.push_str(&line(r));
        }
        s
    }
}

/// PSNR in dB to two decimals, `∞` for identical images.
pub fn fmt_psnr(p: Option<f64>) -> String {
    p.map_or("∞".to_owned(), |p| format!("{p:.2}"))
}

/// `f(v)`, or `–` when there is no value.
fn opt<T>(v: Option<T>, f: impl Fn(T) -> String) -> String {
    v.map_or("–".to_owned(), f)
}

/// How a method is named in headings.
pub fn label(method: &str) -> &str {
    match method {
        "svo" => "SVO",
        other => other,
    }
}

fn ratio(a: f64, b: f64) -> String {
    if b > 0.0 {
        format!("{:.2}", a / b)
    } else {
        "–".into()
    }
}

fn megabytes(r: &Row) -> String {
    format!("{:.3}", r.bytes as f64 / 1e6)
}

/// The per-model table: a row per depth; PSNR, FLIP, size, build and render time per method,
/// with the multi-octree's gain and ratios against the SVO when both were swept.
pub fn model_table(report: &Report, model: &str) -> Table {
    let methods = report.methods();
    let both = report.compares_methods();
    let mut header = vec!["depth".to_owned()];
    let metric_cols = |name: &str, header: &mut Vec<String>| {
        for m in &methods {
            header.push(format!("{name} {}", label(m)));
        }
    };
    metric_cols("PSNR dB", &mut header);
    if both {
        header.push("ΔPSNR".into());
    }
    metric_cols("FLIP", &mut header);
    metric_cols("MB", &mut header);
    if both {
        header.push("size ×".into());
    }
    metric_cols("build ms", &mut header);
    metric_cols("render ms", &mut header);
    if both {
        header.push("render ×".into());
    }
    let mut out = Vec::new();
    for d in report.depths() {
        let get = |m: &str| report.find(model, m, d);
        if methods.iter().all(|m| get(m).is_none()) {
            continue;
        }
        let pair = match (get("multi"), get("svo")) {
            (Some(a), Some(b)) if both => Some((a, b)),
            _ => None,
        };
        let mut cells = vec![d.to_string()];
        for m in &methods {
            cells.push(opt(get(m), |r| match r.lod {
                Some(lod) => format!("{} (LOD {lod})", fmt_psnr(r.psnr)),
                None => fmt_psnr(r.psnr),
            }));
        }
        if both {
            cells.push(opt(pair.and_then(|(a, b)| psnr_gain(a, b)), |g| {
                format!("{g:+.2}")
            }));
        }
        for m in &methods {
            cells.push(opt(get(m), |r| format!("{:.4}", r.flip)));
        }
        for m in &methods {
            cells.push(opt(get(m), megabytes));
        }
        if both {
            cells.push(opt(pair, |(a, b)| ratio(a.bytes as f64, b.bytes as f64)));
        }
        for m in &methods {
            cells.push(opt(get(m).and_then(|r| r.build_ms), |ms| {
                format!("{ms:.0}")
            }));
        }
        for m in &methods {
            cells.push(opt(get(m), |r| format!("{:.1}", r.render_ms)));
        }
        if both {
            cells.push(opt(pair, |(a, b)| ratio(a.render_ms, b.render_ms)));
        }
        out.push(cells);
    }
    Table { header, rows: out }
}

/// The multi-octree at depth d against the SVO one level deeper (the paper's second claim).
pub fn shallower_table(report: &Report, model: &str) -> Option<Table> {
    let header = [
        "multi depth",
        "PSNR multi",
        "PSNR SVO d+1",
        "ΔPSNR",
        "FLIP multi",
        "FLIP SVO d+1",
        "MB multi",
        "MB SVO d+1",
        "size ×",
    ];
    let mut out = Vec::new();
    for &d in &report.settings.depths {
        let (Some(a), Some(b)) = (
            report.find(model, "multi", d),
            report.find(model, "svo", d + 1),
        ) else {
            continue;
        };
        out.push(vec![
            d.to_string(),
            fmt_psnr(a.psnr),
            fmt_psnr(b.psnr),
            opt(psnr_gain(a, b), |g| format!("{g:+.2}")),
            format!("{:.4}", a.flip),
            format!("{:.4}", b.flip),
            megabytes(a),
            megabytes(b),
            ratio(a.bytes as f64, b.bytes as f64),
        ]);
    }
    (!out.is_empty()).then(|| Table {
        header: header.iter().map(|h| (*h).to_owned()).collect(),
        rows: out,
    })
}

/// The levels of one file (`sweep --levels`), per method: each level's own bytes, the bytes a
/// reader needs to draw it (the prefix of the file up to it), PSNR, FLIP and render time; the
/// last column is the whole file against the leaf-only file of its finest depth (that level's
/// own bytes: a level is, byte for byte, the separate build of its depth).
pub fn levels_table(report: &Report, model: &str) -> Option<Table> {
    let header = [
        "method",
        "level",
        "voxels",
        "level MB",
        "MB read",
        "PSNR dB",
        "FLIP",
        "render ms",
        "file / leaf-only",
    ];
    let mut out = Vec::new();
    for method in report.methods() {
        let mut levels: Vec<&Row> = report
            .rows
            .iter()
            .filter(|r| r.model == model && r.method == method && r.bytes_read.is_some())
            .collect();
        levels.sort_by_key(|r| r.depth);
        let Some(finest) = levels.last() else {
            continue;
        };
        let file = finest.bytes_read.unwrap_or(0) as f64;
        for r in &levels {
            out.push(vec![
                label(&method).to_owned(),
                r.depth.to_string(),
                opt(r.voxels, |v| v.to_string()),
                megabytes(r),
                opt(r.bytes_read, |b| format!("{:.3}", b as f64 / 1e6)),
                fmt_psnr(r.psnr),
                format!("{:.4}", r.flip),
                format!("{:.1}", r.render_ms),
                if std::ptr::eq(*r, *finest) {
                    ratio(file, finest.bytes as f64)
                } else {
                    String::new()
                },
            ]);
        }
    }
    (!out.is_empty()).then(|| Table {
        header: header.iter().map(|h| (*h).to_owned()).collect(),
        rows: out,
    })
}

/// Across models, per depth: median and worst PSNR gain, median FLIP change, size and render
/// time ratios of the multi-octree against the SVO (the model's [`Summary::gains`]).
///
/// [`Summary::gains`]: super::model::Summary::gains
pub fn summary_table(report: &Report) -> Option<Table> {
    let rows: Vec<Vec<String>> = report
        .summary
        .gains
        .iter()
        .map(|g| {
            vec![
                g.depth.to_string(),
                g.models.to_string(),
                opt(g.median_psnr_gain, |v| format!("{v:+.2}")),
                opt(g.worst_psnr_gain, |v| format!("{v:+.2}")),
                opt(g.median_flip_change, |v| format!("{v:+.4}")),
                opt(g.median_size_ratio, |v| format!("{v:.2}")),
                opt(g.median_render_ratio, |v| format!("{v:.2}")),
            ]
        })
        .collect();
    let header = [
        "depth",
        "models",
        "median ΔPSNR",
        "worst ΔPSNR",
        "median ΔFLIP",
        "median size ×",
        "median render ×",
    ];
    (!rows.is_empty()).then(|| Table {
        header: header.iter().map(|h| (*h).to_owned()).collect(),
        rows,
    })
}

/// The protocol in one paragraph, for the table and the page.
pub fn protocol(report: &Report) -> String {
    let settings = &report.settings;
    format!(
        "Paper protocol: {} views of {}×{} pixels (radius 3 around the origin in the y = 0 plane, \
         fov 60°), lambert shading, compared with the source mesh rendered by the same renderer. \
         PSNR (dB, higher is better) and FLIP (lower is better) are means over the views; MB = \
         10^6 bytes of the packed 8-bit octree file; build ms = whole build; render ms = mean per \
         view{}. Multi-octree voxel cap {}{}; threads {}. ΔPSNR = multi − SVO; × = multi / SVO. \
         ∞ = identical images.",
        settings.views,
        settings.size,
        settings.size,
        match report.provenance.frames {
            1 => String::new(),
            n => format!(" of each view's median over {n} frames"),
        },
        settings.max_voxels,
        if settings.fit_corners {
            "; corners fitted to the surface"
        } else {
            ""
        },
        settings
            .threads
            .map_or("all cores".to_owned(), |t| t.to_string())
    )
}

/// The heading of a model's section: its triangles and reference time when it was swept here.
pub fn model_heading(report: &Report, name: &str) -> String {
    match report.models.iter().find(|m| m.model == name) {
        Some(m) => format!(
            "{name} ({} triangles; reference render {:.1} ms per view)",
            m.triangles, m.reference_render_ms
        ),
        // A model the sweep has rows of but no record yet is the one being swept; a model
        // only extra rows name was measured elsewhere.
        None if report
            .rows
            .iter()
            .any(|r| r.model == name && report.settings.methods.contains(&r.method)) =>
        {
            format!("{name} (in progress)")
        }
        None => format!("{name} (rows from another producer)"),
    }
}
