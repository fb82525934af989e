//! The sweep's text outputs: results.json, results.csv, table.md (the paper's Tables 1–2
//! layout) and index.html. Every file is written atomically.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;
use serde_json::json;

use super::{heatmap_file, image_rel, reference_file, view_file, Model, Row, SweepSettings};
use crate::output::write_derived;

/// Where and with what a sweep ran, recorded in results.json and on the page.
#[derive(Clone, Debug, Serialize)]
pub struct Provenance {
    /// `sdfmo-cli` and its version.
    pub program: String,
    /// The git commit the binary was built from, when it was built from a git checkout.
    pub git_commit: Option<String>,
    /// CPU model (`model name` in `/proc/cpuinfo`), when known.
    pub cpu: Option<String>,
    /// Logical CPUs of the machine.
    pub cpus: usize,
    /// Worker threads the sweep used.
    pub threads: usize,
    /// When the results were written, UTC (`YYYY-MM-DDTHH:MM:SSZ`).
    pub date: String,
}

impl Provenance {
    /// The provenance of this process, with the sweep's worker count.
    pub fn current(settings: &SweepSettings) -> Provenance {
        let cpu = std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_owned())
        });
        let secs = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        Provenance {
            program: format!("sdfmo-cli {}", env!("CARGO_PKG_VERSION")),
            git_commit: option_env!("SDFMO_GIT_COMMIT").map(str::to_owned),
            cpu,
            cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
            threads: settings.threads.unwrap_or_else(rayon::current_num_threads),
            date: utc_date(secs),
        }
    }

    fn html(&self) -> String {
        format!(
            "<p class=\"provenance\">Produced by {} (commit {}) on {} ({} logical CPUs) with {} \
             worker threads, {}.</p>",
            esc(&self.program),
            esc(self.git_commit.as_deref().unwrap_or("unknown")),
            esc(self.cpu.as_deref().unwrap_or("an unknown CPU")),
            self.cpus,
            self.threads,
            esc(&self.date)
        )
    }
}

/// Seconds since the Unix epoch as `YYYY-MM-DDTHH:MM:SSZ` (proleptic Gregorian calendar; the
/// days-to-civil algorithm of Howard Hinnant's `chrono`-compatible date library).
fn utc_date(secs: u64) -> String {
    let (days, rem) = ((secs / 86_400) as i64, secs % 86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// Writes results.json, results.csv and table.md; returns their names.
pub fn write_tables(
    out: &Path,
    settings: &SweepSettings,
    models: &[Model],
    rows: &[Row],
) -> anyhow::Result<Vec<String>> {
    let results = json!({
        "settings": settings,
        "provenance": Provenance::current(settings),
        "models": models,
        "rows": rows,
    });
    let mut text = serde_json::to_string_pretty(&results)?;
    text.push('\n');
    write_derived(&out.join("results.json"), text.as_bytes())?;
    write_derived(&out.join("results.csv"), csv(rows).as_bytes())?;
    write_derived(
        &out.join("table.md"),
        table_md(settings, models, rows).as_bytes(),
    )?;
    Ok(vec![
        "results.json".into(),
        "results.csv".into(),
        "table.md".into(),
    ])
}

/// The rows as CSV (PSNR `inf` when the images were identical).
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "model,method,depth,psnr,flip,bytes,build_ms,render_ms,nodes,leaves,voxels,surface_voxels,cap_hits\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{:.6},{},{:.3},{:.3},{},{},{},{},{}",
            r.model,
            r.method,
            r.depth,
            r.psnr.map_or("inf".to_owned(), |p| format!("{p:.4}")),
            r.flip,
            r.bytes,
            r.build_ms,
            r.render_ms,
            r.nodes,
            r.leaves,
            r.voxels,
            r.surface_voxels,
            r.cap_hits
        );
    }
    s
}

