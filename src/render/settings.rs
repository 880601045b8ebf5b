//! What a render is asked to do: the estimator and its parameters, sample counts, limits.
use std::fmt;
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

pub use crate::accel::Accel;
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
    Leaf,
    /// One segment over the grid with the global bound, its tentative collisions culled by
    /// the per-leaf bound at their point (`tracking::sample_free_flight`): the global walk's
    /// steps with per-leaf bounds' lookups.
    Culled,
    /// The adaptive hierarchy (`volume::adaptive`): per-leaf bounds merged into larger blocks
    /// wherever one coarse segment is cheaper than the fine cells it replaces.
    Adaptive,
}

impl MajorantMode {
    pub const ALL: [MajorantMode; 4] = [
        MajorantMode::Global,
        MajorantMode::Leaf,
        MajorantMode::Culled,
        MajorantMode::Adaptive,
    ];

    pub fn name(self) -> &'static str {
        match self {
            MajorantMode::Global => "global",
            MajorantMode::Leaf => "leaf",
            MajorantMode::Culled => "culled",
            MajorantMode::Adaptive => "adaptive",
        }
    }

    /// Whether the bounds come from local (per-leaf or merged) cells, whose minorants are true
    /// minorants (the control of analog decomposition tracking). The culled global walk counts
    /// as local: its control is the global segment's minorant, 0 wherever it culls
    /// (`volume::cull`), so every estimator's majorant is the bound it thins.
    pub fn is_local(self) -> bool {
        self != MajorantMode::Global
    }
}

/// What a real collision in a medium does with absorption.
///
/// `Event` is the analog form of the seed paper's estimators: the collision is an absorption
/// with probability `sigma_a / sigma_t` (the grey view uses the channel-mean albedo and weights
/// the scattered channels by `albedo / mean`), and an absorbed path ends there.
/// `Weight` never samples absorption: every real collision scatters and the throughput is
/// multiplied by the RGB single-scattering albedo `sigma_s / sigma_t`; termination is left to
/// the path's Russian roulette (as Mitsuba 3's `volpath` does). Both estimate the same
/// collision integral `sigma_s L_s` (`E[1{scatter} w] = (sigma_s / sigma_t)` per channel),
/// so both are unbiased; `Weight` keeps the next-event estimate an absorbed path would lose
/// and bounds the per-bounce weight by the albedo (no `albedo / mean` growth in chromatic
/// media), which removes the fireflies of dense chromatic media.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Absorption {
    Event,
    Weight,
}

impl Absorption {
    pub fn name(self) -> &'static str {
        match self {
            Absorption::Event => "event",
            Absorption::Weight => "weight",
        }
    }
}

/// How the blackbody of a temperature grid is taken between its voxels. `Temperature`
/// (default): the blackbody of the trilinearly interpolated temperature, the continuous
/// field's. `Voxels`: the trilinear blend of each voxel's blackbody, what Cycles' stochastic
/// voxel lookups average to; the two differ where the temperature changes from voxel to voxel,
/// since the blackbody grows as `T^4`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlackbodyModel {
    Temperature,
    Voxels,
}

impl BlackbodyModel {
    pub fn name(self) -> &'static str {
        match self {
            BlackbodyModel::Temperature => "temperature",
            BlackbodyModel::Voxels => "voxels",
        }
    }
}

impl std::str::FromStr for BlackbodyModel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "temperature" => Ok(BlackbodyModel::Temperature),
            "voxels" => Ok(BlackbodyModel::Voxels),
            other => Err(format!(
                "'{other}' is not a blackbody model: temperature or voxels"
            )),
        }
    }
}

/// How next-event estimation chooses its light at a medium scattering event.
///
/// `Guided` (default) weighs each light by its unoccluded contribution through the phase
/// function, with a uniform share (`Lights::phase_selection`), samples a constant
/// environment by the phase function and leaves the share `Lights::continuation_albedo` of
/// it to the continuation ray; `GuidedFullSky` is the same selection with the whole sky
/// estimated at the event (the ablation of that last step); `Uniform` picks every light with
/// the same probability (pbrt-v4's `UniformLightSampler`, the ablation). Scenes with area
/// lights or more than `lights::GUIDED_MAX_PUNCTUAL` punctual lights always select uniformly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSelection {
    Guided,
    GuidedFullSky,
    Uniform,
}

impl LightSelection {
    pub fn name(self) -> &'static str {
        match self {
            LightSelection::Guided => "guided",
            LightSelection::GuidedFullSky => "guided-full-sky",
            LightSelection::Uniform => "uniform",
        }
    }

    /// Medium events select lights by contribution.
    pub fn guided(self) -> bool {
        self != LightSelection::Uniform
    }

    /// The share of a constant sky left to the continuation ray at medium events, for a scene
    /// whose [`Lights::continuation_albedo`](super::lights::Lights) is `scene_albedo`.
    pub fn continuation_albedo(self, scene_albedo: f32) -> f32 {
        if self == LightSelection::Guided {
            scene_albedo
        } else {
            0.0
        }
    }
}

