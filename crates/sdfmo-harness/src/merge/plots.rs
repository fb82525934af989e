//! The dataset report's plots: the CDF of the PSNR gain and of the size ratio per depth, and
//! build and render time against triangle count.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use crate::error::{HarnessError, Result};
use crate::files::write_derived_png;
use crate::plots::{axis_label, log_ticks, Drawn, PALETTE};
use crate::{Model, Row, SweepSettings};

const WIDTH: u32 = 1100;
const HEIGHT: u32 = 560;
/// Width of the scatter plot's legend column, right of the chart: inside the chart the legend
/// covered the points of the smallest models.
const LEGEND_WIDTH: u32 = 230;

/// One colour per depth (or method), cycled: the sweep's palette without its brown and pink.
const COLORS: [RGBColor; 6] = {
    let p = PALETTE;
    [p[0], p[1], p[2], p[3], p[4], p[7]]
};

/// Writes the plots into `out`; returns their file names.
pub fn write(
    out: &Path,
    settings: &SweepSettings,
    models: &[Model],
    rows: &[Row],
) -> Result<Vec<String>> {
    crate::plots::register_font()?;
    let mut files = Vec::new();
    let per_depth = |f: &dyn Fn(&Row, &Row) -> f64| -> Vec<(String, Vec<f64>)> {
        settings
            .depths
            .iter()
            .map(|&d| {
                let v: Vec<f64> = models
                    .iter()
                    .filter_map(|m| {
                        let find = |method: &str| {
                            rows.iter()
                                .find(|r| r.model == m.model && r.method == method && r.depth == d)
                        };
                        Some(f(find("multi")?, find("svo")?)).filter(|v| v.is_finite())
                    })
                    .collect();
                (format!("depth {d}"), v)
            })
            .collect()
    };
    let gains = per_depth(&|m, s| match (m.psnr, s.psnr) {
        (Some(a), Some(b)) => a - b,
        (None, None) => 0.0,
        _ => f64::NAN,
    });
    let ratios = per_depth(&|m, s| m.bytes as f64 / s.bytes.max(1) as f64);
    for (file, title, xlabel, series) in [
        (
            "dataset_psnr_gain_cdf.png",
            "Share of models with a PSNR gain ≤ x (multi-octree − SVO, same depth)",
            "ΔPSNR (dB)",
            gains,
        ),
        (
            "dataset_size_ratio_cdf.png",
            "Share of models with a size ratio ≤ x (multi-octree / SVO, same depth)",
            "size ratio",
            ratios,
        ),
    ] {
        let img = cdf(title, xlabel, &series).map_err(|reason| HarnessError::Plot {
            plot: file.to_owned(),
            reason,
        })?;
        write_derived_png(&out.join(file), &img)?;
        files.push(file.to_owned());
    }
    // Build and render time at the deepest depth against triangles, per method.
    let deepest = settings.depths.iter().copied().max().unwrap_or(0);
    let mut points: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for method in &settings.methods {
        for (what, pick) in [
            ("build", (|r: &Row| r.build_ms) as fn(&Row) -> Option<f64>),
            ("render", |r: &Row| Some(r.render_ms)),
        ] {
            let v = models
                .iter()
                .filter_map(|m| {
                    let r = rows.iter().find(|r| {
                        r.model == m.model && r.method == *method && r.depth == deepest
                    })?;
                    Some((m.triangles.max(1) as f64, pick(r)?.max(1e-3)))
                })
                .collect();
            points.push((format!("{method} {what}, depth {deepest}"), v));
        }
    }
    let file = "dataset_time_vs_triangles.png";
    let img = scatter(
        "Build time and render time per view against triangles",
        &points,
    )
    .map_err(|reason| HarnessError::Plot {
        plot: file.to_owned(),
        reason,
    })?;
    write_derived_png(&out.join(file), &img)?;
    files.push(file.to_owned());
    Ok(files)
}

/// The range of `values` padded by 5 %, never empty.
fn padded(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return 0.0..1.0;
    }
    let pad = ((hi - lo) * 0.05).max(1e-3);
    lo - pad..hi + pad
}

/// Empirical CDFs, one line per series.
fn cdf(title: &str, xlabel: &str, series: &[(String, Vec<f64>)]) -> Drawn<image::RgbImage> {
    let xr = padded(series.iter().flat_map(|s| s.1.iter().copied()));
    let frame = Frame {
        title,
        x_desc: xlabel,
        y_desc: "share of models",
        y_label_area: 64,
        legend: Legend::Inside(SeriesLabelPosition::LowerRight),
    };
    frame.draw(xr, 0.0..1.0, |chart| {
        for (k, (label, values)) in series.iter().enumerate() {
            let mut v = values.clone();
            v.sort_by(f64::total_cmp);
            let n = v.len() as f64;
            let color = COLORS[k % COLORS.len()];
            let pts: Vec<(f64, f64)> = v
                .iter()
                .enumerate()
                .flat_map(|(i, &x)| [(x, i as f64 / n), (x, (i + 1) as f64 / n)])
                .collect();
            chart
                .draw_series(LineSeries::new(pts, color.stroke_width(3)))
                .map_err(|e| e.to_string())?
                .label(format!("{label} ({} models)", v.len()))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
                });
        }
        Ok(())
    })
}