/// A table of text cells, rendered as Markdown or HTML.
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn markdown(&self) -> String {
        let mut s = format!("| {} |\n", self.header.join(" | "));
        let _ = writeln!(s, "|{}", "---:|".repeat(self.header.len()));
        for r in &self.rows {
            let _ = writeln!(s, "| {} |", r.join(" | "));
        }
        s
    }

    fn html(&self) -> String {
        let mut s = String::from("<table>\n<tr>");
        for h in &self.header {
            let _ = write!(s, "<th>{}</th>", esc(h));
        }
        s.push_str("</tr>\n");
        for r in &self.rows {
            s.push_str("<tr>");
            for c in r {
                let _ = write!(s, "<td>{}</td>", esc(c));
            }
            s.push_str("</tr>\n");
        }
        s.push_str("</table>\n");
        s
    }
}

fn find<'a>(rows: &'a [Row], model: &str, method: &str, depth: u8) -> Option<&'a Row> {
    rows.iter()
        .find(|r| r.model == model && r.method == method && r.depth == depth)
}

fn fmt_psnr(p: Option<f64>) -> String {
    p.map_or("∞".to_owned(), |p| format!("{p:.2}"))
}

fn opt<T>(v: Option<T>, f: impl Fn(T) -> String) -> String {
    v.map_or("–".to_owned(), f)
}

fn label(method: &str) -> &str {
    match method {
        "svo" => "SVO",
        "multi" => "multi",
        other => other,
    }
}

/// Gain of the multi-octree over the SVO in PSNR (None when either is missing or infinite).
fn psnr_gain(multi: &Row, svo: &Row) -> Option<f64> {
    Some(multi.psnr? - svo.psnr?)
}

