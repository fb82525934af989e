//! The sweep's report: one typed model ([`model::Report`]) rendered four ways — results.json
//! (serde), results.csv (the `csv` crate), table.md and index.html (an askama template) — each
//! written atomically. One concern a module: the model, the tables both text renderers lay out,
//! each renderer, the page's crops, and the rows other producers feed in (`--extra-rows`).

pub mod crops;
pub mod csv;
pub mod dataset;
pub mod dataset_page;
pub mod extra;
pub mod html;
pub mod markdown;
pub mod model;
pub mod tables;

use std::path::Path;

pub use html::write_html;
pub use markdown::table_md;
pub use model::{Model, Provenance, Report, Row, SweepSettings};

use crate::error::{HarnessError, Result};
use crate::files::write_derived;

/// results.json's text: the report (a sweep's [`Report`] or a merge's
/// [`dataset::DatasetReport`]), pretty-printed, with a final newline. Through a
/// `serde_json::Value`, whose maps sort their keys: every object's keys in alphabetical order,
/// as results.json has always had them (scripts diff these files).
pub fn results_json(report: &impl serde::Serialize) -> Result<String> {
    let serialise = |source| HarnessError::Serialise {
        what: "results.json",
        source,
    };
    let value = serde_json::to_value(report).map_err(serialise)?;
    let mut text = serde_json::to_string_pretty(&value).map_err(serialise)?;
    text.push('\n');
    Ok(text)
}

/// Writes results.json, results.csv and table.md; returns their names.
pub fn write_tables(out: &Path, report: &Report) -> Result<Vec<String>> {
    write_derived(&out.join("results.json"), results_json(report)?.as_bytes())?;
    write_derived(&out.join("results.csv"), csv::csv(report)?.as_bytes())?;
    write_derived(&out.join("table.md"), table_md(report)?.as_bytes())?;
    Ok(vec![
        "results.json".into(),
        "results.csv".into(),
        "table.md".into(),
    ])
}

/// Asserts that `text` contains each of `needles` (the report tests' check; the whole text in
/// the message).
#[cfg(test)]
fn assert_contains_all(text: &str, needles: &[&str]) {
    for needle in needles {
        assert!(text.contains(needle), "{needle:?} not in:\n{text}");
    }
}

#[cfg(test)]
mod tests {
    use super::model::ExtraRows;
    use super::*;

    fn settings() -> SweepSettings {
        SweepSettings::for_tests(vec![4, 5], 32)
    }

