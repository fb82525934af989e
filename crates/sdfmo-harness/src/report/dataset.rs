//! The dataset report: the sweep's [`Report`] of every merged model, extended with what a
//! dataset adds ([`DatasetReport`]): the failures, the shards, and the statistics over the
//! models per depth ([`DatasetStats`]). Serialised (through a `serde_json::Value`, which sorts
//! every object's keys) it is the merge's results.json; `dataset.md` and `index.html` are it
//! rendered through the templates `dataset.md` and `dataset.html` (`super::dataset_page`).
//!
//! Statistics per depth d, over the models with both methods at d: the distribution
//! (quantiles) of ΔPSNR = PSNR(multi) − PSNR(SVO), ΔFLIP = FLIP(multi) − FLIP(SVO) and the
//! size ratio bytes(multi) / bytes(SVO); the share of models where the multi-octree's PSNR is
//! higher; and the share where the multi-octree at d beats the SVO at d + 1.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use super::model::{Model, Report, Row, SweepSettings};
use crate::manifest::Shard;

/// Models listed per depth as the worst (lowest ΔPSNR); their images are copied into the report.
pub const WORST: usize = 6;

/// Quantiles reported: the minimum, the deciles 10 and 90, the quartiles, the median, the
/// maximum.
pub const QUANTILES: [f64; 7] = [0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0];

/// A distribution summarised by [`QUANTILES`] (nearest rank), `null` for an infinite value.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Distribution {
    /// Values counted.
    pub n: usize,
    /// Value at each of [`QUANTILES`].
    pub quantiles: Vec<Option<f64>>,
    /// Mean of the finite values.
    pub mean: Option<f64>,
}

impl Distribution {
    /// Of `values` (infinite ones sort to the ends).
    pub fn of(mut values: Vec<f64>) -> Distribution {
        values.retain(|v| !v.is_nan());
        values.sort_by(f64::total_cmp);
        let n = values.len();
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        Distribution {
            n,
            quantiles: QUANTILES
                .iter()
                .map(|&q| {
                    (n > 0)
                        .then(|| values[nearest_rank(q, n)])
                        .filter(|v| v.is_finite())
                })
                .collect(),
            mean: (!finite.is_empty()).then(|| finite.iter().sum::<f64>() / finite.len() as f64),
        }
    }

    /// The median.
    pub fn median(&self) -> Option<f64> {
        self.quantiles.get(3).copied().flatten()
    }
}

/// Index of quantile `q` of `n` sorted values, nearest rank.
fn nearest_rank(q: f64, n: usize) -> usize {
    ((q * n as f64).ceil() as usize).clamp(1, n) - 1
}

/// One depth's comparison of the two methods over the dataset.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct DepthStats {
    /// The depth.
    pub depth: u8,
    /// Models with both methods at this depth.
    pub models: usize,
    /// ΔPSNR (dB): multi − SVO.
    pub psnr_gain: Distribution,
    /// ΔFLIP: multi − SVO (negative is better).
    pub flip_change: Distribution,
    /// bytes(multi) / bytes(SVO).
    pub size_ratio: Distribution,
    /// Share of the models where the multi-octree's PSNR is higher than the SVO's.
    pub multi_beats_svo: f64,
    /// Share where the multi-octree's FLIP is lower.
    pub multi_beats_svo_flip: f64,
    /// Share where the multi-octree at this depth has a higher PSNR than the SVO one level
    /// deeper (`None` at the deepest depth).
    pub multi_beats_deeper_svo: Option<f64>,
    /// The models with the lowest ΔPSNR, worst first: (model, ΔPSNR).
    pub worst: Vec<(String, Option<f64>)>,
}

/// A least-squares line `ms = intercept + slope · triangles` of time per model.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct TimeFit {
    /// Models fitted.
    pub models: usize,
    /// ms per model at zero triangles.
    pub intercept_ms: f64,
    /// ms per triangle.
    pub slope_ms_per_triangle: f64,
    /// Mean wall time per model (ms).
    pub mean_ms: f64,
    /// Total wall time of the models (ms), summed over the shards.
    pub total_ms: f64,
}

/// What the merge adds to the single run's results.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct DatasetStats {
    /// Models in the manifest.
    pub manifest_models: usize,
    /// Models with rows.
    pub done: usize,
    /// Models that failed.
    pub failed: usize,
    /// Per depth.
    pub depths: Vec<DepthStats>,
    /// Wall time per model (its process, load to last image) against its triangles.
    pub time_per_model: Option<TimeFit>,
}

