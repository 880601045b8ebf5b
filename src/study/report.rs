//! Turning checkpoints into the study's figures: per-configuration summaries, the CSV, and the
//! Markdown and JSON tables.
use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::run::{AdaptiveSampling, Checkpoint, StudyConfig};
use super::stats::{fit_line, mean_std};
use crate::film::{write_atomically, FilmError};

/// Checkpoints before this pass index are left out of slope fits: the first passes have 1-2
/// samples per pixel, where the error is dominated by a few paths and far from its asymptote.
pub const SLOPE_SKIP_PASSES: usize = 3;

/// Figures of one configuration over its repeats. "Time" is the wall-clock rendering time at
/// the last completed pass (scene preparation excluded; the last pass may end a little past
/// the budget because passes are not cut short).
#[derive(Clone, Debug, Serialize)]
pub struct ConfigSummary {
    pub config: StudyConfig,
    pub repeats: usize,
    /// Mean rendering time at the final checkpoint, seconds.
    pub seconds: f64,
    /// Mean samples per pixel reached (over the image's pixels: fewer than the passes'
    /// count where adaptive sampling stopped pixels).
    pub spp: f64,
    /// RMSE at the final checkpoint: mean and sample std over repeats.
    pub rmse_mean: f64,
    pub rmse_std: f64,
    /// relMSE at the final checkpoint, mean over repeats.
    pub relmse_mean: f64,
    /// Camera samples per second of rendering.
    pub samples_per_second: f64,
    /// Density lookups per camera sample.
    pub lookups_per_sample: f64,
    /// Time x RMSE at the final checkpoint (the seed paper's TTUV form), mean and std.
    pub ttuv_mean: f64,
    pub ttuv_std: f64,
    /// Time x MSE: the inverse efficiency; for an unbiased estimator MSE ~ 1/t, so this does
    /// not depend on the budget.
    pub time_mse_mean: f64,
    pub time_mse_std: f64,
    /// 1 / (time x MSE), from the mean of time x MSE.
    pub efficiency: f64,
    /// Mean seconds to first reach the target RMSE (log-log interpolation between
    /// checkpoints) over the repeats that reached it; `None` if none did.
    pub time_to_target: Option<f64>,
    /// Repeats that reached the target within the budget.
    pub reached_target: usize,
    /// Least-squares slope of log RMSE against log time over all repeats' checkpoints from
    /// pass [`SLOPE_SKIP_PASSES`] on (-0.5 for an unbiased estimator at a fixed cost per
    /// sample).
    pub loglog_slope: Option<f64>,
}

/// The whole study.
#[derive(Clone, Debug, Serialize)]
pub struct StudySummary {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub budget_seconds: f64,
    pub repeats: u32,
    /// Target RMSE of the time-to-target column.
    pub target_rmse: f64,
    /// How the target was chosen.
    pub target_rule: String,
    pub reference: String,
    /// Noise RMSE of the reference itself (from its variance layer), if known.
    pub reference_noise_rmse: Option<f64>,
    pub threads: usize,
    pub configs: Vec<ConfigSummary>,
    /// Each adaptive configuration against the same one with fixed sampling, where the study
    /// has both.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub adaptive_gains: Vec<AdaptiveGain>,
}

/// Fixed against adaptive sampling of one configuration at the target RMSE: the time each
/// takes to reach it and their ratio.
#[derive(Clone, Debug, Serialize)]
pub struct AdaptiveGain {
    /// Label of the fixed-sampling row.
    pub fixed: String,
    /// Label of the adaptive row.
    pub adaptive: String,
    /// Mean time to the target RMSE, `None` unless every repeat reached it.
    pub fixed_seconds: Option<f64>,
    pub adaptive_seconds: Option<f64>,
    /// `fixed_seconds / adaptive_seconds`: above 1 where adaptive sampling saves time.
    pub ratio: Option<f64>,
}

/// Pairs every adaptive row of `configs` with the fixed-sampling row of the same
/// configuration, when the study has it.
pub fn adaptive_gains(configs: &[ConfigSummary]) -> Vec<AdaptiveGain> {
    let every = |c: &ConfigSummary| c.time_to_target.filter(|_| c.reached_target == c.repeats);
    configs
        .iter()
        .filter(|a| a.config.adaptive_sampling.is_some())
        .filter_map(|a| {
            let fixed = a.config.fixed();
            let f = configs.iter().find(|c| c.config == fixed)?;
            let (tf, ta) = (every(f), every(a));
            Some(AdaptiveGain {
                fixed: f.config.label.clone(),
                adaptive: a.config.label.clone(),
                fixed_seconds: tf,
                adaptive_seconds: ta,
                ratio: tf.zip(ta).map(|(f, a)| f / a.max(1e-12)),
            })
        })
        .collect()
}

