//! The sweep's PNG plots (plotters, bitmap backend, text with an embedded DejaVu Sans through
//! plotters' `ab_glyph` feature: no system font library is involved).

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::Row;
use crate::error::{HarnessError, Result};
use crate::files::write_derived_png;

/// A drawing's result: the plotting library's error as text (its error type is generic over
/// the backend), which the caller names the plot in ([`HarnessError::Plot`]).
pub(crate) type Drawn<T> = std::result::Result<T, String>;

/// Plot size in pixels, legend included.
const WIDTH: u32 = 1100;
const HEIGHT: u32 = 600;
/// Width of the legend column right of the chart (outside the data).
const LEGEND_WIDTH: u32 = 250;

/// Text sizes in pixels of the 1100-pixel plot. The page shows two plots a row, each at about
/// 48 % of a 1600-pixel page (≈ 0.7×): tick labels of 22 pixels read at ≈ 15 CSS pixels, the
/// size of the page's own small text (15-pixel labels read at 10, which was too small).
const TITLE_PX: u32 = 32;
const TICK_PX: u32 = 22;
const AXIS_PX: u32 = 24;
const LEGEND_PX: u32 = 20;
const POINT_LABEL_PX: u32 = 17;

/// The plots' colours, from matplotlib's tab10: blue, red, green, purple, orange, brown, pink,
/// cyan.
pub(super) const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// A colour per method, the same in every plot: the SVO blue, the multi-octree red, NGLOD green
/// (the palette's first three), other producers' methods the next colours in turn.
const SVO: RGBColor = PALETTE[0];
const MULTI: RGBColor = PALETTE[1];
const NGLOD: RGBColor = PALETTE[2];
const OTHERS: &[RGBColor] = PALETTE.split_at(3).1;

/// The colour of `method`; `others` lists the methods without a fixed colour, in order.
fn method_color(method: &str, others: &[&str]) -> RGBColor {
    match method {
        "svo" => SVO,
        "multi" => MULTI,
        "nglod" => NGLOD,
        m => OTHERS[others.iter().position(|o| *o == m).unwrap_or(0) % OTHERS.len()],
    }
}

/// How a model's points are marked (the colour says the method): a shape per model, cycled.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Mark {
    Circle,
    Triangle,
    Square,
    Cross,
}

const MARKS: [Mark; 4] = [Mark::Circle, Mark::Triangle, Mark::Square, Mark::Cross];

/// Draws a point's mark `$mark` at `$at` (the area's coordinates) in `$color` on the drawing
/// area `$area`. A macro, as each shape is its own element type and the chart's and the legend's
/// areas are of different coordinate types.
macro_rules! draw_mark {
    ($area:expr, $mark:expr, $at:expr, $color:expr) => {{
        let (at, color) = ($at, $color);
        match $mark {
            Mark::Circle => $area.draw(&Circle::new(at, 6, color.filled())),
            Mark::Triangle => $area.draw(&TriangleMarker::new(at, 7, color.filled())),
            Mark::Square => $area
                .draw(&(EmptyElement::at(at) + Rectangle::new([(-5, -5), (5, 5)], color.filled()))),
            Mark::Cross => $area.draw(&Cross::new(at, 6, color.stroke_width(3))),
        }
    }};
}

/// Registers the embedded font under plotters' default family name, once.
pub(super) fn register_font() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(HarnessError::PlotFont)
    }
}

/// One line of a plot: a model's method.
struct Series {
    label: String,
    color: RGBColor,
    /// The model's mark; models after the first are also dashed, so two models of one method
    /// stay apart where their marks overlap.
    mark: Mark,
    dashed: bool,
    points: Vec<(f64, f64)>,
    /// Each point's tag, written beside it: `dN` for octree depth N, `LN` for another producer's
    /// own level of detail N (NGLOD's LOD, tabled at a depth).
    tags: Vec<String>,
}

/// Axis of a plot: its label and whether it is logarithmic.
#[derive(Clone, Copy)]
struct Axis<'a> {
    label: &'a str,
    log: bool,
    /// Integer values (depths): padded by half a step, labelled at integers only.
    integer: bool,
    /// How many labels (and bold grid lines) plotters may place: on an integer axis as many as
    /// integers, so that every grid line is labelled (ten put unlabelled lines at half depths).
    labels: usize,
}

