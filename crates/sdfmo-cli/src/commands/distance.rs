//! `sdfmo distance`: signed distances of points to a mesh, in model units (or, with
//! `--normalized`, in the octree's normalised frame).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::{bail, Context};
use glam::{DVec3, Vec3};
use sdf_multioctree::distance::{reshape_fans, MeshDistance};
use sdf_multioctree::mesh::Normalization;
use serde_json::json;

use crate::args::DistanceArgs;
use crate::commands::{load_input, sign_name, Workers};
use crate::output::{check_output, json_f32, print_json, print_text, write_atomic};

/// Largest points file read (1 GiB, some 30 million points).
const MAX_POINTS_FILE: u64 = 1 << 30;

/// Largest coordinate accepted: the queries work with squared distances in f32, which overflow
/// (to a `null` distance) beyond about 1.8e19.
const MAX_COORDINATE: f32 = sdf_multioctree::distance::MAX_QUERY_COORDINATE;

/// Most characters of a malformed line or field quoted in an error.
const MAX_QUOTED: usize = 60;

/// `text` quoted for an error message, cut to [`MAX_QUOTED`] characters with the full length
/// named, so a hostile 1 GiB line does not become a 1 GiB message.
fn quoted(text: &str) -> String {
    let mut chars = text.char_indices();
    match chars.nth(MAX_QUOTED) {
        None => format!("{text:?}"),
        Some((cut, _)) => format!("{:?}… ({} bytes in all)", &text[..cut], text.len()),
    }
}

/// Loads the mesh, normalises it as the builder does, and prints or writes one signed distance
/// per point (negative inside), in the points' frame: model units unless `--normalized`.
pub fn run(args: &DistanceArgs) -> anyhow::Result<()> {
    if let Some(out) = &args.output {
        check_output(out, "the distances file (-o)", &[])?;
    }
    let text = sdf_multioctree::io::read_regular_to_string(&args.points, MAX_POINTS_FILE)?;
    let input = load_input(Some(&args.mesh))?;
    // The queries run in the normalised frame; model-unit points are mapped there and the
    // distances back with the conversions Python and the library use (`Normalization`), so the
    // three front-ends give the same number for the same point.
    let frame = sdf_multioctree::mesh_frame(&input.mesh);
    let to_frame = (!args.normalized).then_some(&frame);
    let points = parse_points(&text, &args.points, to_frame)?;
    // Only distances are printed, so flat fans may be re-triangulated (same surface).
    let reshaped = reshape_fans(&input.mesh);
    let mesh = reshaped.as_ref().map_or(&input.mesh, |r| &r.mesh);
    let (normalized, _) = mesh.normalized(sdf_multioctree::DEFAULT_MARGIN);
    let dist = MeshDistance::new(&normalized, args.sign.mode())
        .with_context(|| format!("cannot prepare distance queries on {}", input.source))?;

    // The worker threads are started (and woken) before the clock starts: `query_ms` is the
    // queries alone.
    let (distances, query_ms) = Workers::new(args.threads)?.install(|| {
        rayon::broadcast(|_| ());
        let start = Instant::now();
        let d = dist.signed_distances(&points);
        (d, start.elapsed().as_secs_f64() * 1e3)
    });
    let distances: Vec<f32> = match to_frame {
        Some(frame) => distances
            .iter()
            .map(|&d| frame.length_to_model(d))
            .collect(),
        None => distances,
    };

    let mut lines = String::with_capacity(distances.len() * 12);
    for d in &distances {
        let _ = writeln!(lines, "{d}");
    }
    if let Some(out) = &args.output {
        write_atomic(out, lines.as_bytes())?;
    }
    let sign = sign_name(dist.sign_mode());
    if args.json {
        let mut j = json!({
            "mesh": input.source,
            "points": points.len(),
            "sign": sign,
            "frame": if args.normalized { "normalized" } else { "model" },
            "query_ms": query_ms,
        });
        match &args.output {
            Some(out) => j["output"] = json!(out.display().to_string()),
            // Each f32 as its shortest decimal (what the text output prints), not widened to
            // f64 digits.
            None => j["distances"] = distances.iter().map(|&d| json_f32(d)).collect(),
        }
        return print_json(&j);
    }
    match &args.output {
        Some(out) => print_text(&format!(
            "{} signed distances ({sign} sign) to {} written to {} in {query_ms:.3} ms of queries\n",
            points.len(),
            input.source,
            out.display()
        )),
        None => print_text(&lines),
    }
}