/// Checkpoints of one configuration, grouped by repeat (in checkpoint order).
fn by_repeat<'a>(points: &'a [Checkpoint], label: &str) -> Vec<Vec<&'a Checkpoint>> {
    let mut reps: Vec<(u32, Vec<&Checkpoint>)> = Vec::new();
    for p in points.iter().filter(|p| p.config == label) {
        match reps.iter_mut().find(|(r, _)| *r == p.repeat) {
            Some((_, v)) => v.push(p),
            None => reps.push((p.repeat, vec![p])),
        }
    }
    reps.into_iter().map(|(_, v)| v).collect()
}

/// First time the curve reaches `target`, interpolated linearly in log time and log RMSE
/// between the checkpoints on either side (the first checkpoint itself if it already does).
pub fn time_to_rmse(curve: &[&Checkpoint], target: f64) -> Option<f64> {
    let i = curve.iter().position(|p| p.rmse <= target)?;
    if i == 0 {
        return Some(curve[0].seconds);
    }
    let (p, q) = (curve[i - 1], curve[i]);
    let (lt0, lt1) = (p.seconds.max(1e-9).ln(), q.seconds.max(1e-9).ln());
    let (le0, le1) = (p.rmse.ln(), q.rmse.ln());
    if !(le0 - le1).is_normal() {
        return Some(q.seconds);
    }
    let f = (le0 - target.ln()) / (le0 - le1);
    Some((lt0 + f * (lt1 - lt0)).exp())
}

/// Log-log slope of RMSE against time over the repeats' checkpoints from pass `skip` on.
pub fn loglog_slope(curves: &[Vec<&Checkpoint>], skip: usize) -> Option<f64> {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for c in curves {
        for p in c.iter().skip(skip) {
            if p.seconds > 0.0 && p.rmse > 0.0 && p.rmse.is_finite() {
                x.push(p.seconds.ln());
                y.push(p.rmse.ln());
            }
        }
    }
    fit_line(&x, &y).map(|(s, _)| s)
}