impl Axis<'static> {
    /// A linear axis of real values.
    const fn linear(label: &'static str) -> Axis<'static> {
        Axis {
            label,
            log: false,
            integer: false,
            labels: 10,
        }
    }

    /// A logarithmic axis.
    const fn log(label: &'static str) -> Axis<'static> {
        Axis {
            log: true,
            ..Axis::linear(label)
        }
    }
}

/// Which plots the sweep writes: file name, title, axes, and the (x, y) of a row.
type Extract = fn(&Row) -> Option<(f64, f64)>;
const PLOTS: [(&str, &str, Axis<'static>, Axis<'static>, Extract); 4] = [
    (
        "plot_psnr_vs_size.png",
        "PSNR vs size",
        Axis::log("size (MB)"),
        Axis::linear("PSNR (dB)"),
        |r| r.psnr.map(|p| (r.bytes as f64 / 1e6, p)),
    ),
    (
        "plot_flip_vs_size.png",
        "FLIP vs size (lower is better)",
        Axis::log("size (MB)"),
        Axis::linear("mean FLIP"),
        |r| Some((r.bytes as f64 / 1e6, r.flip)),
    ),
    (
        "plot_psnr_vs_render_time.png",
        "PSNR vs render time per view",
        Axis::log(RENDER_TIME),
        Axis::linear("PSNR (dB)"),
        |r| r.psnr.map(|p| (r.render_ms, p)),
    ),
    (
        "plot_build_time_vs_depth.png",
        "Build time vs depth",
        Axis {
            label: "depth",
            log: false,
            integer: true,
            labels: 10,
        },
        Axis::log("build time (ms)"),
        |r| r.build_ms.map(|ms| (f64::from(r.depth), ms)),
    ),
];

/// The render-time axis's label; [`write_plots`] adds how the time was taken (the median of the
/// sweep's `--frames` renders of each view: one frame's time on a loaded machine is noise).
const RENDER_TIME: &str = "render time per view (ms)";

/// [`RENDER_TIME`] with how the time was taken from `frames` renders of each view.
fn render_time_label(frames: usize) -> String {
    match frames {
        0 | 1 => format!("{RENDER_TIME}, one frame"),
        n => format!("{RENDER_TIME}, median of {n} frames"),
    }
}

/// The plot of a sweep with `--levels`: PSNR against the bytes a reader needs for each level.
const LEVELS_PLOT: (&str, &str, Axis<'static>, Axis<'static>, Extract) = (
    "plot_psnr_vs_bytes_read.png",
    "Levels of one file: PSNR vs bytes read",
    Axis::log("bytes read (MB)"),
    Axis::linear("PSNR (dB)"),
    |r| Some((r.bytes_read? as f64 / 1e6, r.psnr?)),
);

/// Writes every plot into `dir` (the levels plot only when rows have `bytes_read`); returns the
/// file names. `frames`: the renders of each view whose median is a row's `render_ms`, said on
/// the render-time axis.
pub fn write_plots(dir: &Path, rows: &[Row], frames: usize) -> Result<Vec<String>> {
    let time_label = render_time_label(frames);
    register_font()?;
    let mut models: Vec<&str> = Vec::new();
    let mut others: Vec<&str> = Vec::new();
    for r in rows {
        if !models.contains(&r.model.as_str()) {
            models.push(&r.model);
        }
        let fixed = ["svo", "multi", "nglod"].contains(&r.method.as_str());
        if !fixed && !others.contains(&r.method.as_str()) {
            others.push(&r.method);
        }
    }
    let one_model = models.len() == 1;
    // A line follows a method from shallow to deep, whichever way its x values go (render time
    // need not grow with depth).
    let mut by_depth: Vec<&Row> = rows.iter().collect();
    by_depth.sort_by_key(|r| r.depth);
    let mut files = Vec::new();
    let levels = rows.iter().any(|r| r.bytes_read.is_some());
    for (file, title, x, y, extract) in PLOTS.iter().chain(levels.then_some(&LEVELS_PLOT)) {
        let mut series: Vec<Series> = Vec::new();
        for &r in &by_depth {
            let Some((px, py)) = extract(r) else { continue };
            if !(px.is_finite() && py.is_finite()) || (x.log && px <= 0.0) || (y.log && py <= 0.0) {
                continue;
            }
            let label = if one_model {
                super::report::tables::label(&r.method).to_owned()
            } else {
                format!("{} {}", r.model, super::report::tables::label(&r.method))
            };
            match series.iter_mut().find(|s| s.label == label) {
                Some(s) => {
                    s.points.push((px, py));
                    s.tags.push(point_tag(r));
                }
                None => {
                    let m = models.iter().position(|m| *m == r.model).unwrap_or(0);
                    series.push(Series {
                        label,
                        color: method_color(&r.method, &others),
                        mark: MARKS[m % MARKS.len()],
                        dashed: m % 2 == 1,
                        points: vec![(px, py)],
                        tags: vec![point_tag(r)],
                    });
                }
            }
        }
        let x = &Axis {
            label: if x.label == RENDER_TIME {
                &time_label
            } else {
                x.label
            },
            ..*x
        };
        let img = plot(title, x, y, &series).map_err(|reason| HarnessError::Plot {
            plot: (*file).to_owned(),
            reason,
        })?;
        write_derived_png(&dir.join(file), &img)?;
        files.push((*file).to_owned());
    }
    Ok(files)
}

/// The tag written beside a row's point: its depth, or a peer's own level of detail.
fn point_tag(r: &Row) -> String {
    match r.lod {
        Some(lod) => format!("L{lod}"),
        None => format!("d{}", r.depth),
    }
}

/// The data range of one axis, padded (multiplicatively on a log axis).
fn range(values: impl Iterator<Item = f64>, log: bool, integer: bool) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !lo.is_finite() || !hi.is_finite() {
        return if log { 1.0..10.0 } else { 0.0..1.0 };
    }
    if integer {
        lo -= 0.5;
        hi += 0.5;
    } else if log {
        lo /= 1.25;
        hi *= 1.25;
    } else {
        let pad = ((hi - lo) * 0.08).max(hi.abs() * 0.02).max(1e-3);
        lo -= pad;
        hi += pad;
    }
    lo..hi
}

