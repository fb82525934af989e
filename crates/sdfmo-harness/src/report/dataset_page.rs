//! The dataset report ([`DatasetReport`]) as Markdown (`dataset.md`, also printed) and HTML
//! (`index.html`), through the askama templates `templates/dataset.md` and
//! `templates/dataset.html`. The tables are laid out here once, as text cells ([`Table`]), for
//! both; each template escapes for its own format (HTML: askama's escaper; Markdown:
//! [`Table::markdown`]).

use askama::Template;

use super::dataset::{DatasetReport, DatasetStats, DepthStats, Distribution, QUANTILES};
use super::model::{Provenance, SweepSettings};
use super::tables::Table;
use crate::{heatmap_file, image_rel, reference_file, view_file};

/// A number with `digits` decimals, `∞` for a missing (infinite) value.
fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or("∞".to_owned(), |x| format!("{x:.digits$}"))
}

/// A share as a percentage.
fn pct(v: f64) -> String {
    format!("{:.0} %", v * 100.0)
}

/// The quantile columns' header.
fn quantile_header() -> impl Iterator<Item = String> {
    QUANTILES.iter().map(|q| match *q {
        0.0 => "min".to_owned(),
        1.0 => "max".to_owned(),
        0.5 => "median".to_owned(),
        q => format!("p{:.0}", q * 100.0),
    })
}

/// The distributions both pages tabulate over the depths: title, statistic, digits shown.
type Statistic = (&'static str, fn(&DepthStats) -> &Distribution, usize);
const DISTRIBUTIONS: [Statistic; 3] = [
    ("ΔPSNR (dB)", |d| &d.psnr_gain, 2),
    ("ΔFLIP", |d| &d.flip_change, 4),
    ("size ratio multi / SVO", |d| &d.size_ratio, 3),
];

/// The tables of [`DISTRIBUTIONS`] with their titles: one row per depth, one column per
/// quantile.
fn distribution_tables(stats: &[DepthStats]) -> Vec<(&'static str, Table)> {
    let header: Vec<String> = ["depth".to_owned(), "n".to_owned()]
        .into_iter()
        .chain(quantile_header())
        .collect();
    DISTRIBUTIONS
        .into_iter()
        .map(|(title, pick, digits)| {
            let rows = stats
                .iter()
                .map(|d| {
                    let dist = pick(d);
                    let mut row = vec![d.depth.to_string(), dist.n.to_string()];
                    row.extend(dist.quantiles.iter().map(|q| num(*q, digits)));
                    row
                })
                .collect();
            (
                title,
                Table {
                    header: header.clone(),
                    rows,
                },
            )
        })
        .collect()
}

/// The summary table: per depth, median gain, shares, median size ratio.
fn summary_table(stats: &[DepthStats]) -> Table {
    Table {
        header: [
            "depth",
            "models",
            "median ΔPSNR (dB)",
            "median ΔFLIP",
            "median size ×",
            "multi > SVO (PSNR)",
            "multi < SVO (FLIP)",
            "multi d > SVO d+1",
        ]
        .map(String::from)
        .to_vec(),
        rows: stats
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
            .collect(),
    }
}

/// The failed models: model, source, error.
fn failures_table(r: &DatasetReport) -> Table {
    Table {
        header: ["model", "source", "error"].map(String::from).to_vec(),
        rows: r
            .failures
            .iter()
            .map(|f| vec![f.model.clone(), f.source.clone(), f.error.clone()])
            .collect(),
    }
}

/// The depths swept, as a list.
fn depth_list(settings: &SweepSettings) -> String {
    let depths: Vec<String> = settings.depths.iter().map(u8::to_string).collect();
    depths.join(", ")
}

/// What `dataset.md` shows.
#[derive(Template)]
#[template(path = "dataset.md")]
struct Markdown<'a> {
    stats: &'a DatasetStats,
    settings: &'a SweepSettings,
    unfinished: usize,
    depths: String,
    summary: Table,
    distributions: Vec<(&'static str, Table)>,
    failures: Table,
}

/// `dataset.md`'s text.
pub fn markdown(r: &DatasetReport) -> Result<String, askama::Error> {
    let stats = &r.dataset;
    Markdown {
        stats,
        settings: &r.report.settings,
        unfinished: stats.unfinished(),
        depths: depth_list(&r.report.settings),
        summary: summary_table(&stats.depths),
        distributions: distribution_tables(&stats.depths),
        failures: failures_table(r),
    }
    .render()
}

/// An image of a worst model with its caption.
struct Figure {
    src: String,
    caption: String,
}

/// A worst model of a depth: its ΔPSNR and view 0's images.
struct Worst {
    name: String,
    triangles: usize,
    gain: String,
    figures: Vec<Figure>,
}

/// A depth's worst models.
struct WorstOfDepth {
    depth: u8,
    models: Vec<Worst>,
}

/// What `index.html` shows.
#[derive(Template)]
#[template(path = "dataset.html")]
struct Html<'a> {
    stats: &'a DatasetStats,
    settings: &'a SweepSettings,
    provenance: &'a Provenance,
    commit: &'a str,
    cpu: &'a str,
    manifest: &'a str,
    shards: usize,
    rows: usize,
    unfinished: usize,
    depths: String,
    summary: Table,
    /// Each distribution's table under its title as a heading (capitalised: the Markdown's
    /// titles run on in a sentence).
    distributions: Vec<(String, Table)>,
    worst: Vec<WorstOfDepth>,
    failures: Table,
}

