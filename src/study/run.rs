//! Running a convergence study: each configuration renders for a wall-time budget while the
//! film is scored against a reference after every progressive pass.
//!
//! The scene is prepared once ([`RenderScene`]) and shared by every render, so only rendering
//! time is measured. A checkpoint is taken after each completed pass through
//! [`cpu::render_observed`]: the film's means are compared with the reference (a few tens of
//! microseconds at study resolutions, counted in the render's time), so one render yields the
//! whole error-versus-time curve instead of one point per render.
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use serde::Serialize;

use super::compare::mse_relmse;
use crate::backend::cpu;
use crate::film::{totals, AttrValue, Film, Image, Metadata};
use crate::render::{Estimator, MajorantMode, RenderScene, RenderSettings};

/// One estimator setting of the study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StudyConfig {
    /// Name in tables, plots and the CSV (no commas).
    pub label: String,
    #[serde(serialize_with = "ser_name")]
    pub estimator: Estimator,
    /// Majorant scale (weighted estimators only; 1 otherwise).
    pub b: f32,
    /// Control fraction (decomposition with global majorants only).
    pub m: Option<f32>,
    #[serde(serialize_with = "ser_majorant")]
    pub majorant: MajorantMode,
    /// Adaptive sampling (`brume render --noise-threshold`); `None`: every pixel takes every
    /// pass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive_sampling: Option<AdaptiveSampling>,
}

/// Adaptive sampling of a study configuration: pixels stop at pass boundaries once their
/// relative standard error is below `noise_threshold` (`film::adaptive`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AdaptiveSampling {
    pub noise_threshold: f32,
    /// Samples every pixel takes before it may stop (`brume render --min-spp`).
    pub min_spp: u32,
}

impl AdaptiveSampling {
    /// Threshold `noise_threshold` with `brume render`'s default minimum sample count.
    pub fn new(noise_threshold: f32) -> Self {
        Self {
            noise_threshold,
            min_spp: RenderSettings::default().min_spp,
        }
    }

    /// The label's suffix: ` noise=E`, and ` min-spp=N` when N is not the default.
    fn label(&self) -> String {
        let mut s = format!(" noise={}", self.noise_threshold);
        if self.min_spp != Self::new(self.noise_threshold).min_spp {
            s += &format!(" min-spp={}", self.min_spp);
        }
        s
    }
}

fn ser_name<S: serde::Serializer>(e: &Estimator, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(e.name())
}
fn ser_majorant<S: serde::Serializer>(m: &MajorantMode, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(m.name())
}

impl StudyConfig {
    /// A configuration with a label made from its parameters. Parameters an estimator ignores
    /// are dropped (b of the analog estimators, m with local majorants, where the control is
    /// the per-leaf minorant), so equal renders get equal labels.
    pub fn new(estimator: Estimator, b: f32, m: Option<f32>, majorant: MajorantMode) -> Self {
        let weighted = matches!(
            estimator,
            Estimator::WeightedDelta | Estimator::WeightedDecomposition
        );
        let decomposition = matches!(
            estimator,
            Estimator::Decomposition | Estimator::WeightedDecomposition
        );
        let b = if weighted { b } else { 1.0 };
        let m = if decomposition && majorant == MajorantMode::Global {
            m.or(if estimator == Estimator::WeightedDecomposition {
                Some(crate::render::settings::DEFAULT_WEIGHTED_M)
            } else {
                None
            })
        } else {
            None
        };
        let mut label = estimator.name().to_string();
        if weighted {
            label += &format!(" b={b}");
        }
        if let Some(m) = m {
            label += &format!(" m={m}");
        } else if decomposition {
            label += " leaf-minorant";
        }
        label += &format!(" {}", majorant.name());
        Self {
            label,
            estimator,
            b,
            m,
            majorant,
            adaptive_sampling: None,
        }
    }

