//! The report's derived figures, from the runs' (seconds, relMSE, FLIP) alone: each method's
//! best trade (its Pareto front), its time at an error by log-log interpolation (the path
//! tracer's also beyond its runs, by its fitted power law), and at each error level which
//! method is fastest. Pure functions of numbers, so the tests check them on synthetic runs with
//! known answers.

use super::metrics::Metrics;

/// What a user would pick: the path tracer or the irradiance cache, raw or denoised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Method {
    /// The path tracer.
    Path,
    /// The path tracer, denoised by OIDN (its time included).
    PathDenoised,
    /// The irradiance cache.
    Cache,
    /// The irradiance cache, denoised by OIDN (its time included).
    CacheDenoised,
}

impl Method {
    /// All four, in the report's order.
    pub const ALL: [Method; 4] = [
        Method::Path,
        Method::PathDenoised,
        Method::Cache,
        Method::CacheDenoised,
    ];

    /// The name in the CSV and the tables.
    pub fn name(self) -> &'static str {
        match self {
            Method::Path => "path",
            Method::PathDenoised => "path+oidn",
            Method::Cache => "ic",
            Method::CacheDenoised => "ic+oidn",
        }
    }

    /// Whether its images go through the denoiser.
    pub fn denoised(self) -> bool {
        matches!(self, Method::PathDenoised | Method::CacheDenoised)
    }

    /// Whether it is the irradiance cache.
    pub fn cache(self) -> bool {
        matches!(self, Method::Cache | Method::CacheDenoised)
    }
}

/// A run's place in the sweep: the primary series of its method (the path tracer's spp, the
/// cache's κ ladder) or an ablation beside it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// The path tracer's spp series (raw or denoised).
    Spp,
    /// The path tracer with adaptive camera sampling (a pixel error target).
    Adaptive,
    /// The cache's consistency ladder: κ with the gathers' M×N growing alongside.
    Ladder,
    /// The default κ with other strata.
    Strata,
    /// The Hessian metric's ladder: its accuracy a with the gathers' M×N growing alongside.
    Hessian,
    /// The κ ladder with radiance records for the glossy lobes.
    Radiance,
    /// One setting changed from the defaults.
    Variant,
    /// A setting asked for with `--extra`.
    Extra,
}

impl Group {
    /// The name in the CSV.
    pub fn name(self) -> &'static str {
        match self {
            Group::Spp => "spp",
            Group::Adaptive => "adaptive",
            Group::Ladder => "kappa",
            Group::Strata => "strata",
            Group::Hessian => "hessian",
            Group::Radiance => "radiance",
            Group::Variant => "variant",
            Group::Extra => "extra",
        }
    }

    /// Whether it is a method's primary series (what its front and the comparisons use).
    pub fn primary(self) -> bool {
        matches!(self, Group::Spp | Group::Ladder)
    }
}

/// One measured setting, over every seed: its figures are the means over the seeds.
#[derive(Clone, Debug)]
pub struct Run {
    /// The method.
    pub method: Method,
    /// The settings, as a label.
    pub label: String,
    /// Primary series or ablation.
    pub group: Group,
    /// The cache's error parameter (NaN for the path tracer).
    pub kappa: f32,
    /// Wall-clock seconds: construction, final pass and, for a denoised run, the denoiser;
    /// the mean over the seeds of each seed's median over its repeats.
    pub seconds: f64,
    /// The standard error of `seconds` across the seeds.
    pub seconds_se: f64,
    /// Of which the denoiser's (the same mean of medians).
    pub denoise_seconds: f64,
    /// Rays traced (mean over the seeds).
    pub rays: u64,
    /// Records (mean over the seeds; 0 for the path tracer).
    pub records: usize,
    /// Errors against the reference, each the mean over the seeds; `rel_mse_se` is relMSE's
    /// standard error across the seeds.
    pub metrics: Metrics,
    /// relMSE of each seed, in the seeds' order (paired seed by seed between settings).
    pub seed_errors: Vec<f64>,
    /// Each seed's timed repeats (seconds), in the seeds' order and the order they ran.
    pub times: Vec<Vec<f64>>,
}

/// The runs no faster run beats in relMSE, in order of time: along it the error falls strictly,
/// so log-log interpolation of time against error is well posed.
pub fn pareto_front<'a>(runs: impl IntoIterator<Item = &'a Run>) -> Vec<&'a Run> {
    let mut by_time: Vec<&Run> = runs.into_iter().collect();
    by_time.sort_by(|a, b| {
        a.seconds
            .total_cmp(&b.seconds)
            .then(a.metrics.rel_mse.total_cmp(&b.metrics.rel_mse))
    });
    let mut front: Vec<&Run> = Vec::new();
    for r in by_time {
        if front
            .last()
            .is_none_or(|f| r.metrics.rel_mse < f.metrics.rel_mse)
        {
            front.push(r);
        }
    }
    front
}