/// Parses `x y z` lines (whitespace or commas between the numbers); blank lines and `#`
/// comments are skipped. A malformed line is an error naming the file and the line. With a
/// `frame`, the numbers are model units, read as f64 and mapped into the normalised frame
/// (rounded once); without, they are read as f32 in the normalised frame.
pub fn parse_points(
    text: &str,
    file: &Path,
    frame: Option<&Normalization>,
) -> anyhow::Result<Vec<Vec3>> {
    let mut points = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|f| !f.is_empty())
            .collect();
        let where_ = || format!("{}:{}", file.display(), i + 1);
        if fields.len() != 3 {
            bail!(
                "{}: expected 3 numbers `x y z`, found {} fields in {}",
                where_(),
                fields.len(),
                quoted(line)
            );
        }
        let mut p = [0.0f64; 3];
        for (slot, f) in p.iter_mut().zip(&fields) {
            // f32 text is parsed as f32 (not through f64, which could round twice).
            let v: f64 = match frame {
                Some(_) => f.parse::<f64>().ok(),
                None => f.parse::<f32>().ok().map(f64::from),
            }
            .ok_or_else(|| anyhow::anyhow!("{}: {} is not a number", where_(), quoted(f)))?;
            if !v.is_finite() {
                bail!("{}: {} is not a finite coordinate", where_(), quoted(f));
            }
            *slot = v;
        }
        let q = match frame {
            Some(frame) => frame.point_to_normalized(DVec3::from_array(p)),
            None => DVec3::from_array(p).as_vec3(),
        };
        if let Some(c) = q
            .to_array()
            .iter()
            .find(|c| !c.is_finite() || c.abs() > MAX_COORDINATE)
        {
            bail!(
                "{}: {} lies {c:e} from the origin of the normalised frame, beyond \
                 {MAX_COORDINATE:e}, where distances overflow f32",
                where_(),
                quoted(line)
            );
        }
        points.push(q);
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_lines_are_quoted_in_part() {
        let line = "\0".repeat(1 << 20);
        let err = parse_points(&line, Path::new("p.xyz"), None)
            .unwrap_err()
            .to_string();
        assert!(err.len() < 400, "{}", err.len());
        assert!(err.contains("1048576 bytes in all"), "{err}");
        let err = parse_points(
            &format!("1 2 {}", "9".repeat(100_000)),
            Path::new("p.xyz"),
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(err.len() < 400, "{}", err.len());
    }

    #[test]
    fn huge_coordinates_are_refused() {
        let err = parse_points("1e20 0 0", Path::new("p.xyz"), None).unwrap_err();
        assert!(err.to_string().contains("overflow"), "{err}");
        assert!(parse_points("1e17 0 0", Path::new("p.xyz"), None).is_ok());
    }

    #[test]
    fn points_parse_with_comments_and_commas() {
        let p = parse_points(
            "# header\n0 0 0\n\n1,2,3\n -0.5\t0.25 1e-3 \n",
            Path::new("p.xyz"),
            None,
        )
        .unwrap();
        assert_eq!(
            p,
            vec![
                Vec3::ZERO,
                Vec3::new(1.0, 2.0, 3.0),
                Vec3::new(-0.5, 0.25, 1e-3)
            ]
        );
    }

    #[test]
    fn model_units_map_into_the_frame_once() {
        let frame = Normalization {
            center: Vec3::new(10.0, 0.0, -5.0),
            scale: 0.25,
        };
        let p = parse_points("14 2 -5\n10.1 0 -5", Path::new("p.xyz"), Some(&frame)).unwrap();
        assert_eq!(p[0], Vec3::new(1.0, 0.5, 0.0));
        // 10.1 is read as f64 (not rounded to f32 first): (10.1 − 10) · 0.25 rounded once.
        assert_eq!(p[1].x, ((10.1f64 - 10.0) * 0.25) as f32);
        // A model point whose image leaves the f32-safe range is refused by line.
        let e = parse_points("0 0 0\n1e30 0 0", Path::new("p.xyz"), Some(&frame))
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.xyz:2") && e.contains("overflow"), "{e}");
    }

    #[test]
    fn malformed_lines_are_named() {
        let e = parse_points("0 0 0\n1 2\n", Path::new("p.xyz"), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.xyz:2"), "{e}");
        let e = parse_points("0 0 zero\n", Path::new("p.xyz"), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.xyz:1") && e.contains("zero"), "{e}");
        let e = parse_points("0 0 0\n0 NaN 0\n", Path::new("p.xyz"), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.xyz:2"), "{e}");
    }
}