/// How the distance of a medium scattering event lit by a point or spot light is chosen.
///
/// `Distance` samples it by free flight alone (pbrt-v4, Mitsuba 3); `Equiangular` samples it
/// along each flight segment equiangularly towards one of the point and spot lights (Kulla and
/// Fajardo 2012) and leaves those lights out of the free-flight events' next-event estimates;
/// `Mis` (default) does both and weighs them by the power heuristic (Cycles' default). Scenes
/// without point or spot lights, or without media, render by free flight whatever the choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeSampling {
    Distance,
    Equiangular,
    Mis,
}

impl VolumeSampling {
    pub fn name(self) -> &'static str {
        match self {
            VolumeSampling::Distance => "distance",
            VolumeSampling::Equiangular => "equiangular",
            VolumeSampling::Mis => "mis",
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
parse_names!(Absorption, "absorption mode", ["event" => Absorption::Event, "weight" => Absorption::Weight]);
parse_names!(VolumeSampling, "volume sampling", ["distance" => VolumeSampling::Distance, "equiangular" => VolumeSampling::Equiangular, "mis" => VolumeSampling::Mis]);
parse_names!(LightSelection, "light selection", ["guided" => LightSelection::Guided, "guided-full-sky" => LightSelection::GuidedFullSky, "uniform" => LightSelection::Uniform]);
// "local" is the default's alias (it named the per-leaf bounds before the adaptive hierarchy).
parse_names!(MajorantMode, "majorant mode", [
    "global" => MajorantMode::Global,
    "leaf" => MajorantMode::Leaf,
    "culled" => MajorantMode::Culled,
    "adaptive" => MajorantMode::Adaptive,
    "local" => MajorantMode::Adaptive,
]);
parse_names!(Accel, "accelerator", [
    "auto" => Accel::Auto,
    "bvh" => Accel::Bvh,
    "embree" => Accel::Embree,
]);
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

/// Default longest path in scattering events (`RenderSettings::max_depth`), also what the
/// reference renderers get when neither the command line nor the scene gives a depth
/// (`tools/cycles/brume_to_cycles.py` keeps the same number, `DEFAULT_MAX_DEPTH`).
pub const DEFAULT_MAX_DEPTH: u32 = 256;

/// Every knob of a render. `Default` is what `brume render` uses without options.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel to reach (a time limit may stop earlier): the render covers sample
    /// indices `[sample_start, spp)` of every pixel.
    pub spp: u32,
    /// First sample index rendered (a farm part renders `[sample_start, spp)`); 0 by default.
    pub sample_start: u32,
    /// Only the pixels in `[x0, x1) x [y0, y1)` (`[x0, y0, x1, y1]`); the whole image if `None`.
    pub region: Option<[u32; 4]>,
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
    /// Absorption at real collisions: sampled as an event, or applied as a weight.
    pub absorption: Absorption,
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
    /// ... or earlier, from the third event on, as soon as the throughput's largest channel
    /// falls below this. With
    /// absorption as a weight, a dark medium (albedo 0.2) does not end paths at absorption
    /// events; without this guard such paths carry tiny weights through `rr_depth` bounces
    /// of full-cost tracking, less efficient than absorption events; the guard at 0.5 makes
    /// the weight form pay there too. 0 disables it.
    pub rr_throughput: f32,
    pub tile_size: u32,
    /// Samples per pixel in the largest pass (passes grow 1, 2, 4, ... up to this).
    pub max_pass_spp: u32,
    /// Guard against runaway paths: at most this many tentative collisions per path before it
    /// is ended and counted (`guard_fired` in the tile log).
    pub max_collisions_per_path: u64,
    /// How next-event estimation draws environment-map directions (the ablation switch).
    pub env_sampling: super::envmap::EnvSampling,
    /// How next-event estimation chooses its light at medium events.
    pub light_selection: LightSelection,
    /// How scattering distances lit by point and spot lights are sampled in media.
    pub volume_sampling: VolumeSampling,
    /// Emitting media are sampled as lights by next-event estimation
    /// (`render::media_lights`), weighed against the flights' own emission by MIS; off, only
    /// the flights find them (the ablation).
    pub media_lights: bool,
    /// A transparent film: the environment the camera sees straight through is left out of
    /// the colour (it still lights the scene), so the colour and the coverage alpha are a
    /// premultiplied RGBA to lay over a plate.
    pub film_transparent: bool,
    /// Keep the light passes (`film::passes::LIGHT_PASSES`) beside the beauty.
    pub light_passes: bool,
    /// Keep the data passes (`film::passes::DATA_PASSES`) beside the beauty.
    pub data_passes: bool,
    /// How a temperature grid's blackbody is taken between voxels.
    pub blackbody: BlackbodyModel,
    /// Keep these light groups beside the beauty (`render::light_groups`: the scene's
    /// `LightGroups::names`; empty: none).
    pub light_groups: Vec<String>,
    /// Adaptive sampling: a pixel stops once the relative standard error of its mean is below
    /// this (`film::adaptive`), decided at pass boundaries; `None`: every pixel takes `spp`.
    pub noise_threshold: Option<f32>,
    /// Samples every pixel takes before adaptive sampling may stop it.
    pub min_spp: u32,
    /// The CPU backend's closest-hit accelerator for static triangles ([`Scene::use_accel`]
    /// builds it; the GPU always traverses its CWBVH).
    ///
    /// [`Scene::use_accel`]: crate::scene::Scene::use_accel
    pub accel: Accel,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            spp: 16,
            sample_start: 0,
            region: None,
            time_limit: None,
            estimator: Estimator::Delta,
            b: 1.0,
            m: None,
            majorant: MajorantMode::Adaptive,
            shadow: ShadowEstimator::Auto,
            force_spectral: false,
            absorption: Absorption::Weight,
            generic: false,
            seed: 0,
            sampler: SamplerKind::Sobol,
            max_depth: DEFAULT_MAX_DEPTH,
            rr_depth: 8,
            rr_throughput: 0.5,
            tile_size: 16,
            max_pass_spp: 16,
            max_collisions_per_path: 1 << 22,
            env_sampling: super::envmap::EnvSampling::Importance,
            light_selection: LightSelection::Guided,
            volume_sampling: VolumeSampling::Mis,
            media_lights: true,
            film_transparent: false,
            light_passes: false,
            data_passes: false,
            light_groups: Vec::new(),
            blackbody: BlackbodyModel::Temperature,
            noise_threshold: None,
            min_spp: 16,
            accel: Accel::Auto,
        }
    }
}