/// Where `y` falls along the points (x, y), in order: x by log-log interpolation, and the
/// segment's parameter (its index plus the fraction along it, in ln y); `None` outside them.
fn interpolate_at(points: &[(f64, f64)], y: f64) -> Option<(f64, f64)> {
    points.windows(2).enumerate().find_map(|(i, w)| {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        let (lo, hi) = (y0.min(y1), y0.max(y1));
        if y < lo || y > hi || y0 == y1 {
            return None;
        }
        let t = (y.ln() - y0.ln()) / (y1.ln() - y0.ln());
        Some(((x0.ln() + t * (x1.ln() - x0.ln())).exp(), i as f64 + t))
    })
}

/// Least-squares slope and intercept of ln y against ln x.
pub fn fit_log(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    if n < 2.0 {
        return None;
    }
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0.ln(), a.1 + p.1.ln()));
    let (mx, my) = (sx / n, sy / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for p in points {
        sxy += (p.0.ln() - mx) * (p.1.ln() - my);
        sxx += (p.0.ln() - mx).powi(2);
    }
    (sxx > 0.0).then(|| {
        let slope = sxy / sxx;
        (slope, my - slope * mx)
    })
}

/// A method's time at an error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeAt {
    /// Seconds.
    pub seconds: f64,
    /// FLIP there (interpolated along the same segment), if known.
    pub flip: Option<f64>,
    /// Whether the time comes from the fitted power law beyond the runs.
    pub extrapolated: bool,
}

/// A method's trade curve: the Pareto front of its primary series.
#[derive(Clone, Debug)]
pub struct Curve {
    /// The method.
    pub method: Method,
    /// (seconds, relMSE, FLIP) along the front, in order of time.
    pub points: Vec<(f64, f64, f64)>,
    /// relMSE ∝ time^slope over all its primary runs (the path tracer's; Monte Carlo's rate is
    /// −1), used beyond its runs. `None` for the other methods: a denoiser's or a cache's error
    /// follows no power law to extrapolate by.
    pub fit: Option<(f64, f64)>,
}

impl Curve {
    /// The curve of `method` from `runs` (its primary runs only).
    pub fn of(method: Method, runs: &[Run]) -> Option<Curve> {
        let primary: Vec<&Run> = runs
            .iter()
            .filter(|r| r.method == method && r.group.primary())
            .collect();
        let points: Vec<(f64, f64, f64)> = pareto_front(primary.iter().copied())
            .iter()
            .map(|r| (r.seconds, r.metrics.rel_mse, r.metrics.flip))
            .collect();
        if points.is_empty() {
            return None;
        }
        let fit = (method == Method::Path)
            .then(|| {
                let all: Vec<(f64, f64)> = primary
                    .iter()
                    .map(|r| (r.seconds, r.metrics.rel_mse))
                    .collect();
                fit_log(&all)
            })
            .flatten();
        Some(Curve {
            method,
            points,
            fit,
        })
    }

    /// The time it needs for relMSE `error`: interpolated along the front (with FLIP), or for
    /// the path tracer extrapolated by its fit; `None` where neither reaches.
    pub fn time_at(&self, error: f64) -> Option<TimeAt> {
        let te: Vec<(f64, f64)> = self.points.iter().map(|p| (p.0, p.1)).collect();
        if self.points.len() == 1 && self.points[0].1 == error {
            let p = self.points[0];
            return Some(TimeAt {
                seconds: p.0,
                flip: Some(p.2),
                extrapolated: false,
            });
        }
        if let Some((seconds, at)) = interpolate_at(&te, error) {
            let i = (at.floor() as usize).min(self.points.len().saturating_sub(2));
            let f = at - i as f64;
            let flip = self.points[i].2 + f * (self.points[i + 1].2 - self.points[i].2);
            return Some(TimeAt {
                seconds,
                flip: Some(flip),
                extrapolated: false,
            });
        }
        self.fit.map(|(k, c)| TimeAt {
            seconds: ((error.ln() - c) / k).exp(),
            flip: None,
            extrapolated: true,
        })
    }

    /// The smallest and largest relMSE along the front.
    pub fn range(&self) -> (f64, f64) {
        let lo = self
            .points
            .iter()
            .map(|p| p.1)
            .fold(f64::INFINITY, f64::min);
        let hi = self.points.iter().map(|p| p.1).fold(0.0, f64::max);
        (lo, hi)
    }
}