/// The default target RMSE and how it was chosen: twice the lowest mean RMSE at the budget,
/// or the highest RMSE an adaptive render ended at when that is above it (an adaptive render
/// that ended once every pixel stopped reaches no lower RMSE).
fn default_target(finals: &[(StudyConfig, Vec<Vec<&Checkpoint>>)]) -> (f64, String) {
    let best = finals
        .iter()
        .map(|(_, curves)| {
            let v: Vec<f64> = curves
                .iter()
                .filter_map(|c| c.last().map(|p| p.rmse))
                .collect();
            mean_std(&v).0
        })
        .filter(|x| x.is_finite())
        .fold(f64::INFINITY, f64::min);
    let adaptive_end = finals
        .iter()
        .filter(|(c, _)| c.adaptive_sampling.is_some())
        .flat_map(|(_, curves)| curves.iter().filter_map(|c| c.last().map(|p| p.rmse)))
        .filter(|x| x.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    if adaptive_end > 2.0 * best {
        (
            adaptive_end,
            "the highest RMSE an adaptive render ended at (above twice the lowest mean RMSE at \
             the budget): every adaptive render reaches it"
                .to_string(),
        )
    } else {
        (
            2.0 * best,
            "twice the lowest mean RMSE at the budget: an estimator as efficient as the best \
             gets there in about a quarter of the budget"
                .to_string(),
        )
    }
}

/// Summarises `points` per configuration, in `configs` order. `target`: the RMSE for the
/// time-to-target column; by default [`default_target`]'s.
#[allow(clippy::too_many_arguments)]
pub fn summarize(
    points: &[Checkpoint],
    configs: &[StudyConfig],
    target: Option<f64>,
    scene: &str,
    width: u32,
    height: u32,
    budget: f64,
    repeats: u32,
    reference: &str,
    reference_noise_rmse: Option<f64>,
    threads: usize,
) -> StudySummary {
    let finals: Vec<(StudyConfig, Vec<Vec<&Checkpoint>>)> = configs
        .iter()
        .map(|c| (c.clone(), by_repeat(points, &c.label)))
        .collect();
    let (target_rmse, target_rule) = match target {
        Some(t) => (t, "given with --target-rmse".to_string()),
        None => default_target(&finals),
    };
    let summaries: Vec<ConfigSummary> = finals
        .iter()
        .map(|(cfg, curves)| {
            let last: Vec<&Checkpoint> = curves.iter().filter_map(|c| c.last().copied()).collect();
            let get = |f: &dyn Fn(&Checkpoint) -> f64| -> Vec<f64> {
                last.iter().map(|p| f(p)).collect()
            };
            let (rmse_mean, rmse_std) = mean_std(&get(&|p| p.rmse));
            let (ttuv_mean, ttuv_std) = mean_std(&get(&|p| p.seconds * p.rmse));
            let (time_mse_mean, time_mse_std) = mean_std(&get(&|p| p.seconds * p.rmse * p.rmse));
            let secs: f64 = last.iter().map(|p| p.seconds).sum();
            let samples: f64 = last.iter().map(|p| p.samples as f64).sum();
            let lookups: f64 = last.iter().map(|p| p.lookups as f64).sum();
            let times: Vec<f64> = curves
                .iter()
                .filter_map(|c| time_to_rmse(c, target_rmse))
                .collect();
            ConfigSummary {
                config: cfg.clone(),
                repeats: last.len(),
                seconds: mean_std(&get(&|p| p.seconds)).0,
                spp: mean_std(&get(&|p| p.mean_spp)).0,
                rmse_mean,
                rmse_std,
                relmse_mean: mean_std(&get(&|p| p.relmse)).0,
                samples_per_second: samples / secs.max(1e-12),
                lookups_per_sample: lookups / samples.max(1.0),
                ttuv_mean,
                ttuv_std,
                time_mse_mean,
                time_mse_std,
                efficiency: 1.0 / time_mse_mean,
                time_to_target: (!times.is_empty()).then(|| mean_std(&times).0),
                reached_target: times.len(),
                loglog_slope: loglog_slope(curves, SLOPE_SKIP_PASSES),
            }
        })
        .collect();
    StudySummary {
        scene: scene.to_string(),
        width,
        height,
        budget_seconds: budget,
        repeats,
        target_rmse,
        target_rule,
        reference: reference.to_string(),
        reference_noise_rmse,
        threads,
        adaptive_gains: adaptive_gains(&summaries),
        configs: summaries,
    }
}

/// Reads a `checkpoints.csv` written by [`write_csv`]. A file without the `mean_spp` column
/// holds fixed-sampling rows, where it equals `spp`.
pub fn read_csv(path: &Path) -> Result<Vec<Checkpoint>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        let bad = |what: &str| format!("{}:{}: bad {what}: {line:?}", path.display(), i + 1);
        let f: Vec<&str> = line.split(',').collect();
        if !(9..=10).contains(&f.len()) {
            return Err(bad("row (expected 10 fields)"));
        }
        let spp: u32 = f[3].parse().map_err(|_| bad("spp"))?;
        let mean_spp = match f.get(9) {
            Some(v) => v.parse().map_err(|_| bad("mean_spp"))?,
            None => spp as f64,
        };
        out.push(Checkpoint {
            config: f[0].to_string(),
            repeat: f[1].parse().map_err(|_| bad("repeat"))?,
            seed: f[2].parse().map_err(|_| bad("seed"))?,
            spp,
            seconds: f[4].parse().map_err(|_| bad("seconds"))?,
            rmse: f[5].parse().map_err(|_| bad("rmse"))?,
            relmse: f[6].parse().map_err(|_| bad("relmse"))?,
            lookups: f[7].parse().map_err(|_| bad("lookups"))?,
            samples: f[8].parse().map_err(|_| bad("samples"))?,
            mean_spp,
        });
    }
    Ok(out)
}

/// `checkpoints.csv`: one row per pass of every render.
pub fn write_csv(path: &Path, points: &[Checkpoint]) -> Result<(), FilmError> {
    let mut s =
        String::from("config,repeat,seed,spp,seconds,rmse,relmse,lookups,samples,mean_spp\n");
    for p in points {
        let _ = writeln!(
            s,
            "{},{},{},{},{:.6},{:.8e},{:.8e},{},{},{:.6}",
            p.config,
            p.repeat,
            p.seed,
            p.spp,
            p.seconds,
            p.rmse,
            p.relmse,
            p.lookups,
            p.samples,
            p.mean_spp
        );
    }
    write_text(path, &s)
}

/// Writes `text` to `path` atomically.
pub fn write_text(path: &Path, text: &str) -> Result<(), FilmError> {
    write_atomically(path, |f| {
        use std::io::Write;
        f.write_all(text.as_bytes()).map_err(|e| FilmError::Io {
            action: "write",
            path: path.to_path_buf(),
            source: e,
        })
    })
}

/// `summary.json`.
pub fn write_json(path: &Path, summary: &StudySummary) -> Result<(), FilmError> {
    let text = serde_json::to_string_pretty(summary).expect("summary serialises");
    write_text(path, &(text + "\n"))
}

fn pm(mean: f64, std: f64, n: usize) -> String {
    if n > 1 {
        format!("{} ± {}", sig(mean), sig(std))
    } else {
        sig(mean)
    }
}