    fn row(method: &str, depth: u8, psnr: Option<f64>, bytes: usize) -> Row {
        Row {
            model: "m".into(),
            method: method.into(),
            depth,
            psnr,
            flip: 0.05,
            bytes,
            build_ms: Some(10.0),
            render_ms: 4.0,
            nodes: Some(1),
            leaves: Some(1),
            voxels: Some(1),
            surface_voxels: Some(0),
            cap_hits: Some(0),
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

    fn report(rows: Vec<Row>, extra: Vec<ExtraRows>) -> Report {
        let s = settings();
        Report::new(s.clone(), Provenance::current(&s, 3), vec![], rows, extra)
    }

    #[test]
    fn table_has_gains_ratios_and_the_deeper_svo() {
        let md = table_md(&report(rows(), vec![])).unwrap();
        // depth 4: +2.50 dB, size 1.20×; depth 5: multi identical to the reference (∞).
        assert_contains_all(
            &md,
            &[
                "| 4 | 20.00 | 22.50 | +2.50 |",
                "| 1.20 |",
                "| 5 | 23.00 | ∞ | – |",
                // multi at depth 4 against SVO at depth 5: 22.5 − 23.0.
                "| 4 | 22.50 | 23.00 | -0.50 |",
                "median ΔPSNR",
                "median over 3 frames",
            ],
        );
    }

    #[test]
    fn table_md_has_a_levels_table_for_a_file_with_levels() {
        // table.md's template was checked byte for byte against the hand-written writer it
        // replaced on seven reports (extra rows, levels, two models, SVO only, no rows).
        let mut levels = rows();
        for (k, r) in levels.iter_mut().enumerate() {
            r.bytes_read = Some(100 * k as u64 + 50);
        }
        let md = table_md(&report(levels, vec![])).unwrap();
        assert!(
            md.contains(&format!("\n{}\n\n|", markdown::LEVELS_NOTE)),
            "{md}"
        );
        assert!(
            md.starts_with("# sdfmo sweep\n\n") && md.ends_with(" |\n"),
            "{md}"
        );
        let md = table_md(&report(Vec::new(), vec![])).unwrap();
        assert!(!md.contains("## "), "{md}");
    }

    #[test]
    fn csv_has_a_line_per_row_and_inf_and_quotes_what_needs_it() {
        let mut rows = rows();
        let c = csv::csv(&report(rows.clone(), vec![])).unwrap();
        assert_eq!(c.lines().count(), 5);
        assert!(
            c.lines().nth(4).unwrap().starts_with("m,multi,5,inf,"),
            "{c}"
        );
        assert!(!c.contains("lod"), "{c}");
        // A name with a comma and a quote (sanitised names have neither, other producers'
        // rows are checked, but the writer must not rely on either).
        rows[0].model = "a,\"b".into();
        let c = csv::csv(&report(rows, vec![])).unwrap();
        assert!(
            c.lines().nth(1).unwrap().starts_with("\"a,\"\"b\",svo,4,"),
            "{c}"
        );
        let back: Vec<csv_record::Rec> = ::csv::Reader::from_reader(c.as_bytes())
            .deserialize()
            .collect::<std::result::Result<_, _>>()
            .unwrap();
        assert_eq!(back[0].model, "a,\"b");
        assert_eq!(back.len(), 4);
    }

    mod csv_record {
        #[derive(serde::Deserialize)]
        pub struct Rec {
            pub model: String,
        }
    }

    #[test]
    fn results_json_round_trips_and_keeps_its_key_order() {
        let r = report(rows(), vec![]);
        let text = results_json(&r).unwrap();
        let back: Report = serde_json::from_str(&text).unwrap();
        assert_eq!(back, r);
        // The keys in the order results.json has always had (alphabetical), `summary` last;
        // inside a row too.
        let keys: Vec<usize> = [
            "\"models\"",
            "\"provenance\"",
            "\"rows\"",
            "\"settings\"",
            "\"summary\"",
        ]
        .iter()
        .map(|k| text.find(k).unwrap())
        .collect();
        assert!(keys.windows(2).all(|w| w[0] < w[1]), "{text}");
        let row = &text[text.find("\"rows\"").unwrap()..];
        assert!(row.find("\"build_ms\"").unwrap() < row.find("\"bytes\"").unwrap());
        assert!(
            !text.contains("extra_rows") && !text.contains("\"lod\""),
            "{text}"
        );
        let p = &r.provenance;
        assert_eq!((p.threads, p.frames), (1, 3));
        assert!(p.program.starts_with("sdfmo-cli 0."), "{p:?}");
        // 2026-12-03T12:49:21Z
        assert_eq!(p.date.len(), 20, "{p:?}");
        assert!(
            p.date.ends_with('Z') && p.date.as_bytes()[10] == b'T',
            "{p:?}"
        );
    }

    #[test]
    fn the_summary_has_medians_per_method_and_the_gains() {
        let r = report(rows(), vec![]);
        let s = &r.summary;
        assert_eq!(s.methods.len(), 4);
        let multi5 = s
            .methods
            .iter()
            .find(|m| m.method == "multi" && m.depth == 5)
            .unwrap();
        assert_eq!((multi5.models, multi5.psnr), (1, None));
        assert_eq!(s.gains.len(), 2);
        assert_eq!(s.gains[0].median_psnr_gain, Some(2.5));
        assert_eq!(s.gains[1].median_psnr_gain, None);
        assert_eq!(s.gains[0].median_size_ratio, Some(1.2));
    }

    #[test]
    fn extra_rows_join_the_tables_with_their_own_columns() {
        let mut rows = rows();
        rows.push(Row {
            method: "nglod".into(),
            depth: 4,
            lod: Some(2),
            psnr: Some(18.25),
            build_ms: None,
            nodes: None,
            leaves: None,
            voxels: None,
            surface_voxels: None,
            cap_hits: None,
            ..row("svo", 4, None, 500)
        });
        let extra = vec![ExtraRows {
            file: "nglod.json".into(),
            rows: 1,
            methods: vec!["nglod".into()],
        }];
        let r = report(rows, extra);
        let md = table_md(&r).unwrap();
        assert_contains_all(
            &md,
            &[
                "PSNR dB nglod",
                "| 4 | 20.00 | 22.50 | 18.25 (LOD 2) | +2.50 |",
                "Rows of nglod from another producer: nglod.json (1 rows).",
            ],
        );
        let c = csv::csv(&r).unwrap();
        assert!(c.lines().next().unwrap().ends_with(",cap_hits,lod"), "{c}");
        assert!(
            c.lines().nth(5).unwrap().starts_with("m,nglod,4,18.2500,"),
            "{c}"
        );
        assert!(c.lines().nth(5).unwrap().ends_with(",,,,,,2"), "{c}");
        let text = results_json(&r).unwrap();
        assert!(
            text.contains("\"lod\": 2") && text.contains("\"extra_rows\""),
            "{text}"
        );
    }

    #[test]
    fn html_links_every_image_relatively_and_escapes() {
        let dir = tempfile::tempdir().unwrap();
        let files = vec!["results.json".to_owned(), "plot_a.png".to_owned()];
        let mut r = report(rows(), vec![]);
        r.provenance.cpu = Some("<b>CPU & \"co\"</b>".into());
        write_html(dir.path(), &r, &files).unwrap();
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        for v in 0..4 {
            assert!(html.contains(&format!("images/m/reference_{v}.png")));
            assert!(html.contains(&format!("images/m/multi_d5_{v}_flip.png")));
            assert!(html.contains(&format!("images/m/svo_d4_{v}.png")));
        }
        assert!(html.contains("src=\"plot_a.png\""));
        assert!(html.contains("<a href=\"results.json\">results.json</a>"));
        assert!(!html.contains("src=\"/"), "links must be relative");
        assert!(
            html.contains("&#60;b&#62;CPU &#38; &#34;co&#34;&#60;/b&#62;")
                || html.contains("&lt;b&gt;CPU &amp; &quot;co&quot;&lt;/b&gt;"),
            "{html}"
        );
        assert!(!html.contains("<b>CPU"), "{html}");
        // The images are not there: the crops say so instead of failing the page.
        assert!(html.contains("Zoomed crops unavailable"), "{html}");
    }
}