    /// This configuration with adaptive sampling `a` (or without, for `None`); the label
    /// says so.
    pub fn with_adaptive_sampling(self, a: Option<AdaptiveSampling>) -> Self {
        let mut c = Self::new(self.estimator, self.b, self.m, self.majorant);
        if let Some(a) = a {
            c.label += &a.label();
        }
        c.adaptive_sampling = a;
        c
    }

    /// Parses `ESTIMATOR[:b=B][:m=M][:global|local][:noise=E[:min-spp=N]]` (majorant default:
    /// global; `noise=E` samples adaptively, with `min-spp` default 16 as in `brume render`),
    /// e.g. `weighted-delta:b=0.75:local`, `weighted-decomposition:m=0.03` or
    /// `delta:leaf:noise=0.01`.
    pub fn parse(s: &str) -> Result<Self, String> {
        let mut parts = s.split(':');
        let estimator: Estimator = parts.next().unwrap_or("").trim().parse()?;
        let (mut b, mut m, mut majorant) = (1.0f32, None, MajorantMode::Global);
        let (mut noise, mut min_spp) = (None, None);
        for p in parts {
            let p = p.trim();
            let num = |v: &str, what: &str| {
                v.parse::<f32>()
                    .ok()
                    .filter(|x| x.is_finite() && *x >= 0.0)
                    .ok_or_else(|| format!("config {s:?}: {what} = {v:?} is not a number >= 0"))
            };
            if let Some(v) = p.strip_prefix("b=") {
                b = num(v, "b")?;
                if b == 0.0 {
                    return Err(format!("config {s:?}: b must be > 0"));
                }
            } else if let Some(v) = p.strip_prefix("m=") {
                m = Some(num(v, "m")?);
            } else if let Some(v) = p.strip_prefix("noise=") {
                noise = Some(num(v, "noise")?).filter(|&e| e > 0.0);
                if noise.is_none() {
                    return Err(format!("config {s:?}: noise must be > 0"));
                }
            } else if let Some(v) = p.strip_prefix("min-spp=") {
                min_spp = Some(v.parse::<u32>().ok().filter(|&n| n > 0).ok_or_else(|| {
                    format!("config {s:?}: min-spp = {v:?} is not a whole number >= 1")
                })?);
            } else {
                majorant = p.parse().map_err(|e| {
                    format!(
                        "config {s:?}: {e} (parts are b=B, m=M, global, leaf, culled, adaptive, \
                         noise=E and min-spp=N)"
                    )
                })?;
            }
        }
        let sampling = match (noise, min_spp) {
            (Some(e), n) => Some(AdaptiveSampling {
                min_spp: n.unwrap_or(AdaptiveSampling::new(e).min_spp),
                ..AdaptiveSampling::new(e)
            }),
            (None, Some(_)) => return Err(format!("config {s:?}: min-spp needs noise=E")),
            (None, None) => None,
        };
        Ok(Self::new(estimator, b, m, majorant).with_adaptive_sampling(sampling))
    }

    /// Parses a label made by [`StudyConfig::new`] (e.g. `weighted-delta b=0.75 local`), to
    /// re-summarise a `checkpoints.csv`.
    pub fn from_label(label: &str) -> Result<Self, String> {
        let mut spec: Vec<String> = Vec::new();
        for (i, t) in label.split(' ').enumerate() {
            if i == 0
                || t.starts_with("b=")
                || t.starts_with("m=")
                || t.starts_with("noise=")
                || t.starts_with("min-spp=")
                || matches!(t, "global" | "leaf" | "adaptive" | "local")
            {
                spec.push(t.to_string());
            } else if t != "leaf-minorant" {
                return Err(format!("{label:?} is not a study configuration label"));
            }
        }
        let c = Self::parse(&spec.join(":"))?;
        if c.label != label {
            return Err(format!("{label:?} is not a study configuration label"));
        }
        Ok(c)
    }

    /// `base` with this configuration's estimator, parameters and adaptive sampling.
    pub fn settings(&self, base: &RenderSettings) -> RenderSettings {
        RenderSettings {
            estimator: self.estimator,
            b: self.b,
            m: self.m,
            majorant: self.majorant,
            noise_threshold: self.adaptive_sampling.map(|a| a.noise_threshold),
            min_spp: self.adaptive_sampling.map_or(base.min_spp, |a| a.min_spp),
            ..base.clone()
        }
    }