/// The error levels worth a row: 1, 2 and 5 × 10^k inside the range the measured runs span
/// (some method interpolates there), largest first.
pub fn error_levels(curves: &[Curve]) -> Vec<f64> {
    let lo = curves
        .iter()
        .map(|c| c.range().0)
        .fold(f64::INFINITY, f64::min);
    let hi = curves.iter().map(|c| c.range().1).fold(0.0, f64::max);
    let mut out = Vec::new();
    if !(lo > 0.0 && hi.is_finite()) {
        return out;
    }
    for k in (-8..=1).rev() {
        for m in [5.0, 2.0, 1.0] {
            let level = m * 10f64.powi(k);
            let interpolated = curves.iter().any(|c| {
                let (a, b) = c.range();
                a <= level && level <= b && c.points.len() > 1
            });
            if interpolated {
                out.push(level);
            }
        }
    }
    out
}

/// At one error level: each method's time (where it reaches it) and the fastest.
#[derive(Clone, Debug)]
pub struct LevelRow {
    /// The relMSE.
    pub error: f64,
    /// Each method's time there, in [`Method::ALL`]'s order.
    pub times: Vec<(Method, Option<TimeAt>)>,
}

impl LevelRow {
    /// The fastest method here, with its time, among those measured (interpolated) or, for the
    /// path tracer, extrapolated.
    pub fn fastest(&self) -> Option<(Method, TimeAt)> {
        self.times
            .iter()
            .filter_map(|(m, t)| t.map(|t| (*m, t)))
            .min_by(|a, b| a.1.seconds.total_cmp(&b.1.seconds))
    }

    /// The time of `method` here.
    pub fn time(&self, method: Method) -> Option<TimeAt> {
        self.times
            .iter()
            .find(|(m, _)| *m == method)
            .and_then(|(_, t)| *t)
    }

    /// The faster of the cache's two methods here.
    pub fn best_cache(&self) -> Option<(Method, TimeAt)> {
        [Method::Cache, Method::CacheDenoised]
            .into_iter()
            .filter_map(|m| self.time(m).map(|t| (m, t)))
            .min_by(|a, b| a.1.seconds.total_cmp(&b.1.seconds))
    }
}

