//! table.md (through the askama template `templates/sweep.md`): a table per model laid out like the paper's Tables 1–2, the multi-octree against the
//! SVO one level deeper, and a summary across models.

use askama::Template;

use super::model::{ExtraRows, Report};
use super::tables::{
    levels_table, model_heading, model_table, protocol, shallower_table, summary_table, Table,
};
use crate::error::Result;

/// What the levels table shows, for table.md and the page.
pub const LEVELS_NOTE: &str = "Levels of one file (sweep --levels): one build writes every \
     level, coarsest first; a reader given the first MB read of the file draws that level. \
     file / leaf-only: the whole file against its finest level alone (the file a build of that \
     depth without levels writes).";

/// A model's tables in table.md.
struct Section {
    heading: String,
    table: Table,
    shallower: Option<Table>,
    levels: Option<Table>,
}

/// What table.md shows.
#[derive(Template)]
#[template(path = "sweep.md")]
struct TableMd<'a> {
    protocol: String,
    extra: &'a [ExtraRows],
    sections: Vec<Section>,
    levels_note: &'a str,
    summary: Option<Table>,
}

/// table.md's text.
pub fn table_md(report: &Report) -> Result<String> {
    Ok(TableMd {
        protocol: protocol(report),
        extra: &report.extra_rows,
        sections: report
            .model_names()
            .iter()
            .map(|name| Section {
                heading: model_heading(report, name),
                table: model_table(report, name),
                shallower: shallower_table(report, name),
                levels: levels_table(report, name),
            })
            .collect(),
        levels_note: LEVELS_NOTE,
        summary: summary_table(report),
    }
    .render()?)
}
