//! `sdfmo compare`: PSNR and FLIP between two images.

use anyhow::Context;
use sdf_multioctree::metrics;
use serde_json::json;

use crate::args::CompareArgs;
use crate::output::{check_output, ensure_parent, json_f64, print_json, print_text};

/// Compares the two images and prints PSNR (dB) and mean FLIP; writes the heat map if asked.
pub fn run(args: &CompareArgs) -> anyhow::Result<()> {
    if let Some(out) = &args.heatmap {
        check_output(out, "the heat map (--heatmap)", &["png"])?;
    }
    let reference = metrics::load_rgb8(&args.reference)?;
    let test = metrics::load_rgb8(&args.test)?;
    let what = || {
        let (r, t) = (args.reference.display(), args.test.display());
        format!("cannot compare {r} with {t}")
    };
    let psnr = metrics::psnr(&reference, &test).with_context(what)?;
    let flip = metrics::flip(&reference, &test).with_context(what)?;
    if let Some(out) = &args.heatmap {
        ensure_parent(out)?;
        metrics::save_png(&metrics::flip_heatmap(&flip), out)?;
    }
    if args.json {
        return print_json(&json!({
            "reference": args.reference.display().to_string(),
            "test": args.test.display().to_string(),
            "width": reference.width(),
            "height": reference.height(),
            "psnr": json_f64(psnr),
            "identical": psnr.is_infinite(),
            "flip": flip.mean,
            "heatmap": args.heatmap.as_ref().map(|p| p.display().to_string()),
        }));
    }
    let mut s = format!("PSNR {}  FLIP {:.6}\n", fmt_psnr(psnr), flip.mean);
    if let Some(out) = &args.heatmap {
        s.push_str(&format!("FLIP heat map written to {}\n", out.display()));
    }
    print_text(&s)
}

/// PSNR for people: `inf dB` when the images are identical.
pub fn fmt_psnr(psnr: f64) -> String {
    if psnr.is_finite() {
        format!("{psnr:.3} dB")
    } else {
        "inf dB (identical)".to_owned()
    }
}