/// Whether positive values span enough (a factor of 8 or more) for a logarithmic axis to have
/// labelled ticks; narrower data is drawn on a linear axis.
fn spans_a_decade(values: impl Iterator<Item = f64>) -> bool {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    lo > 0.0 && hi / lo >= 8.0
}

/// Ticks of a logarithmic axis over `r`: 1, 2 and 5 times each power of ten inside it (every
/// integer multiple when that gives fewer than four), so that a range below 100 ms is labelled
/// too, not only at the powers of ten; the powers of ten alone when that gives more than
/// [`MAX_LOG_TICKS`] (over more than about three decades the labels at 1 and 2 collide).
pub(super) fn log_ticks(r: &std::ops::Range<f64>) -> Vec<f64> {
    let (lo, hi) = (r.start, r.end);
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let ticks = |multiples: &[f64]| -> Vec<f64> {
        let mut out = Vec::new();
        for e in lo.log10().floor() as i32..=hi.log10().ceil() as i32 {
            for &m in multiples {
                let v = m * 10f64.powi(e);
                if v >= lo && v <= hi {
                    out.push(v);
                }
            }
        }
        out
    };
    let coarse = ticks(&[1.0, 2.0, 5.0]);
    if coarse.len() > MAX_LOG_TICKS {
        ticks(&[1.0])
    } else if coarse.len() >= 4 {
        coarse
    } else {
        ticks(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    }
}

/// Most labels on a logarithmic axis: the plots' charts are 700-800 pixels wide, and the
/// labels at 1 and 2 times a power of ten lie 0.3 decade apart, too close for a 6-character
/// label once the axis spans more than about three decades (ten ticks at 1, 2, 5).
const MAX_LOG_TICKS: usize = 10;

/// A tick label: integers only on an integer axis, else about three significant digits without
/// trailing zeros (0.3, 25, 1200, 0.045).
pub(super) fn axis_label(v: f64, integer: bool) -> String {
    if integer {
        return if (v - v.round()).abs() < 1e-6 {
            format!("{}", v.round())
        } else {
            String::new()
        };
    }
    let a = v.abs();
    let decimals = if a == 0.0 || a >= 100.0 {
        0
    } else {
        (2 - a.log10().floor() as i32).clamp(0, 8) as usize
    };
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

/// Draws one plot into an RGB image.
fn plot(title: &str, x: &Axis, y: &Axis, series: &[Series]) -> Drawn<image::RgbImage> {
    let xs = || series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = || series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let x = &Axis {
        log: x.log && spans_a_decade(xs()),
        ..*x
    };
    let y = &Axis {
        log: y.log && spans_a_decade(ys()),
        ..*y
    };
    let xr = range(xs(), x.log, x.integer);
    let yr = range(ys(), y.log, y.integer);
    let integer_labels = |a: &Axis, r: &std::ops::Range<f64>| {
        if a.integer {
            (r.end - r.start).round().max(1.0) as usize
        } else {
            a.labels
        }
    };
    let x = &Axis {
        labels: integer_labels(x, &xr),
        ..*x
    };
    let y = &Axis {
        labels: integer_labels(y, &yr),
        ..*y
    };
    let mut buf = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
    let (kx, ky) = (log_ticks(&xr), log_ticks(&yr));
    match (x.log, y.log) {
        (false, false) => draw(&mut buf, title, x, y, xr, yr, series),
        (true, false) => draw(
            &mut buf,
            title,
            x,
            y,
            xr.log_scale().with_key_points(kx),
            yr,
            series,
        ),
        (false, true) => draw(
            &mut buf,
            title,
            x,
            y,
            xr,
            yr.log_scale().with_key_points(ky),
            series,
        ),
        (true, true) => draw(
            &mut buf,
            title,
            x,
            y,
            xr.log_scale().with_key_points(kx),
            yr.log_scale().with_key_points(ky),
            series,
        ),
    }?;
    image::RgbImage::from_raw(WIDTH, HEIGHT, buf).ok_or_else(|| "plot buffer size".to_owned())
}

fn draw<X, Y>(
    buf: &mut [u8],
    title: &str,
    x: &Axis,
    y: &Axis,
    xr: X,
    yr: Y,
    series: &[Series],
) -> Drawn<()>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let x_fmt = |v: &f64| axis_label(*v, x.integer);
    let y_fmt = |v: &f64| axis_label(*v, y.integer);
    let root = BitMapBackend::with_buffer(buf, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (area, legend) = root.split_horizontally(WIDTH - LEGEND_WIDTH);
    let mut chart = ChartBuilder::on(&area)
        .caption(title, ("sans-serif", TITLE_PX))
        .margin(16)
        .x_label_area_size(62)
        .y_label_area_size(90)
        .build_cartesian_2d(xr, yr)
        .map_err(|e| err(&e))?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x.label)
        .y_desc(y.label)
        .x_labels(x.labels)
        .y_labels(y.labels)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .light_line_style(RGBColor(235, 235, 235))
        .label_style(("sans-serif", TICK_PX))
        .axis_desc_style(("sans-serif", AXIS_PX));
    // An axis of integers (depths) has a grid line at each integer and none between: the
    // light lines plotters adds between labels would be unlabelled fractions of a depth.
    if x.integer {
        mesh.x_max_light_lines(0);
    }
    if y.integer {
        mesh.y_max_light_lines(0);
    }
    mesh.draw().map_err(|e| err(&e))?;
    for s in series {
        let style = s.color.stroke_width(3);
        let points = s.points.iter().copied();
        if s.dashed {
            chart.draw_series(DashedLineSeries::new(points, 10, 6, style))
        } else {
            chart.draw_series(LineSeries::new(points, style))
        }
        .map_err(|e| err(&e))?;
        let area = chart.plotting_area();
        for &p in &s.points {
            draw_mark!(area, s.mark, p, s.color).map_err(|e| err(&e))?;
        }
    }
    // Each point's depth beside it (not on the depth plot, where x is the depth): the SVO's
    // labels below right, the others' above right, so the methods' labels do not collide.
    if !x.integer {
        for s in series {
            let offset = if s.color == SVO { (7, 5) } else { (7, -22) };
            let font = ("sans-serif", POINT_LABEL_PX).into_font().color(&s.color);
            chart
                .draw_series(s.points.iter().zip(&s.tags).map(|(&p, tag)| {
                    EmptyElement::at(p) + Text::new(tag.clone(), offset, font.clone())
                }))
                .map_err(|e| err(&e))?;
        }
    }
    // The legend in its own column, outside the data.
    let text = ("sans-serif", LEGEND_PX).into_font();
    let mut ly = 60;
    for s in series {
        let line = vec![(8, ly), (44, ly)];
        let style = s.color.stroke_width(3);
        if s.dashed {
            legend.draw(&DashedPathElement::new(line, 7, 4, style))
        } else {
            legend.draw(&PathElement::new(line, style))
        }
        .map_err(|e| err(&e))?;
        draw_mark!(legend, s.mark, (26, ly), s.color).map_err(|e| err(&e))?;
        legend
            .draw(&Text::new(s.label.clone(), (54, ly - 10), text.clone()))
            .map_err(|e| err(&e))?;
        ly += 30;
    }
    if !series.is_empty() && !x.integer {
        let mut notes = vec!["dN = octree depth"];
        if series
            .iter()
            .any(|s| s.tags.iter().any(|t| t.starts_with('L')))
        {
            notes.push("LN = the peer's LOD N");
        }
        for (i, note) in notes.into_iter().enumerate() {
            legend
                .draw(&Text::new(
                    note.to_owned(),
                    (8, ly + 8 + 22 * i as i32),
                    ("sans-serif", POINT_LABEL_PX)
                        .into_font()
                        .color(&RGBColor(90, 90, 90)),
                ))
                .map_err(|e| err(&e))?;
        }
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_label_below_100_ms() {
        assert_eq!(
            log_ticks(&(11.0..2000.0)),
            vec![20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0]
        );
        // Less than a decade: every integer multiple.
        assert_eq!(
            log_ticks(&(6.5..45.0)),
            vec![7.0, 8.0, 9.0, 10.0, 20.0, 30.0, 40.0]
        );
        assert!(log_ticks(&(0.0..10.0)).is_empty());
        // Over more than three decades (the dataset's triangle counts): the powers of ten
        // alone, whose labels do not collide.
        assert_eq!(
            log_ticks(&(30.0..2.0e6)),
            vec![100.0, 1000.0, 10000.0, 100000.0, 1000000.0]
        );
        assert_eq!(log_ticks(&(0.9..900.0)).len(), 9);
    }

    fn row(model: &str, method: &str, depth: u8, psnr: Option<f64>) -> Row {
        Row {
            model: model.into(),
            method: method.into(),
            depth,
            psnr,
            flip: 0.1 / f64::from(depth),
            bytes: 1000 << depth,
            build_ms: Some(3.0 * f64::from(depth)),
            render_ms: 10.0 + f64::from(depth),
            ..Row::default()
        }
    }

    #[test]
    fn plots_have_text_and_lines() {
        let dir = std::env::temp_dir().join(format!("sdfmo-cli-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rows = vec![
            row("a", "svo", 4, Some(20.0)),
            row("a", "svo", 5, Some(24.0)),
            row("a", "multi", 4, Some(22.0)),
            row("a", "multi", 5, None), // identical images: no point, no failure
        ];
        let files = write_plots(&dir, &rows, 5).unwrap();
        assert_eq!(files.len(), 4);
        for f in &files {
            let img = image::open(dir.join(f)).unwrap().to_rgb8();
            assert_eq!(img.dimensions(), (WIDTH, HEIGHT));
            // Text and lines leave dark and coloured pixels on the white background.
            let dark = img.pixels().filter(|p| p.0.iter().all(|&c| c < 80)).count();
            assert!(dark > 500, "{f}: {dark} dark pixels");
            // A colour per method: the SVO blue, the multi-octree red.
            let count = |c: RGBColor| img.pixels().filter(|p| p.0 == [c.0, c.1, c.2]).count();
            assert!(
                count(SVO) > 50,
                "{f}: SVO line missing ({} pixels)",
                count(SVO)
            );
            assert!(
                count(MULTI) > 30,
                "{f}: multi line missing ({} pixels)",
                count(MULTI)
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn log_ranges_are_padded_and_empty_ranges_valid() {
        let r = range([1.0, 100.0].into_iter(), true, false);
        assert!(r.start < 1.0 && r.end > 100.0);
        let r = range(std::iter::empty(), false, false);
        assert!(r.start < r.end);
        let r = range([5.0].into_iter(), false, false);
        assert!(r.start < 5.0 && r.end > 5.0);
        assert_eq!(range([6.0, 9.0].into_iter(), false, true), 5.5..9.5);
        assert!(spans_a_decade([0.5, 4.0].into_iter()));
        assert!(!spans_a_decade([3.3, 3.8].into_iter()));
        assert!(!spans_a_decade(std::iter::empty()));
    }

    #[test]
    fn the_render_time_axis_says_how_the_time_was_taken() {
        assert_eq!(
            render_time_label(5),
            "render time per view (ms), median of 5 frames"
        );
        assert_eq!(render_time_label(1), "render time per view (ms), one frame");
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(axis_label(0.30000000000000004, false), "0.3");
        assert_eq!(axis_label(0.045, false), "0.045");
        assert_eq!(axis_label(25.0, false), "25");
        assert_eq!(axis_label(1234.6, false), "1235");
        assert_eq!(axis_label(7.0, true), "7");
        assert_eq!(axis_label(6.5, true), "");
    }
}