impl RenderSettings {
    /// The passes kept beside the beauty, in layer order (none by default).
    pub fn pass_names(&self) -> Vec<String> {
        use crate::film::passes::{DATA_PASSES, LIGHT_PASSES};
        let light = LIGHT_PASSES.iter().filter(|_| self.light_passes);
        let data = DATA_PASSES.iter().filter(|_| self.data_passes);
        let names = light.chain(data).map(|s| s.to_string());
        names.chain(self.light_groups.iter().cloned()).collect()
    }

    /// One past the last sample index to render: `spp`, or without end (`u32::MAX`) when
    /// `spp` is 0 and a time limit ends the render; spp 0 without one is the empty range.
    pub fn sample_end(&self) -> u32 {
        if self.spp == 0 && self.time_limit.is_some() {
            u32::MAX
        } else {
            self.spp
        }
    }

    /// Whether no further pass may start: `stop` is set (Ctrl-C, SIGTERM) or the time budget
    /// counted from `start` is spent.
    pub fn must_stop(&self, stop: &AtomicBool, start: Instant) -> bool {
        stop.load(Ordering::Relaxed)
            || self
                .time_limit
                .is_some_and(|t| start.elapsed().as_secs_f64() >= t)
    }

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
        if self.spp != 0 && self.sample_start > self.spp {
            return Err(format!(
                "sample range {}..{} ends before it starts",
                self.sample_start, self.spp
            ));
        }
        if let Some([x0, y0, x1, y1]) = self.region {
            if !(x0 < x1 && y0 < y1 && x1 <= self.width && y1 <= self.height) {
                return Err(format!(
                    "region {x0},{y0},{x1},{y1} is empty or not inside the {}x{} image",
                    self.width, self.height
                ));
            }
        }
        if let Some(e) = self.noise_threshold {
            if !(e > 0.0 && e.is_finite()) {
                return Err(format!("noise threshold {e} must be in (0, inf)"));
            }
            if self.min_spp == 0 {
                // A pixel without samples has no error to judge: it would stop at once.
                return Err(
                    "min spp 0 with a noise threshold: every pixel needs at least one \
                            sample before it may stop"
                        .into(),
                );
            }
            if self.sample_start != 0 {
                return Err(format!(
                    "a noise threshold with samples {}..{}: a part starting after sample 0 \
                     cannot know which pixels the samples before it stopped; split by region \
                     instead",
                    self.sample_start, self.spp
                ));
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
        if !(self.rr_throughput >= 0.0 && self.rr_throughput <= 1.0) {
            return Err(format!(
                "Russian roulette throughput {} must be in [0, 1]",
                self.rr_throughput
            ));
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