    /// The label without the majorant mode: configurations that differ only in it share a
    /// plot colour.
    pub fn family(&self) -> String {
        let mode = self.majorant.name();
        let words: Vec<&str> = self.label.split(' ').filter(|w| *w != mode).collect();
        words.join(" ")
    }

    /// The same configuration with fixed sampling (itself when it has none).
    pub fn fixed(&self) -> Self {
        self.clone().with_adaptive_sampling(None)
    }
}

/// The seed paper's sweep: weighted delta tracking with b in {0.25, 0.5, 0.75, 1}, weighted
/// decomposition tracking with m in {0.01, ..., 0.05} at b = 1, and analog delta tracking,
/// each with the global bound, per-leaf majorants and the adaptive hierarchy. With local
/// (per-leaf or merged) majorants the decomposition control is the local minorant and m is
/// unused, so the five m values would be five identical renders: that row appears once.
/// 22 configurations.
pub fn default_sweep() -> Vec<StudyConfig> {
    let mut v = Vec::new();
    // The culled global walk is left to the adaptive rows (it is one of the walks adaptive
    // chooses among); forced on its own it would add six renders per scene.
    for majorant in [
        MajorantMode::Global,
        MajorantMode::Leaf,
        MajorantMode::Adaptive,
    ] {
        for b in [0.25, 0.5, 0.75, 1.0] {
            v.push(StudyConfig::new(
                Estimator::WeightedDelta,
                b,
                None,
                majorant,
            ));
        }
        for m in [0.01, 0.02, 0.03, 0.04, 0.05] {
            let c = StudyConfig::new(Estimator::WeightedDecomposition, 1.0, Some(m), majorant);
            if !v.contains(&c) {
                v.push(c);
            }
        }
        v.push(StudyConfig::new(Estimator::Delta, 1.0, None, majorant));
    }
    v
}

/// One point of an error-versus-time curve: the state of the film after a pass.
#[derive(Clone, Debug, Serialize)]
pub struct Checkpoint {
    pub config: String,
    pub repeat: u32,
    pub seed: u32,
    /// Samples per pixel so far of the pixels still sampling (every pixel without adaptive
    /// sampling).
    pub spp: u32,
    /// Wall-clock seconds of rendering so far (scene preparation excluded).
    pub seconds: f64,
    /// RMSE against the reference, pooled over pixels and RGB.
    pub rmse: f64,
    /// `mean((a - ref)^2 / (ref^2 + 1e-2))`.
    pub relmse: f64,
    /// Density lookups so far (all kinds).
    pub lookups: u64,
    /// Camera samples so far.
    pub samples: u64,
    /// Samples the image's pixels hold so far, on average: `spp` without adaptive sampling,
    /// less once pixels stop.
    pub mean_spp: f64,
}

/// Renders `cfg` for `budget` seconds (no new pass starts after it) and scores every pass
/// against `reference`, over the whole image: pixels that adaptive sampling stopped count
/// with the mean they hold. An adaptive render ends early once every pixel has stopped.
pub fn run_config(
    rs: &RenderScene,
    base: &RenderSettings,
    cfg: &StudyConfig,
    budget: f64,
    repeat: u32,
    seed: u32,
    reference: &Image,
) -> Vec<Checkpoint> {
    render_config(rs, base, cfg, budget, repeat, seed, reference).0
}