/// The per-model table: a row per depth; PSNR, FLIP, size, build and render time per method,
/// with the multi-octree's gain and ratios against the SVO when both were swept.
fn model_table(settings: &SweepSettings, model: &str, rows: &[Row]) -> Table {
    let methods = &settings.methods;
    let both = methods.iter().any(|m| m == "svo") && methods.iter().any(|m| m == "multi");
    let mut header = vec!["depth".to_owned()];
    let metric_cols = |name: &str, header: &mut Vec<String>| {
        for m in methods {
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
    for &d in &settings.depths {
        let get = |m: &str| find(rows, model, m, d);
        if methods.iter().all(|m| get(m).is_none()) {
            continue;
        }
        let pair = match (get("multi"), get("svo")) {
            (Some(a), Some(b)) if both => Some((a, b)),
            _ => None,
        };
        let mut cells = vec![d.to_string()];
        for m in methods {
            cells.push(opt(get(m), |r| fmt_psnr(r.psnr)));
        }
        if both {
            cells.push(opt(pair.and_then(|(a, b)| psnr_gain(a, b)), |g| {
                format!("{g:+.2}")
            }));
        }
        for m in methods {
            cells.push(opt(get(m), |r| format!("{:.4}", r.flip)));
        }
        for m in methods {
            cells.push(opt(get(m), |r| format!("{:.3}", r.bytes as f64 / 1e6)));
        }
        if both {
            cells.push(opt(pair, |(a, b)| ratio(a.bytes as f64, b.bytes as f64)));
        }
        for m in methods {
            cells.push(opt(get(m), |r| format!("{:.0}", r.build_ms)));
        }
        for m in methods {
            cells.push(opt(get(m), |r| format!("{:.1}", r.render_ms)));
        }
        if both {
            cells.push(opt(pair, |(a, b)| ratio(a.render_ms, b.render_ms)));
        }
        out.push(cells);
    }
    Table { header, rows: out }
}

fn ratio(a: f64, b: f64) -> String {
    if b > 0.0 {
        format!("{:.2}", a / b)
    } else {
        "–".into()
    }
}

/// The multi-octree at depth d against the SVO one level deeper (the paper's second claim).
fn shallower_table(settings: &SweepSettings, model: &str, rows: &[Row]) -> Option<Table> {
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
    for &d in &settings.depths {
        let (Some(a), Some(b)) = (
            find(rows, model, "multi", d),
            find(rows, model, "svo", d + 1),
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
            format!("{:.3}", a.bytes as f64 / 1e6),
            format!("{:.3}", b.bytes as f64 / 1e6),
            ratio(a.bytes as f64, b.bytes as f64),
        ]);
    }
    (!out.is_empty()).then(|| Table {
        header: header.iter().map(|h| (*h).to_owned()).collect(),
        rows: out,
    })
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// Across models, per depth: median and worst PSNR gain, median FLIP change, size and render
/// time ratios of the multi-octree against the SVO.
fn summary_table(settings: &SweepSettings, models: &[String], rows: &[Row]) -> Option<Table> {
    let mut out = Vec::new();
    for &d in &settings.depths {
        let pairs: Vec<(&Row, &Row)> = models
            .iter()
            .filter_map(|m| Some((find(rows, m, "multi", d)?, find(rows, m, "svo", d)?)))
            .collect();
        if pairs.is_empty() {
            continue;
        }
        let gains: Vec<f64> = pairs.iter().filter_map(|(a, b)| psnr_gain(a, b)).collect();
        let worst = gains.iter().copied().fold(f64::INFINITY, f64::min);
        out.push(vec![
            d.to_string(),
            pairs.len().to_string(),
            opt(median(gains.clone()), |g| format!("{g:+.2}")),
            if worst.is_finite() {
                format!("{worst:+.2}")
            } else {
                "–".into()
            },
            opt(
                median(pairs.iter().map(|(a, b)| a.flip - b.flip).collect()),
                |g| format!("{g:+.4}"),
            ),
            opt(
                median(
                    pairs
                        .iter()
                        .map(|(a, b)| a.bytes as f64 / b.bytes.max(1) as f64)
                        .collect(),
                ),
                |r| format!("{r:.2}"),
            ),
            opt(
                median(
                    pairs
                        .iter()
                        .filter(|(_, b)| b.render_ms > 0.0)
                        .map(|(a, b)| a.render_ms / b.render_ms)
                        .collect(),
                ),
                |r| format!("{r:.2}"),
            ),
        ]);
    }
    let header = [
        "depth",
        "models",
        "median ΔPSNR",
        "worst ΔPSNR",
        "median ΔFLIP",
        "median size ×",
        "median render ×",
    ];
    (!out.is_empty()).then(|| Table {
        header: header.iter().map(|h| (*h).to_owned()).collect(),
        rows: out,
    })
}

fn protocol(settings: &SweepSettings) -> String {
    format!(
        "Paper protocol: {} views of {}×{} pixels (radius 3 around the origin in the y = 0 plane, \
         fov 60°), lambert shading, compared with the source mesh rendered by the same renderer. \
         PSNR (dB, higher is better) and FLIP (lower is better) are means over the views; MB = \
         10^6 bytes of the packed 8-bit octree file; build ms = whole build; render ms = mean per \
         view. Multi-octree voxel cap {}; threads {}. ΔPSNR = multi − SVO; × = multi / SVO. \
         ∞ = identical images.",
        settings.views,
        settings.size,
        settings.size,
        settings.max_voxels,
        settings
            .threads
            .map_or("all cores".to_owned(), |t| t.to_string())
    )
}

fn model_names(rows: &[Row], models: &[Model]) -> Vec<String> {
    let mut names: Vec<String> = models.iter().map(|m| m.model.clone()).collect();
    for r in rows {
        if !names.contains(&r.model) {
            names.push(r.model.clone());
        }
    }
    names
}

fn model_heading(name: &str, models: &[Model]) -> String {
    match models.iter().find(|m| m.model == name) {
        Some(m) => format!(
            "{name} ({} triangles; reference render {:.1} ms per view)",
            m.triangles, m.reference_render_ms
        ),
        None => format!("{name} (in progress)"),
    }
}

/// table.md: a table per model laid out like the paper's Tables 1–2, the multi-octree against the
/// SVO one level deeper, and a summary across models.
pub fn table_md(settings: &SweepSettings, models: &[Model], rows: &[Row]) -> String {
    let mut s = format!("# sdfmo sweep\n\n{}\n", protocol(settings));
    let names = model_names(rows, models);
    for name in &names {
        let _ = write!(
            s,
            "\n## {}\n\n{}",
            model_heading(name, models),
            model_table(settings, name, rows).markdown()
        );
        if let Some(t) = shallower_table(settings, name, rows) {
            let _ = write!(
                s,
                "\nMulti-octree at depth d against the SVO at depth d + 1:\n\n{}",
                t.markdown()
            );
        }
    }
    if let Some(t) = summary_table(settings, &names, rows) {
        let _ = write!(
            s,
            "\n## Summary over the models (multi-octree against SVO)\n\n{}",
            t.markdown()
        );
    }
    s
}

/// HTML escaping of text.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// What the page compares, for a reader who has not read the paper.
fn introduction(settings: &SweepSettings, models: &[Model]) -> String {
    let mut s = String::from(
        "<p>This page compares two ways of storing a triangle mesh as a sparse octree of \
         trilinear signed-distance voxels, at several octree depths, by rendering them and \
         comparing the images with the mesh itself. The <b>SVO</b> (sparse voxel octree) is the \
         classic baseline: one voxel (eight corner distances) per leaf. The <b>multi-octree</b> is \
         the method of <i>SDFMultiOctree: implicit representation of surfaces based on signed \
         distance functions</i> (Mayorov, Garifullin, Voloboy, Frolov): a leaf may hold several \
         voxels, one per connected component of the mesh inside it, so parts closer than a voxel \
         do not melt together, and a voxel may be flagged <i>surface</i> (no inside or outside), \
         so open sheets and elements thinner than a voxel survive.</p>\n",
    );
    if models.iter().any(|m| m.source == "demo") {
        s.push_str(
            "<p>The built-in <b>demo part</b> puts one case of each kind in every view: a sphere \
             and a box (plain closed volumes, where both methods agree), a plate thinner than a \
             voxel (an SVO loses it or shows holes), an open sheet (no inside: an SVO cannot \
             represent it) and two cubes separated by a slot narrower than a voxel at eye height \
             (an SVO closes the slot).</p>\n",
        );
    }
    let _ = writeln!(
        s,
        "<p>Each configuration is rendered from the paper's {} views; the thumbnails link to the \
         full-resolution images, and the zoomed crops below each model show, at the depth where \
         the methods' FLIP differs most, the region of each view where their FLIP maps differ \
         most.</p>",
        settings.views
    );
    s
}

/// index.html: tables, plots, and per model and view the reference, each method's image and
/// FLIP heat map side by side; every link relative to the output directory.
pub fn write_html(
    out: &Path,
    settings: &SweepSettings,
    models: &[Model],
    rows: &[Row],
    files: &[String],
) -> anyhow::Result<String> {
    let mut s = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>sdfmo sweep</title>\n<style>\n\
         body{font-family:sans-serif;margin:1.5em;max-width:1600px}\n\
         table{border-collapse:collapse;margin:0.5em 0 1em}\n\
         th,td{border:1px solid #bbb;padding:3px 7px;text-align:right}\n\
         th{background:#eee}\n\
         .plots img{width:48%;min-width:420px;margin:0.5%}\n\
         .grid td{text-align:center;vertical-align:top;font-size:small}\n\
         .grid img{width:100%;max-width:256px}\n\
         .crop td{text-align:center;vertical-align:top;font-size:small}\n\
         .crop img{image-rendering:pixelated}\n\
         </style>\n</head>\n<body>\n<h1>sdfmo sweep</h1>\n",
    );
    s.push_str(&introduction(settings, models));
    s.push_str(&Provenance::current(settings).html());
    let _ = writeln!(s, "<p>{}</p>", esc(&protocol(settings)));
    let links: Vec<String> = files
        .iter()
        .filter(|f| !f.starts_with("plot"))
        .map(|f| format!("<a href=\"{0}\">{0}</a>", esc(f)))
        .collect();
    let _ = writeln!(s, "<p>Data: {}</p>", links.join(" · "));

    let names = model_names(rows, models);
    if let Some(t) = summary_table(settings, &names, rows) {
        let _ = write!(
            s,
            "<h2>Summary over the models (multi-octree against SVO)</h2>\n{}",
            t.html()
        );
    }
    let plots: Vec<&String> = files.iter().filter(|f| f.starts_with("plot")).collect();
    if !plots.is_empty() {
        s.push_str("<h2>Plots</h2>\n<div class=\"plots\">\n");
        for p in plots {
            let _ = writeln!(
                s,
                "<a href=\"{0}\"><img src=\"{0}\" alt=\"{0}\"></a>",
                esc(p)
            );
        }
        s.push_str("</div>\n");
    }
    for name in &names {
        let _ = write!(
            s,
            "<h2 id=\"{0}\">{1}</h2>\n{2}",
            esc(name),
            esc(&model_heading(name, models)),
            model_table(settings, name, rows).html()
        );
        if let Some(t) = shallower_table(settings, name, rows) {
            let _ = write!(
                s,
                "<p>Multi-octree at depth d against the SVO at depth d + 1:</p>\n{}",
                t.html()
            );
        }
        s.push_str(&crops_html(out, settings, name, rows));
        for view in 0..settings.views {
            let _ = writeln!(
                s,
                "<details{}><summary>View {view}: reference, each method, FLIP heat maps</summary>\n<table class=\"grid\">",
                if view == 0 { " open" } else { "" }
            );
            s.push_str("<tr><th>depth</th><th>reference</th>");
            for m in &settings.methods {
                let _ = write!(s, "<th>{}</th>", esc(label(m)));
            }
            for m in &settings.methods {
                let _ = write!(s, "<th>FLIP {}</th>", esc(label(m)));
            }
            s.push_str("</tr>\n");
            let reference = image_rel(name, &reference_file(view));
            for &d in &settings.depths {
                if settings
                    .methods
                    .iter()
                    .all(|m| find(rows, name, m, d).is_none())
                {
                    continue;
                }
                let _ = write!(s, "<tr><td>{d}</td>{}", img_cell(&reference, "mesh"));
                for m in &settings.methods {
                    match find(rows, name, m, d) {
                        Some(r) => {
                            let psnr = r.psnr_views.get(view).copied().flatten();
                            let cap = format!("{} d{d}: {} dB", label(m), fmt_psnr(psnr));
                            s.push_str(&img_cell(&image_rel(name, &view_file(m, d, view)), &cap));
                        }
                        None => s.push_str("<td>–</td>"),
                    }
                }
                for m in &settings.methods {
                    match find(rows, name, m, d) {
                        Some(r) => {
                            let flip = r.flip_views.get(view).copied().unwrap_or(f64::NAN);
                            let cap = format!("FLIP {flip:.4}");
                            s.push_str(&img_cell(
                                &image_rel(name, &heatmap_file(m, d, view)),
                                &cap,
                            ));
                        }
                        None => s.push_str("<td>–</td>"),
                    }
                }
                s.push_str("</tr>\n");
            }
            s.push_str("</table>\n</details>\n");
        }
    }
    s.push_str("</body>\n</html>\n");
    write_derived(&out.join("index.html"), s.as_bytes())?;
    Ok("index.html".to_owned())
}

/// The square window of edge `size` (top-left corner) with the largest sum of `map`
/// (row-major, `width` × `height`), by a summed-area table; the first such window in row-major
/// order on ties.
fn best_window(map: &[f32], width: u32, height: u32, size: u32) -> (u32, u32) {
    let (w, h) = (width as usize, height as usize);
    let size = (size as usize).min(w).min(h);
    if size == 0 || map.len() != w * h {
        return (0, 0);
    }
    let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            row += f64::from(map[y * w + x]);
            sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + row;
        }
    }
    let at = |x: usize, y: usize| sat[y * (w + 1) + x];
    let mut best = (f64::NEG_INFINITY, 0, 0);
    for y in 0..=h - size {
        for x in 0..=w - size {
            let sum = at(x + size, y + size) - at(x, y + size) - at(x + size, y) + at(x, y);
            if sum > best.0 {
                best = (sum, x, y);
            }
        }
    }
    (best.1 as u32, best.2 as u32)
}

/// Zoomed crops for one model: at the depth where the two methods' mean FLIP differs most, per
/// view the window (a tenth of the image's side) where their FLIP maps differ most, cut from the
/// reference, each method's image and heat map, and shown magnified with visible pixels. The
/// FLIP maps are recomputed from the saved PNGs (exactly what the page shows). When an image
/// cannot be read the section says so instead of failing the page.
fn crops_html(out: &Path, settings: &SweepSettings, name: &str, rows: &[Row]) -> String {
    match write_crops(out, settings, name, rows) {
        Ok(html) => html,
        Err(e) => format!(
            "<p>Zoomed crops unavailable: {}</p>\n",
            esc(&format!("{e:#}"))
        ),
    }
}

fn write_crops(
    out: &Path,
    settings: &SweepSettings,
    name: &str,
    rows: &[Row],
) -> anyhow::Result<String> {
    use sdf_multioctree::metrics;
    let [a, b] = match settings.methods.as_slice() {
        [a, b, ..] => [a, b],
        _ => return Ok(String::new()),
    };
    let Some(depth) = settings
        .depths
        .iter()
        .filter_map(|&d| {
            Some((
                d,
                (find(rows, name, a, d)?.flip - find(rows, name, b, d)?.flip).abs(),
            ))
        })
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(d, _)| d)
    else {
        return Ok(String::new());
    };
    let mut s = format!(
        "<h3>Where {} and {} differ most (depth {depth})</h3>\n<table class=\"crop\">\n\
         <tr><th>view</th><th>reference</th><th>{0}</th><th>{1}</th><th>FLIP {0}</th><th>FLIP {1}</th></tr>\n",
        esc(label(a)),
        esc(label(b))
    );
    for view in 0..settings.views {
        let load = |file: String| metrics::load_rgb8(out.join(image_rel(name, &file)));
        let reference = load(reference_file(view))?;
        let (ia, ib) = (
            load(view_file(a, depth, view))?,
            load(view_file(b, depth, view))?,
        );
        let (fa, fb) = (
            metrics::flip(&reference, &ia)?,
            metrics::flip(&reference, &ib)?,
        );
        let diff: Vec<f32> = fa
            .map
            .iter()
            .zip(&fb.map)
            .map(|(x, y)| (x - y).abs())
            .collect();
        let (w, h) = reference.dimensions();
        let size = (w.min(h) / 10).max(8).min(w.min(h));
        let (x, y) = best_window(&diff, w, h, size);
        let window_mean = |f: &metrics::FlipResult| {
            let mut sum = 0.0f64;
            for yy in y..y + size {
                for xx in x..x + size {
                    sum += f64::from(f.map[(yy * w + xx) as usize]);
                }
            }
            sum / f64::from(size * size)
        };
        let _ = write!(
            s,
            "<tr><td>{view}<br>x {x}–{}<br>y {y}–{}</td>",
            x + size,
            y + size
        );
        let parts = [
            ("reference", reference, "mesh".to_owned()),
            (a.as_str(), ia, label(a).to_owned()),
            (b.as_str(), ib, label(b).to_owned()),
            (
                "flip_a",
                metrics::flip_heatmap(&fa),
                format!("FLIP {:.4} here", window_mean(&fa)),
            ),
            (
                "flip_b",
                metrics::flip_heatmap(&fb),
                format!("FLIP {:.4} here", window_mean(&fb)),
            ),
        ];
        for (tag, img, caption) in parts {
            let file = format!("crop_d{depth}_{view}_{tag}.png");
            let crop = image::imageops::crop_imm(&img, x, y, size, size).to_image();
            crate::output::write_derived_png(&out.join(image_rel(name, &file)), &crop)?;
            // Shown at exactly twice its size: every image pixel is a 2×2 block.
            let _ = write!(
                s,
                "<td><a href=\"{0}\"><img src=\"{0}\" alt=\"{1}\" width=\"{2}\" height=\"{2}\"></a><br>{1}</td>",
                esc(&image_rel(name, &file)),
                esc(&caption),
                2 * size
            );
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    Ok(s)
}

fn img_cell(src: &str, caption: &str) -> String {
    format!(
        "<td><a href=\"{0}\"><img src=\"{0}\" alt=\"{1}\" loading=\"lazy\"></a><br>{1}</td>",
        esc(src),
        esc(caption)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> SweepSettings {
        SweepSettings {
            depths: vec![4, 5],
            methods: vec!["svo".into(), "multi".into()],
            size: 32,
            max_voxels: 8,
            threads: Some(1),
            views: 4,
        }
    }

    fn row(method: &str, depth: u8, psnr: Option<f64>, bytes: usize) -> Row {
        Row {
            model: "m".into(),
            method: method.into(),
            depth,
            psnr,
            flip: 0.05,
            bytes,
            build_ms: 10.0,
            render_ms: 4.0,
            psnr_views: vec![psnr; 4],
            flip_views: vec![0.05; 4],
            ..Row::default()
        }
    }

    fn rows() -> Vec<Row> {
        vec![
            row("svo", 4, Some(20.0), 1000),
            row("svo", 5, Some(23.0), 4000),
            row("multi", 4, Some(22.5), 1200),
            row("multi", 5, None, 4400),
        ]
    }

    #[test]
    fn table_has_gains_ratios_and_the_deeper_svo() {
        let md = table_md(&settings(), &[], &rows());
        // depth 4: +2.50 dB, size 1.20×; depth 5: multi identical to the reference (∞).
        assert!(md.contains("| 4 | 20.00 | 22.50 | +2.50 |"), "{md}");
        assert!(md.contains("| 1.20 |"), "{md}");
        assert!(md.contains("| 5 | 23.00 | ∞ | – |"), "{md}");
        // multi at depth 4 against SVO at depth 5: 22.5 − 23.0.
        assert!(md.contains("| 4 | 22.50 | 23.00 | -0.50 |"), "{md}");
        assert!(md.contains("median ΔPSNR"), "{md}");
    }

    #[test]
    fn csv_has_a_line_per_row_and_inf() {
        let c = csv(&rows());
        assert_eq!(c.lines().count(), 5);
        assert!(
            c.lines().nth(4).unwrap().starts_with("m,multi,5,inf,"),
            "{c}"
        );
    }

    #[test]
    fn html_links_every_image_relatively_and_escapes() {
        let dir = std::env::temp_dir().join(format!("sdfmo-cli-html-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let files = vec!["results.json".to_owned(), "plot_a.png".to_owned()];
        write_html(&dir, &settings(), &[], &rows(), &files).unwrap();
        let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
        for v in 0..4 {
            assert!(html.contains(&format!("images/m/reference_{v}.png")));
            assert!(html.contains(&format!("images/m/multi_d5_{v}_flip.png")));
            assert!(html.contains(&format!("images/m/svo_d4_{v}.png")));
        }
        assert!(html.contains("src=\"plot_a.png\""));
        assert!(!html.contains("src=\"/"), "links must be relative");
        assert_eq!(esc("<a&\">"), "&lt;a&amp;&quot;&gt;");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn best_window_finds_the_hot_spot() {
        let (w, h) = (40u32, 30u32);
        let mut map = vec![0.1f32; (w * h) as usize];
        for y in 20..24 {
            for x in 5..9 {
                map[(y * w + x) as usize] = 1.0;
            }
        }
        assert_eq!(best_window(&map, w, h, 4), (5, 20));
        // A larger window still covers the spot, the first such position in row-major order.
        assert_eq!(best_window(&map, w, h, 8), (1, 16));
        assert_eq!(best_window(&map, w, h, 100), (0, 0));
    }

    #[test]
    fn utc_dates_of_known_instants() {
        assert_eq!(utc_date(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc_date(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(utc_date(1_798_761_599), "2026-12-31T23:59:59Z");
    }

    #[test]
    fn results_json_has_provenance_with_threads() {
        let dir = std::env::temp_dir().join(format!("sdfmo-cli-prov-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        write_tables(&dir, &settings(), &[], &rows()).unwrap();
        let text = std::fs::read_to_string(dir.join("results.json")).unwrap();
        let j: serde_json::Value = serde_json::from_str(&text).unwrap();
        let p = &j["provenance"];
        assert_eq!(p["threads"], 1, "{p}");
        assert!(
            p["program"].as_str().unwrap().starts_with("sdfmo-cli 0."),
            "{p}"
        );
        assert!(p["cpus"].as_u64().unwrap() >= 1, "{p}");
        assert_eq!(p["date"].as_str().unwrap().len(), 20, "{p}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn median_of_even_and_odd() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0]), Some(2.5));
        assert_eq!(median(vec![]), None);
    }
}