/// `s` with its first letter a capital.
fn capitalised(s: &str) -> String {
    let mut chars = s.chars();
    chars
        .next()
        .into_iter()
        .flat_map(char::to_uppercase)
        .chain(chars)
        .collect()
}

/// The worst models of each depth with view 0 of the reference and of each method, and its
/// FLIP map: the images the merge copies ([`DatasetStats::shown`]).
fn worst(r: &DatasetReport) -> Vec<WorstOfDepth> {
    let settings = &r.report.settings;
    let triangles = |m: &str| {
        r.report
            .models
            .iter()
            .find(|x| x.model == m)
            .map_or(0, |x| x.triangles)
    };
    r.dataset
        .depths
        .iter()
        .map(|d| WorstOfDepth {
            depth: d.depth,
            models: d
                .worst
                .iter()
                .map(|(m, g)| {
                    let fig = |file: String, caption: String| Figure {
                        src: image_rel(m, &file),
                        caption,
                    };
                    let mut figures = vec![fig(reference_file(0), "reference".to_owned())];
                    for method in &settings.methods {
                        figures.push(fig(view_file(method, d.depth, 0), method.clone()));
                        figures.push(fig(
                            heatmap_file(method, d.depth, 0),
                            format!("{method} FLIP"),
                        ));
                    }
                    Worst {
                        name: m.clone(),
                        triangles: triangles(m),
                        gain: num(*g, 2),
                        figures,
                    }
                })
                .collect(),
        })
        .collect()
}

/// `index.html`'s text.
pub fn html(r: &DatasetReport) -> Result<String, askama::Error> {
    let stats = &r.dataset;
    let provenance = &r.report.provenance;
    Html {
        stats,
        settings: &r.report.settings,
        provenance,
        commit: provenance.git_commit.as_deref().unwrap_or("unknown"),
        cpu: provenance.cpu.as_deref().unwrap_or("an unknown CPU"),
        manifest: &r.manifest,
        shards: r.shards.len(),
        rows: r.report.rows.len(),
        unfinished: stats.unfinished(),
        depths: depth_list(&r.report.settings),
        summary: summary_table(&stats.depths),
        distributions: distribution_tables(&stats.depths)
            .into_iter()
            .map(|(title, t)| (capitalised(title), t))
            .collect(),
        worst: worst(r),
        failures: failures_table(r),
    }
    .render()
}

#[cfg(test)]
mod tests {
    use super::super::assert_contains_all;
    use super::super::dataset::{depth_stats, time_fit, Failure, ShardSummary};
    use super::super::model::{Model, Report, Row};
    use super::super::results_json;
    use super::*;
    use crate::Shard;

