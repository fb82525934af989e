//! `sdfmo generate-parts -n N [--seed S] -o DIR`: seeded CAD-like parts
//! ([`sdf_multioctree::mesh::procedural::cad`]) as OBJ files (one `o` block per feature, so each
//! feature is a part) and `DIR/manifest.csv` (`id,path`, relative to DIR) listing them, ready for
//! `sdfmo sweep --manifest DIR/manifest.csv`.

use std::fmt::Write as _;
use std::path::Path;

use sdf_multioctree::mesh::procedural::cad;
use sdf_multioctree::mesh::write::to_obj;

use crate::args::GeneratePartsArgs;
use crate::output::{print_json, print_text, write_derived};
use crate::progress;

/// File name of part `index`.
pub fn part_file(index: u64) -> String {
    format!("part_{index:06}.obj")
}

/// Writes the parts, then the manifest (last, so a manifest only lists parts that exist).
pub fn run(args: &GeneratePartsArgs) -> anyhow::Result<()> {
    let out = &args.output;
    // The last index must exist: `--first 18446744073709551615 -n 2` wrapped to an empty range
    // and claimed two parts written.
    let Some(last) = args.first.checked_add(args.count) else {
        anyhow::bail!(
            "--first {} -n {}: the part indices would pass {} (the largest index)",
            args.first,
            args.count,
            u64::MAX
        );
    };
    sdf_multioctree::io::create_derived_dir(out, Path::new(""))?;
    let bar = progress::steps(args.count, "parts");
    let mut manifest = String::from("id,path\n");
    let mut triangles = 0usize;
    for i in args.first..last {
        let part = cad::cad_part(cad::part_seed(args.seed, i));
        triangles += part.mesh.triangle_count();
        let file = part_file(i);
        let mut text = format!(
            "# sdfmo generate-parts: seed {} index {i}; features:",
            args.seed
        );
        for f in &part.features {
            let _ = write!(text, " {}", f.kind.name());
        }
        text.push('\n');
        text.push_str(&to_obj(&part.mesh));
        write_derived(&out.join(&file), text.as_bytes())?;
        let _ = writeln!(manifest, "part_{i:06},{file}");
        bar.inc(1);
    }
    write_derived(&out.join("manifest.csv"), manifest.as_bytes())?;
    bar.finish_and_clear();
    let manifest_path = out.join("manifest.csv");
    if args.json {
        return print_json(&serde_json::json!({
            "output": out.display().to_string(),
            "manifest": manifest_path.display().to_string(),
            "parts": args.count,
            "triangles": triangles,
        }));
    }
    print_text(&format!(
        "Wrote {} parts ({} triangles in all) and {}.\n",
        args.count,
        triangles,
        manifest_path.display()
    ))
}
