//! table.md: a table per model laid out like the paper's Tables 1–2, the multi-octree against the
//! SVO one level deeper, and a summary across models.

use std::fmt::Write as _;

use super::model::Report;
use super::tables::{
    levels_table, model_heading, model_table, protocol, shallower_table, summary_table,
};

/// What the levels table shows, for table.md and the page.
pub const LEVELS_NOTE: &str = "Levels of one file (sweep --levels): one build writes every \
     level, coarsest first; a reader given the first MB read of the file draws that level. \
     file / leaf-only: the whole file against its finest level alone (the file a build of that \
     depth without levels writes).";

/// table.md's text.
pub fn table_md(report: &Report) -> String {
    let mut s = format!("# sdfmo sweep\n\n{}\n", protocol(report));
    for e in &report.extra_rows {
        let _ = writeln!(
            s,
            "\nRows of {} from another producer: {} ({} rows).",
            e.methods.join(", "),
            e.file,
            e.rows
        );
    }
    for name in &report.model_names() {
        let _ = write!(
            s,
            "\n## {}\n\n{}",
            model_heading(report, name),
            model_table(report, name).markdown()
        );
        if let Some(t) = shallower_table(report, name) {
            let _ = write!(
                s,
                "\nMulti-octree at depth d against the SVO at depth d + 1:\n\n{}",
                t.markdown()
            );
        }
        if let Some(t) = levels_table(report, name) {
            let _ = write!(s, "\n{LEVELS_NOTE}\n\n{}", t.markdown());
        }
    }
    if let Some(t) = summary_table(report) {
        let _ = write!(
            s,
            "\n## Summary over the models (multi-octree against SVO)\n\n{}",
            t.markdown()
        );
    }
    s
}