/// One row per error level of [`error_levels`].
pub fn level_rows(curves: &[Curve]) -> Vec<LevelRow> {
    error_levels(curves)
        .into_iter()
        .map(|error| LevelRow {
            error,
            times: Method::ALL
                .into_iter()
                .map(|m| {
                    (
                        m,
                        curves
                            .iter()
                            .find(|c| c.method == m)
                            .and_then(|c| c.time_at(error)),
                    )
                })
                .collect(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(method: Method, group: Group, seconds: f64, rel_mse: f64, flip: f64) -> Run {
        Run {
            method,
            label: format!("{seconds}"),
            group,
            kappa: f32::NAN,
            seconds,
            seconds_se: 0.0,
            denoise_seconds: 0.0,
            rays: 0,
            records: 0,
            metrics: Metrics {
                rel_mse,
                flip,
                ..Metrics::default()
            },
            seed_errors: Vec::new(),
            times: Vec::new(),
        }
    }

    /// The front keeps, in order of time, the runs whose error is below every faster run's;
    /// ties in time keep the lower error.
    #[test]
    fn the_front_drops_dominated_runs() {
        let runs = [
            run(Method::Cache, Group::Ladder, 2.0, 1e-3, 0.0),
            run(Method::Cache, Group::Ladder, 1.0, 2e-3, 0.0),
            run(Method::Cache, Group::Variant, 3.0, 1.5e-3, 0.0), // slower and worse than 2 s
            run(Method::Cache, Group::Variant, 4.0, 5e-4, 0.0),
            run(Method::Cache, Group::Variant, 1.0, 3e-3, 0.0), // same time as 1 s, worse
        ];
        let front: Vec<f64> = pareto_front(&runs).iter().map(|r| r.seconds).collect();
        assert_eq!(front, [1.0, 2.0, 4.0]);
        let errors: Vec<f64> = pareto_front(&runs)
            .iter()
            .map(|r| r.metrics.rel_mse)
            .collect();
        assert_eq!(errors, [2e-3, 1e-3, 5e-4]);
    }

    /// A Monte Carlo method's runs lie on relMSE = c/t: log-log interpolation between two of
    /// them is exact, the fit recovers slope −1 and c, and extrapolation along it is exact.
    /// Equality to 1e-12 relative: a handful of ln/exp of values near 1, each within a few ulps.
    #[test]
    fn a_power_law_is_interpolated_fitted_and_extrapolated_exactly() {
        let c = 3e-3;
        let runs: Vec<Run> = [0.5, 2.0, 8.0, 32.0]
            .into_iter()
            .map(|t| run(Method::Path, Group::Spp, t, c / t, 0.1))
            .collect();
        let curve = Curve::of(Method::Path, &runs).unwrap_or_else(|| panic!("no curve"));
        let (k, b) = curve.fit.unwrap_or_default();
        assert!(
            (k + 1.0).abs() < 1e-12 && (b - c.ln()).abs() < 1e-12,
            "{k} {b}"
        );
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b;
        for (t, extrapolated) in [(1.0, false), (4.0, false), (100.0, true), (0.1, true)] {
            let at = curve.time_at(c / t).unwrap_or_else(|| panic!("{t}"));
            assert!(close(at.seconds, t), "{t}: {at:?}");
            assert_eq!(at.extrapolated, extrapolated);
            assert_eq!(at.flip.is_none(), extrapolated);
        }
    }

    /// Within a segment FLIP is interpolated with the same parameter as the time: halfway in
    /// ln relMSE between (1 s, 1e-2, FLIP 0.2) and (4 s, 1e-4, FLIP 0.1) lies (2 s, 1e-3, 0.15).
    /// Methods other than the path tracer are never extrapolated.
    #[test]
    fn flip_follows_the_segment_and_denoised_curves_are_not_extrapolated() {
        let runs = [
            run(Method::PathDenoised, Group::Spp, 1.0, 1e-2, 0.2),
            run(Method::PathDenoised, Group::Spp, 4.0, 1e-4, 0.1),
        ];
        let curve = Curve::of(Method::PathDenoised, &runs).unwrap_or_else(|| panic!());
        let at = curve.time_at(1e-3).unwrap_or_else(|| panic!());
        assert!((at.seconds - 2.0).abs() < 1e-12, "{at:?}");
        assert!((at.flip.unwrap_or_default() - 0.15).abs() < 1e-12, "{at:?}");
        assert!(curve.fit.is_none());
        assert_eq!(curve.time_at(1e-5), None);
        assert_eq!(curve.time_at(1e-1), None);
    }

    /// Only a method's primary series makes its curve: an ablation faster and better than the
    /// ladder is reported, but not used for the method's time at an error.
    #[test]
    fn ablations_stay_out_of_the_curves() {
        let runs = [
            run(Method::Cache, Group::Ladder, 1.0, 1e-2, 0.0),
            run(Method::Cache, Group::Ladder, 10.0, 1e-3, 0.0),
            run(Method::Cache, Group::Variant, 1.0, 1e-3, 0.0),
        ];
        let curve = Curve::of(Method::Cache, &runs).unwrap_or_else(|| panic!());
        assert_eq!(curve.points.len(), 2);
        let at = curve.time_at(1e-3).unwrap_or_else(|| panic!());
        assert!((at.seconds - 10.0).abs() < 1e-12);
    }

    /// The levels are the 1-2-5 values inside some curve's interpolated range; at each the
    /// fastest method is the one with the least time, and the best cache is the faster of the
    /// two cache methods. Four synthetic methods with known times: path t = 1e-3/e,
    /// path+oidn t = 2e-4/e, cache t = 1e-4/e, cache+oidn t = 1.5e-4/e (all relMSE ∝ 1/t).
    #[test]
    fn at_each_level_the_fastest_method_is_named() {
        let mut runs = Vec::new();
        for (method, c) in [
            (Method::Path, 1e-3),
            (Method::PathDenoised, 2e-4),
            (Method::Cache, 1e-4),
            (Method::CacheDenoised, 1.5e-4),
        ] {
            let group = if method.cache() {
                Group::Ladder
            } else {
                Group::Spp
            };
            for e in [1e-2, 1e-3, 1e-4] {
                runs.push(run(method, group, c / e, e, 0.0));
            }
        }
        let curves: Vec<Curve> = Method::ALL
            .into_iter()
            .filter_map(|m| Curve::of(m, &runs))
            .collect();
        let rows = level_rows(&curves);
        let levels: Vec<f64> = rows.iter().map(|r| r.error).collect();
        assert_eq!(levels.len(), 7, "{levels:?}");
        assert_eq!(levels[0], 1e-2);
        assert_eq!(levels[6], 1e-4);
        for row in &rows {
            let (m, t) = row.fastest().unwrap_or_else(|| panic!());
            assert_eq!(m, Method::Cache);
            assert!((t.seconds - 1e-4 / row.error).abs() <= 1e-9 * t.seconds);
            let (b, _) = row.best_cache().unwrap_or_else(|| panic!());
            assert_eq!(b, Method::Cache);
            let pd = row.time(Method::PathDenoised).unwrap_or_else(|| panic!());
            assert!((pd.seconds / t.seconds - 2.0).abs() < 1e-9);
        }
        // No curve spans anything: no levels.
        assert!(error_levels(&[]).is_empty());
    }
}