impl DatasetStats {
    /// Models of the manifest with no current record: neither done nor failed.
    pub fn unfinished(&self) -> usize {
        self.manifest_models
            .saturating_sub(self.done)
            .saturating_sub(self.failed)
    }

    /// The models shown with their images: every depth's worst, each once, in order.
    pub fn shown(&self) -> Vec<&str> {
        let mut shown: Vec<&str> = Vec::new();
        for (m, _) in self.depths.iter().flat_map(|d| &d.worst) {
            if !shown.contains(&m.as_str()) {
                shown.push(m);
            }
        }
        shown
    }
}

/// A model that failed.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Failure {
    /// Position in the manifest.
    pub index: usize,
    /// Manifest id.
    pub id: String,
    /// Model name.
    pub model: String,
    /// Path (empty when the manifest line named none).
    pub source: String,
    /// The error line.
    pub error: String,
}

/// One shard folder merged.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ShardSummary {
    /// The folder, as given.
    pub folder: String,
    /// Which shard it holds.
    pub shard: Shard,
    /// Models of the shard.
    pub models: usize,
    /// Wall time of its last invocation (ms).
    pub wall_ms: f64,
}

/// The merge's report: the single run's [`Report`] of the models that succeeded (its keys at
/// the top level of results.json), and the dataset's additions.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct DatasetReport {
    /// The statistics over the models.
    pub dataset: DatasetStats,
    /// The models that failed, in manifest order.
    pub failures: Vec<Failure>,
    /// The manifest, as the shards were given it.
    pub manifest: String,
    /// The models that succeeded, their rows, settings, provenance and summary.
    #[serde(flatten)]
    pub report: Report,
    /// The hash of the settings every shard ran with.
    pub settings_hash: String,
    /// The shard folders merged.
    pub shards: Vec<ShardSummary>,
}

/// PSNR with `None` (identical images) as +∞.
fn psnr(r: &Row) -> f64 {
    r.psnr.unwrap_or(f64::INFINITY)
}

/// Difference of two PSNRs that may be infinite (∞ − ∞ = 0).
fn gain(multi: f64, svo: f64) -> f64 {
    if multi == svo {
        0.0
    } else {
        multi - svo
    }
}

/// The statistics of `rows` for `settings`' depths.
pub fn depth_stats(settings: &SweepSettings, models: &[Model], rows: &[Row]) -> Vec<DepthStats> {
    let find: HashMap<(&str, &str, u8), &Row> = rows
        .iter()
        .map(|r| ((r.model.as_str(), r.method.as_str(), r.depth), r))
        .collect();
    let deepest = settings.depths.iter().copied().max().unwrap_or(0);
    settings
        .depths
        .iter()
        .map(|&d| {
            let mut gains = Vec::new();
            let mut flips = Vec::new();
            let mut ratios = Vec::new();
            let (mut beats, mut beats_flip, mut deeper, mut deeper_n) = (0, 0, 0, 0);
            let mut worst: Vec<(String, f64)> = Vec::new();
            for m in models {
                let name = m.model.as_str();
                let (Some(s), Some(mu)) =
                    (find.get(&(name, "svo", d)), find.get(&(name, "multi", d)))
                else {
                    continue;
                };
                let g = gain(psnr(mu), psnr(s));
                gains.push(g);
                worst.push((name.to_owned(), g));
                flips.push(mu.flip - s.flip);
                ratios.push(mu.bytes as f64 / s.bytes.max(1) as f64);
                beats += usize::from(g > 0.0);
                beats_flip += usize::from(mu.flip < s.flip);
                if let Some(s1) = find.get(&(name, "svo", d + 1)) {
                    deeper_n += 1;
                    deeper += usize::from(gain(psnr(mu), psnr(s1)) > 0.0);
                }
            }
            worst.sort_by(|a, b| a.1.total_cmp(&b.1).then_with(|| a.0.cmp(&b.0)));
            worst.truncate(WORST);
            let n = gains.len();
            let share = |k: usize, of: usize| if of == 0 { 0.0 } else { k as f64 / of as f64 };
            DepthStats {
                depth: d,
                models: n,
                psnr_gain: Distribution::of(gains),
                flip_change: Distribution::of(flips),
                size_ratio: Distribution::of(ratios),
                multi_beats_svo: share(beats, n),
                multi_beats_svo_flip: share(beats_flip, n),
                multi_beats_deeper_svo: (d < deepest && deeper_n > 0)
                    .then(|| share(deeper, deeper_n)),
                worst: worst
                    .into_iter()
                    .map(|(m, g)| (m, g.is_finite().then_some(g)))
                    .collect(),
            }
        })
        .collect()
}