/// A log–log scatter plot, one colour per series, ticks at 1, 2 and 5 times the powers of ten
/// (the powers alone over a wide range, [`log_ticks`]) with short labels, the legend in a
/// column of its own.
fn scatter(title: &str, series: &[(String, Vec<(f64, f64)>)]) -> Drawn<image::RgbImage> {
    let all = || series.iter().flat_map(|s| s.1.iter().copied());
    let log_range = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
        if lo.is_finite() && hi > 0.0 {
            lo / 1.3..hi * 1.3
        } else {
            1.0..10.0
        }
    };
    let xr = log_range(&mut all().map(|p| p.0));
    let yr = log_range(&mut all().map(|p| p.1));
    let entries: Vec<(&str, RGBColor)> = series
        .iter()
        .enumerate()
        .map(|(k, (label, _))| (label.as_str(), COLORS[k % COLORS.len()]))
        .collect();
    let frame = Frame {
        title,
        x_desc: "triangles",
        y_desc: "time (ms)",
        y_label_area: 72,
        legend: Legend::Column(&entries),
    };
    let (kx, ky) = (log_ticks(&xr), log_ticks(&yr));
    frame.draw(
        xr.log_scale().with_key_points(kx),
        yr.log_scale().with_key_points(ky),
        |chart| {
            for (k, (_, pts)) in series.iter().enumerate() {
                let color = COLORS[k % COLORS.len()];
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                    .map_err(|e| e.to_string())?;
            }
            Ok(())
        },
    )
}

/// Where a plot's legend goes.
enum Legend<'a> {
    /// Inside the chart, plotters' legend of the labelled series.
    Inside(SeriesLabelPosition),
    /// In a column right of the chart, outside the data: a filled circle and a label per
    /// entry.
    Column(&'a [(&'a str, RGBColor)]),
}

/// What the dataset plots share around their series: the caption, the axes' descriptions, the
/// width of the y labels and where the legend goes.
struct Frame<'a> {
    title: &'a str,
    x_desc: &'a str,
    y_desc: &'a str,
    y_label_area: u32,
    legend: Legend<'a>,
}

impl Frame<'_> {
    /// A `WIDTH` × `HEIGHT` image: a white chart over `xr` × `yr` with this frame, the series
    /// `series` draws, and their legend.
    fn draw<X, Y>(
        self,
        xr: X,
        yr: Y,
        series: impl FnOnce(
            &mut ChartContext<
                '_,
                BitMapBackend<'_>,
                Cartesian2d<X::CoordDescType, Y::CoordDescType>,
            >,
        ) -> Drawn<()>,
    ) -> Drawn<image::RgbImage>
    where
        X: AsRangedCoord<Value = f64>,
        Y: AsRangedCoord<Value = f64>,
        X::CoordDescType: ValueFormatter<f64>,
        Y::CoordDescType: ValueFormatter<f64>,
    {
        let mut buf = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (WIDTH, HEIGHT)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| e.to_string())?;
            let (area, column) = match self.legend {
                Legend::Column(_) => {
                    let (area, column) = root.split_horizontally(WIDTH - LEGEND_WIDTH);
                    (area, Some(column))
                }
                Legend::Inside(_) => (root.clone(), None),
            };
            // Short tick labels (0.3, 25, 100000: no trailing ".0"), the sweep's plots' rule.
            let label = |v: &f64| axis_label(*v, false);
            let mut chart = ChartBuilder::on(&area)
                .caption(self.title, ("sans-serif", 22))
                .margin(12)
                // Room right of the chart for half of the last x label, which is centred on
                // the chart's edge (a 6-digit label was cut off).
                .margin_right(40)
                .x_label_area_size(48)
                .y_label_area_size(self.y_label_area)
                .build_cartesian_2d(xr, yr)
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc(self.x_desc)
                .y_desc(self.y_desc)
                .x_label_formatter(&label)
                .y_label_formatter(&label)
                .label_style(("sans-serif", 16))
                .axis_desc_style(("sans-serif", 18))
                .draw()
                .map_err(|e| e.to_string())?;
            series(&mut chart)?;
            match self.legend {
                Legend::Inside(position) => chart
                    .configure_series_labels()
                    .position(position)
                    .label_font(("sans-serif", 16))
                    .background_style(WHITE.mix(0.9))
                    .border_style(BLACK)
                    .draw()
                    .map_err(|e| e.to_string())?,
                Legend::Column(entries) => {
                    let column = column.expect("split for the column");
                    for (i, (text, color)) in entries.iter().enumerate() {
                        let y = 60 + 28 * i as i32;
                        column
                            .draw(&Circle::new((14, y), 5, color.filled()))
                            .map_err(|e| e.to_string())?;
                        column
                            .draw(&Text::new(
                                text.to_string(),
                                (28, y - 9),
                                ("sans-serif", 16).into_font(),
                            ))
                            .map_err(|e| e.to_string())?;
                    }
                }
            }
            root.present().map_err(|e| e.to_string())?;
        }
        image::RgbImage::from_raw(WIDTH, HEIGHT, buf).ok_or_else(|| "plot buffer size".to_owned())
    }
}
