//! What a render is asked to do: the estimator and its parameters, sample counts, limits.
use std::fmt;
use std::str::FromStr;

pub use crate::sampling::SamplerKind;

/// Free-flight (distance) sampling in heterogeneous media.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    /// Analog delta tracking (needs a bounding majorant).
    Delta,
    /// Weighted delta tracking with majorant scale `b`.
    WeightedDelta,
    /// Analog decomposition tracking: control `min(m * bound, minorant)`.
    Decomposition,
    /// Weighted decomposition tracking: control `m * bound` (may exceed the minorant).
    WeightedDecomposition,
}

impl Estimator {
    pub const ALL: [Estimator; 4] = [
        Estimator::Delta,
        Estimator::WeightedDelta,
        Estimator::Decomposition,
        Estimator::WeightedDecomposition,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Estimator::Delta => "delta",
            Estimator::WeightedDelta => "weighted-delta",
            Estimator::Decomposition => "decomposition",
            Estimator::WeightedDecomposition => "weighted-decomposition",
        }
    }
}

/// Where the bounds along a ray come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MajorantMode {
    /// One bound for the whole grid.
    Global,
    /// Per-leaf (8^3 voxel) bounds walked with the 3D-DDA.
    Local,
}

impl MajorantMode {
    pub fn name(self) -> &'static str {
        match self {
            MajorantMode::Global => "global",
            MajorantMode::Local => "local",
        }
    }
}

/// Transmittance estimator for shadow rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowEstimator {
    /// Ratio tracking for delta-type estimators, residual ratio tracking (same control) for
    /// decomposition-type ones.
    Auto,
    Ratio,
    ResidualRatio,
}

macro_rules! parse_names {
    ($t:ty, $what:literal, [$($name:literal => $v:expr),+ $(,)?]) => {
        impl FromStr for $t {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                match s {
                    $($name => Ok($v),)+
                    _ => Err(format!(concat!("unknown ", $what, " '{}' (expected one of: {})"), s, [$($name),+].join(", "))),
                }
            }
        }
    };
}
parse_names!(Estimator, "estimator", [
    "delta" => Estimator::Delta,
    "weighted-delta" => Estimator::WeightedDelta,
    "decomposition" => Estimator::Decomposition,
    "weighted-decomposition" => Estimator::WeightedDecomposition,
]);
parse_names!(MajorantMode, "majorant mode", ["global" => MajorantMode::Global, "local" => MajorantMode::Local]);
parse_names!(ShadowEstimator, "shadow estimator", [
    "auto" => ShadowEstimator::Auto,
    "ratio" => ShadowEstimator::Ratio,
    "residual-ratio" => ShadowEstimator::ResidualRatio,
]);

impl fmt::Display for Estimator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Default control fraction of weighted decomposition tracking, in the range the seed paper
/// sweeps (0.01 to 0.05). Where the control exceeds the density the residual is negative and
/// each null collision multiplies the weight by about `1 + 2 m`, so large `m` makes weights
/// grow geometrically across empty space: unbiased, but very noisy.
pub const DEFAULT_WEIGHTED_M: f32 = 0.02;

/// Every knob of a render. `Default` is what `brume render` uses without options.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel to reach (a time limit may stop earlier).
    pub spp: u32,
    /// Wall-clock budget in seconds: no new pass starts after it.
    pub time_limit: Option<f64>,
    pub estimator: Estimator,
    /// Majorant scale of the weighted estimators (`sigma_maj = b * bound`), in (0, inf).
    pub b: f32,
    /// Minorant fraction of the decomposition estimators; `None`: the per-leaf minorant
    /// (analog) or [`DEFAULT_WEIGHTED_M`] (weighted).
    pub m: Option<f32>,
    pub majorant: MajorantMode,
    pub shadow: ShadowEstimator,
    /// Use spectral tracking even for grey media (chromatic media always use it).
    pub force_spectral: bool,
    /// Run the unspecialised path (every effect enabled) to measure what specialisation saves.
    pub generic: bool,
    pub seed: u32,
    /// What drives the fixed-layout decisions of a path (pixel jitter, light and scattering
    /// samples, roulette): Owen-scrambled Sobol (default) or the independent PCG stream.
    pub sampler: SamplerKind,
    /// Longest path, in scattering events (media and surfaces).
    pub max_depth: u32,
    /// Russian roulette starts after this many scattering events.
    pub rr_depth: u32,
    pub tile_size: u32,
    /// Samples per pixel in the largest pass (passes grow 1, 2, 4, ... up to this).
    pub max_pass_spp: u32,
    /// Guard against runaway paths: at most this many tentative collisions per path before it
    /// is ended and counted (`guard_fired` in the tile log).
    pub max_collisions_per_path: u64,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            spp: 16,
            time_limit: None,
            estimator: Estimator::Delta,
            b: 1.0,
            m: None,
            majorant: MajorantMode::Local,
            shadow: ShadowEstimator::Auto,
            force_spectral: false,
            generic: false,
            seed: 0,
            sampler: SamplerKind::Sobol,
            max_depth: 256,
            rr_depth: 8,
            tile_size: 16,
            max_pass_spp: 16,
            max_collisions_per_path: 1 << 22,
        }
    }
}

impl RenderSettings {
    /// Checks the numbers a user can get wrong.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 {
            return Err(format!(
                "image size {}x{} is empty",
                self.width, self.height
            ));
        }
        if self.width > 1 << 15 || self.height > 1 << 15 {
            return Err(format!(
                "image size {}x{} is larger than 32768 on a side",
                self.width, self.height
            ));
        }
        if !(self.b > 0.0 && self.b.is_finite()) {
            return Err(format!("majorant scale b = {} must be in (0, inf)", self.b));
        }
        if let Some(m) = self.m {
            if !(m >= 0.0 && m.is_finite()) {
                return Err(format!("minorant fraction m = {m} must be >= 0 and finite"));
            }
        }
        if self.spp == 0 && self.time_limit.is_none() {
            return Err("spp is 0 and no time limit is set".into());
        }
        if let Some(t) = self.time_limit {
            if !(t >= 0.0 && t.is_finite()) {
                return Err(format!("time limit {t} s must be >= 0 and finite"));
            }
        }
        if self.tile_size == 0 || self.max_pass_spp == 0 {
            return Err("tile size and pass size must be positive".into());
        }
        Ok(())
    }

    /// The minorant fraction in effect for the chosen estimator.
    pub fn m_or_default(&self) -> Option<f32> {
        match (self.estimator, self.m) {
            (_, Some(m)) => Some(m),
            (Estimator::WeightedDecomposition, None) => Some(DEFAULT_WEIGHTED_M),
            _ => None,
        }
    }
}