/// The least-squares line of wall time against triangles over `points` (triangles, ms).
pub fn time_fit(points: &[(usize, f64)]) -> Option<TimeFit> {
    if points.is_empty() {
        return None;
    }
    let pts: Vec<(f64, f64)> = points.iter().map(|&(t, ms)| (t as f64, ms)).collect();
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    Some(TimeFit {
        models: pts.len(),
        intercept_ms: my - slope * mx,
        slope_ms_per_triangle: slope,
        mean_ms: my,
        total_ms: pts.iter().map(|p| p.1).sum(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(model: &str, method: &str, depth: u8, psnr: Option<f64>, bytes: usize) -> Row {
        Row {
            model: model.into(),
            method: method.into(),
            depth,
            psnr,
            flip: if method == "multi" { 0.1 } else { 0.2 },
            bytes,
            ..Row::default()
        }
    }

    fn model(name: &str) -> Model {
        Model {
            model: name.into(),
            source: name.into(),
            triangles: 100,
            reference_render_ms: 1.0,
        }
    }

    #[test]
    fn quantiles_are_nearest_rank_and_infinities_are_null() {
        let d = Distribution::of(vec![3.0, 1.0, 2.0, 4.0, f64::NAN]);
        assert_eq!(d.n, 4);
        assert_eq!(
            d.quantiles,
            [1.0, 1.0, 1.0, 2.0, 3.0, 4.0, 4.0].map(Some).to_vec()
        );
        assert_eq!(d.mean, Some(2.5));
        let d = Distribution::of(vec![f64::INFINITY, 1.0]);
        assert_eq!(d.quantiles[6], None);
        assert_eq!(d.median(), Some(1.0));
        assert_eq!(Distribution::of(Vec::new()).median(), None);
    }

    #[test]
    fn depth_stats_compare_the_methods_per_model() {
        let settings = SweepSettings::for_tests(vec![5, 6], 64);
        let rows = vec![
            row("a", "svo", 5, Some(20.0), 100),
            row("a", "multi", 5, Some(26.0), 120),
            row("a", "svo", 6, Some(25.0), 400),
            row("a", "multi", 6, Some(30.0), 440),
            row("b", "svo", 5, Some(22.0), 100),
            row("b", "multi", 5, Some(21.0), 100),
            row("b", "svo", 6, None, 400),
            row("b", "multi", 6, None, 400),
        ];
        let s = depth_stats(&settings, &[model("a"), model("b")], &rows);
        assert_eq!(s[0].models, 2);
        assert_eq!(s[0].psnr_gain.quantiles[0], Some(-1.0));
        assert_eq!(s[0].psnr_gain.quantiles[6], Some(6.0));
        assert_eq!(s[0].multi_beats_svo, 0.5);
        assert_eq!(s[0].multi_beats_svo_flip, 1.0);
        // a: multi d5 26 > svo d6 25; b: 21 < ∞.
        assert_eq!(s[0].multi_beats_deeper_svo, Some(0.5));
        assert_eq!(s[1].multi_beats_deeper_svo, None);
        assert_eq!(s[0].worst[0], ("b".to_owned(), Some(-1.0)));
        assert_eq!(s[0].size_ratio.quantiles[6], Some(1.2));
        // ∞ − ∞ counts as no gain.
        assert_eq!(s[1].psnr_gain.quantiles[0], Some(0.0));
    }

    #[test]
    fn the_time_fit_is_a_least_squares_line() {
        let f = time_fit(&[(0, 10.0), (100, 30.0), (200, 50.0)]).unwrap();
        assert!((f.slope_ms_per_triangle - 0.2).abs() < 1e-12);
        assert!((f.intercept_ms - 10.0).abs() < 1e-9);
        assert_eq!(f.total_ms, 90.0);
        assert_eq!(time_fit(&[]), None);
    }
}