/// [`run_config`], also returning the film of the last pass (to check the image itself).
pub fn render_config(
    rs: &RenderScene,
    base: &RenderSettings,
    cfg: &StudyConfig,
    budget: f64,
    repeat: u32,
    seed: u32,
    reference: &Image,
) -> (Vec<Checkpoint>, Film) {
    let settings = RenderSettings {
        spp: 0,
        time_limit: Some(budget),
        seed,
        ..cfg.settings(base)
    };
    let mut points = Vec::new();
    let mut means = Vec::with_capacity(reference.rgb.len());
    let stop = AtomicBool::new(false);
    let out = cpu::render_observed(rs, &settings, &stop, &|_, _, _| {}, &mut |view| {
        means.clear();
        means.extend(
            view.film
                .pixels()
                .iter()
                .map(|p| crate::film::accum::rgb(p.mean).map(|m| m as f32)),
        );
        let (mse, relmse) = mse_relmse(&means, &reference.rgb);
        let t = totals(view.records);
        let held: u64 = view.film.pixels().iter().map(|p| p.count as u64).sum();
        points.push(Checkpoint {
            config: cfg.label.clone(),
            repeat,
            seed,
            spp: view.spp,
            seconds: view.seconds,
            rmse: mse.sqrt(),
            relmse,
            lookups: t.counters.density_lookups,
            samples: t.counters.samples,
            mean_spp: held as f64 / means.len().max(1) as f64,
        });
    });
    (points, out.film)
}

/// Seed of configuration `index` in repeat `repeat`: distinct for every render of a study and
/// never equal to [`REFERENCE_SEED`], so no render shares random numbers with the reference.
pub fn seed_for(base_seed: u32, index: usize, repeat: u32) -> u32 {
    base_seed
        .wrapping_add(repeat.wrapping_mul(1000))
        .wrapping_add(index as u32)
}

/// Seed of the reference render.
pub const REFERENCE_SEED: u32 = 0x5EED_0F0F;

/// Where a cached reference lives in `dir`: keyed by the scene file's name and a hash of its
/// bytes (an edited scene gets a new reference), the resolution and the sample count.
pub fn reference_cache_path(
    dir: &Path,
    scene: &Path,
    width: u32,
    height: u32,
    spp: u32,
) -> std::io::Result<PathBuf> {
    let bytes = std::fs::read(scene)?;
    // FNV-1a, 64 bit: stable across Rust versions, unlike `DefaultHasher`.
    let hash = bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    });
    let stem = scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    Ok(dir.join(format!(
        "reference-{stem}-{:08x}-{width}x{height}-{spp}spp.exr",
        hash as u32
    )))
}

/// The reference estimator: analog delta tracking with per-leaf majorants (unbiased, and the
/// cheapest per sample on sparse clouds).
pub fn reference_settings(base: &RenderSettings, spp: u32) -> RenderSettings {
    RenderSettings {
        spp,
        time_limit: None,
        seed: REFERENCE_SEED,
        ..StudyConfig::new(Estimator::Delta, 1.0, None, MajorantMode::Leaf).settings(base)
    }
}

/// Renders the reference image (mean, variance of the mean, sample count) with
/// [`reference_settings`].
pub fn render_reference(rs: &RenderScene, base: &RenderSettings, spp: u32) -> (Image, f64) {
    let settings = reference_settings(base, spp);
    let out = cpu::render(rs, &settings, &AtomicBool::new(false), &|_, _, _| {});
    let meta = Metadata::new()
        .with("brume:content", AttrValue::Text("study reference".into()))
        .with("brume:estimator", AttrValue::Text("delta".into()))
        .with("brume:majorant", AttrValue::Text("local".into()))
        .with("brume:spp", AttrValue::Int(out.spp as i32))
        .with("brume:seconds", AttrValue::Double(out.seconds))
        .with("brume:seed", AttrValue::Int(REFERENCE_SEED as i32));
    (Image::from_film(&out.film, &meta), out.seconds)
}

/// RMSE of the reference's own noise: `sqrt(mean(variance of the pixel mean))`, the floor
/// under which no render can be measured against it (measured MSE = true MSE + this squared).
pub fn reference_noise_rmse(reference: &Image) -> Option<f64> {
    let v = reference.variance.as_ref()?;
    let n = (v.len() * 3).max(1) as f64;
    Some((v.iter().flatten().map(|&x| x as f64).sum::<f64>() / n).sqrt())
}