/// Three significant digits, plain or scientific as fits.
pub fn sig(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{v:.2e}")
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 10.0 {
        format!("{v:.1}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// The Markdown table and its notes (`summary.md`, as in docs/study/summary.md).
pub fn markdown(summary: &StudySummary) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Scene `{}`, {}x{} pixels, budget {} s per render, {} repeat(s), {} thread(s). Reference: {}{}.\n",
        summary.scene,
        summary.width,
        summary.height,
        summary.budget_seconds,
        summary.repeats,
        summary.threads,
        summary.reference,
        summary
            .reference_noise_rmse
            .map_or(String::new(), |r| format!(" (its own noise RMSE {})", sig(r)))
    );
    s += "| configuration | time (s) | spp | RMSE at budget | relMSE | time to RMSE target (s) | samples/s | lookups/sample | TTUV = t x RMSE | t x MSE | efficiency 1/(t x MSE) | log-log slope |\n";
    s += "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for c in &summary.configs {
        let ttt = match c.time_to_target {
            Some(t) if c.reached_target == c.repeats => sig(t),
            Some(t) => format!("{} ({}/{})", sig(t), c.reached_target, c.repeats),
            None => "not reached".into(),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            c.config.label,
            sig(c.seconds),
            c.spp,
            pm(c.rmse_mean, c.rmse_std, c.repeats),
            sig(c.relmse_mean),
            ttt,
            sig(c.samples_per_second),
            sig(c.lookups_per_sample),
            pm(c.ttuv_mean, c.ttuv_std, c.repeats),
            pm(c.time_mse_mean, c.time_mse_std, c.repeats),
            sig(c.efficiency),
            c.loglog_slope.map_or("-".into(), |v| format!("{v:.2}")),
        );
    }
    s += &adaptive_lines(summary);
    let _ = write!(
        s,
        "\nNotes:\n\
- Time is wall-clock rendering time at the last completed progressive pass (scene loading and \
preparation excluded). No pass starts after the budget, so a render may end slightly past it.\n\
- RMSE and relMSE (`mean((a - ref)^2 / (ref^2 + 0.01))`) are pooled over pixels and RGB \
channels of linear radiance, against the reference. Values are mean ± sample std over repeats \
(different seeds).\n\
- Time to target: first time the RMSE reaches {} ({}), interpolated in log-log between \
checkpoints; mean over the repeats that reached it (k/n when not all did).\n\
- TTUV = time x RMSE grows like sqrt(time) for an unbiased estimator, so it compares \
configurations only at equal budgets. Time x MSE (inverse efficiency) is independent of the \
budget for an unbiased estimator (MSE ~ 1/time), so it is the figure to rank by; efficiency is \
its reciprocal.\n\
- Log-log slope: least squares of log RMSE on log time over every repeat's checkpoints from \
pass {} on; -0.5 is the Monte Carlo rate. A flatter slope at the end means the error is \
nearing the reference's own noise (or a bias).\n",
        sig(summary.target_rmse),
        summary.target_rule,
        SLOPE_SKIP_PASSES
    );
    if summary
        .configs
        .iter()
        .any(|c| c.config.adaptive_sampling.is_some())
    {
        let _ = writeln!(
            s,
            "- `noise=E` rows sample adaptively (`brume render --noise-threshold E --min-spp N`, \
N {} unless the label says): a pixel stops at a pass boundary once the standard error of its \
mean is below E times the mean. Their spp is the mean over pixels, their samples/s counts the \
samples taken, and their RMSE is over the whole image, stopped pixels included. Such a render \
ends before the budget once every pixel has stopped.",
            AdaptiveSampling::new(1.0).min_spp
        );
    }
    s
}

/// The lines comparing fixed and adaptive sampling at the target RMSE (empty when the study
/// has no adaptive row with its fixed-sampling twin).
pub fn adaptive_lines(summary: &StudySummary) -> String {
    let mut s = String::new();
    if summary.adaptive_gains.is_empty() {
        return s;
    }
    let _ = writeln!(
        s,
        "\nTime to RMSE {}, fixed against adaptive sampling:\n",
        sig(summary.target_rmse)
    );
    let time = |t: Option<f64>| t.map_or("not reached in every repeat".into(), |t| sig(t) + " s");
    for g in &summary.adaptive_gains {
        let ratio = g.ratio.map_or("no ratio".into(), |r| {
            format!("fixed / adaptive time = {}", sig(r))
        });
        let _ = writeln!(
            s,
            "- `{}` {}, `{}` {}: {ratio}",
            g.fixed,
            time(g.fixed_seconds),
            g.adaptive,
            time(g.adaptive_seconds)
        );
    }
    s
}