    fn row(model: &str, method: &str, psnr: f64, bytes: usize) -> Row {
        Row {
            model: model.into(),
            method: method.into(),
            depth: 4,
            psnr: Some(psnr),
            flip: 0.1,
            bytes,
            ..Row::default()
        }
    }

    /// Two models, one failure whose source and error hold what HTML and Markdown must escape
    /// (a shard folder is untrusted: its ledger says what the error line is).
    fn report() -> DatasetReport {
        let settings = SweepSettings::for_tests(vec![4], 16);
        let models: Vec<Model> = ["a", "b"]
            .map(|m| Model {
                model: m.into(),
                source: format!("{m}.obj"),
                triangles: 12,
                reference_render_ms: 1.0,
            })
            .to_vec();
        let rows = vec![
            row("a", "svo", 20.0, 100),
            row("a", "multi", 23.5, 120),
            row("b", "svo", 30.0, 100),
            row("b", "multi", 29.0, 100),
        ];
        let dataset = DatasetStats {
            manifest_models: 4,
            done: 2,
            failed: 1,
            depths: depth_stats(&settings, &models, &rows),
            time_per_model: time_fit(&[(12, 100.0), (12, 300.0)]),
        };
        let provenance = Provenance::current(&settings, 1);
        DatasetReport {
            dataset,
            failures: vec![Failure {
                index: 2,
                id: "c".into(),
                model: "c".into(),
                source: "<script>c|d.obj".into(),
                error: "bad | \"mesh\"\nsecond line".into(),
            }],
            manifest: "m<1>.csv".into(),
            report: Report::new(settings, provenance, models, rows, Vec::new()),
            settings_hash: "0123abcd".into(),
            shards: vec![ShardSummary {
                folder: "s0".into(),
                shard: Shard::ALL,
                models: 4,
                wall_ms: 400.0,
            }],
        }
    }

    #[test]
    fn results_json_is_the_typed_report_and_reads_back() {
        let r = report();
        let text = results_json(&r).unwrap();
        let back: DatasetReport = serde_json::from_str(&text).unwrap();
        assert_eq!(back, r);
        // The single run's keys at the top level, beside the dataset's, sorted.
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
        assert_eq!(
            keys,
            [
                "dataset",
                "failures",
                "manifest",
                "models",
                "provenance",
                "rows",
                "settings",
                "settings_hash",
                "shards",
                "summary"
            ]
        );
    }

    #[test]
    fn the_markdown_has_every_table_and_escapes_the_failure() {
        let md = markdown(&report()).unwrap();
        assert!(
            md.starts_with("# Dataset sweep: 4 models (2 done, 1 failed, 1 not run)\n\n"),
            "{md}"
        );
        // a gains 3.5 dB, b loses 1: the median of two is the lower (nearest rank).
        assert_contains_all(
            &md,
            &[
                "| 4 | 2 | -1.00 | 0.0000 | 1.000 | 50 % | 0 % | – |",
                "\nΔPSNR (dB):\n\n",
                "\nΔFLIP:\n\n",
                "\nsize ratio multi / SVO:\n\n",
                "mean 200 ms over 2 models, 0.4 s in all",
            ],
        );
        assert!(
            md.ends_with("| c | <script>c\\|d.obj | bad \\| \"mesh\" second line |\n"),
            "{md}"
        );
    }

    #[test]
    fn the_page_escapes_what_a_shard_folder_says() {
        let html = html(&report()).unwrap();
        assert!(!html.contains("<script>"), "{html}");
        assert_contains_all(
            &html,
            &[
                "<code>m&#60;1&#62;.csv</code>",
                "<td>&#60;script&#62;c|d.obj</td>",
                "<b>1 not run</b>",
                "<h3>Size ratio multi / SVO</h3>",
                // The worst model of depth 4 (b, −1 dB) with its images, relative links.
                "<div><b>b</b> (12 triangles): ΔPSNR -1.00 dB<br>",
                "<img src=\"images/b/multi_d4_0_flip.png\" alt=\"multi FLIP\">",
            ],
        );
        assert!(html.ends_with("</body></html>\n"), "{html}");
    }
}
