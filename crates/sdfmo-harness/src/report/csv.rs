//! results.csv through the `csv` crate: a model name with a comma or a quote is quoted as RFC
//! 4180 says, which the hand-written writer this replaces did not do. The numbers keep their
//! fixed decimals (PSNR 4, FLIP 6, times 3), `inf` for identical images, and an empty cell for
//! a value another producer does not have.

use super::model::Report;
use crate::error::Result;

/// The columns every results.csv has (the header the hand-written writer wrote); `lod` and
/// `bytes_read` follow when a row has one.
const HEADER: &str = "model,method,depth,psnr,flip,bytes,build_ms,render_ms,nodes,leaves,voxels,\
                      surface_voxels,cap_hits";

/// The rows of `report` as CSV text.
pub fn csv(report: &Report) -> Result<String> {
    let with_lod = report.rows.iter().any(|r| r.lod.is_some());
    let with_read = report.rows.iter().any(|r| r.bytes_read.is_some());
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    let mut header: Vec<&str> = HEADER.split(',').collect();
    if with_lod {
        header.push("lod");
    }
    if with_read {
        header.push("bytes_read");
    }
    w.write_record(&header)?;
    let count = |v: Option<usize>| v.map_or(String::new(), |v| v.to_string());
    for r in &report.rows {
        let mut record = vec![
            r.model.clone(),
            r.method.clone(),
            r.depth.to_string(),
            r.psnr.map_or("inf".to_owned(), |p| format!("{p:.4}")),
            format!("{:.6}", r.flip),
            r.bytes.to_string(),
            r.build_ms.map_or(String::new(), |ms| format!("{ms:.3}")),
            format!("{:.3}", r.render_ms),
            count(r.nodes),
            count(r.leaves),
            count(r.voxels),
            count(r.surface_voxels),
            count(r.cap_hits),
        ];
        if with_lod {
            record.push(r.lod.map_or(String::new(), |l| l.to_string()));
        }
        if with_read {
            record.push(r.bytes_read.map_or(String::new(), |b| b.to_string()));
        }
        w.write_record(&record)?;
    }
    Ok(text(w)?)
}

/// The text a CSV writer wrote (flushed into its buffer). Every field written is a `str`, so
/// the bytes are UTF-8 and the lossy conversion is exact.
pub fn text(w: csv::Writer<Vec<u8>>) -> std::result::Result<String, csv::Error> {
    let bytes = w
        .into_inner()
        .map_err(|e| csv::Error::from(e.into_error()))?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}
