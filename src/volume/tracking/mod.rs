//! Null-collision tracking: ONE free-flight loop over majorant segments, and the estimators
//! that plug into it.
//!
//! The model is pbrt-v4's `SampleT_maj` (`src/pbrt/media.h`): [`sample_free_flight`] walks the
//! [`MajorantSegment`]s of a ray, samples tentative collisions with exponential steps on each
//! segment's majorant, and hands each one to a callback that decides (absorb, scatter, null,
//! control, ...) and says whether to continue. `flight.rs` writes once what every estimator
//! does around that decision (the culling stages, the emission hook, the counters, the weight's
//! update, Russian roulette, the closed-form control factor, the event or estimate it ends
//! with) in the two drivers [`sample_distance`] and [`transmittance`], generic over the
//! estimator. An estimator is a type whose value holds its parameters (`WeightedDelta { b }`),
//! and its module writes only its walk ([`Estimator`]) and its collision rules
//! ([`DistanceEstimator`], [`TransmittanceEstimator`]):
//!
//! | estimator                 | distance sampling       | transmittance                            |
//! |---------------------------|-------------------------|------------------------------------------|
//! | [`Delta`]                 | analog                  | Bernoulli (track length)                 |
//! | [`WeightedDelta`]         | weighted, scale b       | weighted Bernoulli                       |
//! | [`Decomposition`]         | analog                  | closed-form control x Bernoulli residual |
//! | [`WeightedDecomposition`] | weighted                | closed-form control x weighted residual  |
//! | [`Ratio`]                 | -                       | ratio tracking                           |
//! | [`ResidualRatio`]         | -                       | residual ratio tracking                  |
//! | [`Spectral`] (RGB)        | weighted, history-aware | weighted, history-aware                  |
//!
//! Random-number order (the WGSL mirror must match): one uniform per tentative collision for
//! its exponential optical depth, drawn by the loop when the previous collision is consumed
//! (not per segment: the depth carries across segments); then whatever the callback draws for
//! that collision (one uniform for the event choice, one more only when Russian roulette
//! fires). A thinned walk decides each collision's culling with one more uniform before the
//! callback; a queued one (a sampler's point) is handed on rescaled as the next uniform drawn
//! ([`thin`]).
//!
//! Units: `t` is the ray parameter and every coefficient is per unit of `t`.
// Comparisons such as `!(x > 0.0)` are written negated on purpose: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::sampling::Rng;
use crate::volume::MajorantSegment;
pub use decomposition::Decomposition;
pub use delta::Delta;
pub use flight::{
    sample_distance, transmittance, DistanceEstimator, Estimator, FlightMedium, Outcome, Real,
    Tracker, TransmittanceEstimator, Weight,
};
use glam::Vec3;
pub use ratio::Ratio;
pub use residual_ratio::ResidualRatio;
pub use spectral::{Spectral, SpectralProbabilities};
pub use thin::{thin, RECYCLE_MIN_P};
pub use weighted_decomposition::WeightedDecomposition;
pub use weighted_delta::WeightedDelta;

pub mod decomposition;
pub mod delta;
mod flight;
pub mod ratio;
pub mod residual_ratio;
pub mod spectral;
mod thin;
pub mod weighted_decomposition;
pub mod weighted_delta;

/// Relative slack before a non-bounding majorant counts as a violation in the analog trackers:
/// f32 density interpolation can exceed a bound computed from the same voxels by a few ulps.
pub const MAJORANT_TOLERANCE: f32 = 1e-4;

/// Russian roulette threshold on `|weight|` for estimators whose weights shrink (ratio
/// tracking, spectral tracking): below it a path survives with probability `|w| / threshold`
/// and then carries `sign(w) * threshold`, which keeps the expectation (no clamping).
pub const ROULETTE_THRESHOLD: f32 = 0.1;

/// Safety net for a ray whose free flight can never end: an infinite segment with a positive
/// majorant in an empty medium has no escape and no real collision. After this many tentative
/// collisions in ONE call the loop gives up, returns `T_maj = 0` (the true majorant
/// transmittance to infinity) and counts [`TrackingStats::collision_cap_hits`].
pub const MAX_TENTATIVE_COLLISIONS: u64 = 1 << 24;

/// Grey absorption and scattering coefficients at one point: the result of ONE density lookup.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Coeffs {
    pub sigma_a: f32,
    pub sigma_s: f32,
}

impl Coeffs {
    pub const ZERO: Coeffs = Coeffs {
        sigma_a: 0.0,
        sigma_s: 0.0,
    };

    pub fn new(sigma_a: f32, sigma_s: f32) -> Self {
        Coeffs { sigma_a, sigma_s }
    }

    /// `sigma_a = (1 - albedo) sigma_t`, `sigma_s = albedo sigma_t`.
    pub fn from_sigma_t(sigma_t: f32, albedo: f32) -> Self {
        Coeffs {
            sigma_a: (1.0 - albedo) * sigma_t,
            sigma_s: albedo * sigma_t,
        }
    }

    #[inline]
    pub fn sigma_t(&self) -> f32 {
        self.sigma_a + self.sigma_s
    }
}

/// RGB coefficients at one point, for spectral tracking.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CoeffsRgb {
    pub sigma_a: Vec3,
    pub sigma_s: Vec3,
}

impl CoeffsRgb {
    pub fn new(sigma_a: Vec3, sigma_s: Vec3) -> Self {
        CoeffsRgb { sigma_a, sigma_s }
    }

    #[inline]
    pub fn sigma_t(&self) -> Vec3 {
        self.sigma_a + self.sigma_s
    }
}

/// Coefficients add where media overlap (`integrator::mixture`): grey and RGB alike.
macro_rules! add_assign_coeffs {
    ($($t:ty),*) => {$(
        impl std::ops::AddAssign for $t {
            #[inline]
            fn add_assign(&mut self, c: $t) {
                self.sigma_a += c.sigma_a;
                self.sigma_s += c.sigma_s;
            }
        }
    )*};
}
add_assign_coeffs!(Coeffs, CoeffsRgb);

/// A grey medium as the trackers see it along one ray.
pub trait Medium {
    /// `sigma_a`, `sigma_s` at ray parameter `t`: one density lookup, the cost the estimators
    /// try to avoid. Trackers count each call in [`TrackingStats::lookups`]. `&self` because a
    /// grid lookup is read-only (and the majorant and collision closures share the medium).
    fn coeffs(&self, t: f32) -> Coeffs;

    /// The lookup-free control component of decomposition tracking (Kutz et al. 2017, sec. 5)
    /// over `seg`: a homogeneous `(sigma_a, sigma_s)` known without touching the density.
    /// Implementations must not look anything up per point here. Default: no control.
    fn control(&self, _seg: &MajorantSegment) -> Coeffs {
        Coeffs::ZERO
    }

    /// Called by every distance sampler at every tentative collision (real, null or control)
    /// with `w`, the estimator's weight BEFORE this collision's own update. Emissive media
    /// collect their emission here: tentative collisions arrive at rate `sigma_maj` while the
    /// walk survives with probability `T(t)` (weighted: expected weight `T(t)`), so
    /// `sum_i w_i * e(t_i) / sigma_maj` estimates `integral T(t) e(t) dt` without bias
    /// (pbrt-v4's VolPathIntegrator collects `sigma_a Le / sigma_maj` the same way).
    /// Default: nothing, which compiles to no code for media without emission.
    #[inline]
    fn on_collision(&self, _t: f32, _sigma_maj: f32, _w: f32) {}

    /// The culling of the walk in progress (see [`sample_free_flight`]): the ratio in `[0, 1]`
    /// of a finer bound at `t` to the bound of the segment the tentative collision was sampled
    /// on. Default: 1, no culling (no uniform is drawn).
    #[inline]
    fn cull_ratio(&self, _t: f32) -> f32 {
        1.0
    }

    /// The second culling stage (see [`sample_free_flight`]): the ratio in `[0, 1]` of the
    /// per-voxel bound at `t` to `bound`, the raw majorant (before the estimator's scale `b`)
    /// the collision was sampled and kept with on `seg`. Sound only where the estimator's
    /// majorant is that bound itself: the estimators call it through [`voxel_stage`].
    /// Default: 1, no culling.
    #[inline]
    fn voxel_ratio(&self, _t: f32, _seg: &MajorantSegment, _bound: f32) -> f32 {
        1.0
    }
}

/// [`Medium::voxel_ratio`] as an estimator calls it, `b` its majorant scale (1 for the
/// estimators without one) and `with_control` whether its majorant is the residual `b max(bound
/// - c, c - min)` (decomposition, weighted decomposition):
/// - ratio and residual ratio tracking do not call it. Their variance grows as their majorant
///   tightens. For a Poisson process of tentative collisions at rate `mu(t)` and
///   `T^ = prod_i (1 - sigma(t_i) / mu(t_i))`, `E[prod f(t_i)] = exp(-int mu (1 - f) dt)`
///   gives
///   ```text
///   E[T^ ^2] = exp(-int (2 sigma - sigma^2 / mu) dt),  Var[T^] = T^2 (exp(int sigma^2 / mu dt) - 1)
///   ```
///   (with `sigma - sigma_c` for residual ratio tracking), so thinning `mu` from the cell
///   bound to the voxel bound raises it (on the sunlit plume by a fifth, in the same time).
///   Delta tracking's and decomposition tracking's estimates (a real collision or none) have
///   a variance that does not depend on the majorant, so they keep the stage;
/// - with a control, the majorant is the bound itself only where the segment's control `c` is
///   0, so those estimators thin only there;
/// - under `b < 1` the weighted estimators' majorant is already below the density in places;
///   thinning it further towards `b sigma_t` only fattens their weights' tails (on the blob,
///   weighted delta at `b = 0.5` reaches twice the largest weight), so only `b >= 1` thins;
/// - spectral tracking does not thin by voxels at all: its null collisions' weights divide by
///   the null probability, which a bound tight on the densest channel shrinks: no bias, but
///   heavier pixel tails, so it keeps the cells' (and the culled walk's) bounds.
#[inline]
pub fn voxel_stage<W, M: FlightMedium<W> + ?Sized>(
    medium: &M,
    b: f32,
    with_control: bool,
    t: f32,
    seg: &MajorantSegment,
    bound: f32,
) -> f32 {
    if !(b >= 1.0) || (with_control && medium.sigma_c(seg) != 0.0) {
        return 1.0;
    }
    medium.voxel_ratio(t, seg, bound)
}

/// An RGB medium along one ray (spectral tracking).
pub trait MediumRgb {
    /// One density lookup, counted like [`Medium::coeffs`].
    fn coeffs(&self, t: f32) -> CoeffsRgb;

    /// As [`Medium::on_collision`], with the RGB weight.
    #[inline]
    fn on_collision(&self, _t: f32, _sigma_maj: f32, _w: Vec3) {}

    /// As [`Medium::cull_ratio`].
    #[inline]
    fn cull_ratio(&self, _t: f32) -> f32 {
        1.0
    }
}

/// Where the control extinction `sigma_c` of (residual) decomposition tracking comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ControlExtinction {
    /// No control component: decomposition degenerates to delta tracking.
    None,
    /// The same `sigma_c` everywhere, e.g. `m * global bound`.
    Constant(f32),
    /// `m * seg.sigma_maj` (the bound before the majorant scale).
    FractionOfBound(f32),
    /// `seg.sigma_min`: the per-leaf minorant, a valid control for analog decomposition.
    SegmentMinorant,
    /// `min(m * seg.sigma_maj, seg.sigma_min)`: a fraction of the bound, capped by the
    /// minorant so that analog decomposition stays unbiased whatever `m` is.
    FractionOfBoundCapped(f32),
}

impl ControlExtinction {
    #[inline]
    pub fn sigma_c(&self, seg: &MajorantSegment) -> f32 {
        match *self {
            ControlExtinction::None => 0.0,
            ControlExtinction::Constant(c) => c,
            ControlExtinction::FractionOfBound(m) => m * seg.sigma_maj,
            ControlExtinction::SegmentMinorant => seg.sigma_min,
            ControlExtinction::FractionOfBoundCapped(m) => (m * seg.sigma_maj).min(seg.sigma_min),
        }
    }
}

/// A [`Medium`] from a closure, with a control policy and the control's single-scattering
/// albedo (media whose albedo is constant make the control's split into `sigma_a`/`sigma_s`
/// lookup-free).
pub struct FnMedium<F> {
    pub lookup: F,
    pub control: ControlExtinction,
    pub control_albedo: f32,
}

impl<F: Fn(f32) -> Coeffs> FnMedium<F> {
    /// A medium without a control component.
    pub fn new(lookup: F) -> Self {
        FnMedium {
            lookup,
            control: ControlExtinction::None,
            control_albedo: 0.0,
        }
    }

    pub fn with_control(lookup: F, control: ControlExtinction, control_albedo: f32) -> Self {
        FnMedium {
            lookup,
            control,
            control_albedo,
        }
    }
}

impl<F: Fn(f32) -> Coeffs> Medium for FnMedium<F> {
    fn coeffs(&self, t: f32) -> Coeffs {
        (self.lookup)(t)
    }

    fn control(&self, seg: &MajorantSegment) -> Coeffs {
        Coeffs::from_sigma_t(self.control.sigma_c(seg), self.control_albedo)
    }
}

/// An RGB medium from a closure.
pub struct FnMediumRgb<F>(pub F);

impl<F: Fn(f32) -> CoeffsRgb> MediumRgb for FnMediumRgb<F> {
    fn coeffs(&self, t: f32) -> CoeffsRgb {
        (self.0)(t)
    }
}

/// Counters the trackers update so that logs can report cost and correctness problems.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackingStats {
    /// Density lookups ([`Medium::coeffs`] calls).
    pub lookups: u64,
    /// Tentative collisions that were null (fictitious).
    pub null_collisions: u64,
    /// Real collisions (absorb, scatter, or a real event ending a transmittance walk) decided
    /// from a density lookup.
    pub real_collisions: u64,
    /// Collisions with the lookup-free control component of decomposition tracking.
    pub control_collisions: u64,
    /// Lookups where an analog tracker found `sigma_t > sigma_maj (1 + MAJORANT_TOLERANCE)`
    /// (or a negative residual): that estimate is biased and this says so.
    pub majorant_violations: u64,
    /// Segments skipped because their majorant was negative, NaN or infinite.
    pub invalid_majorants: u64,
    /// Free flights stopped by [`MAX_TENTATIVE_COLLISIONS`].
    pub collision_cap_hits: u64,
    /// Paths ended by Russian roulette.
    pub roulette_kills: u64,
    /// Majorant segments the free-flight loop walked (DDA or hierarchy steps, empty ones
    /// included): the walk's share of the cost, next to `lookups`.
    pub segments: u64,
    /// Largest `|weight|` seen by a weighted tracker: weights grow geometrically when the
    /// majorant does not bound (`b < 1`); a large value explains a noisy image.
    pub max_abs_weight: f32,
}

impl TrackingStats {
    /// Adds another set of counters (e.g. from another thread).
    pub fn merge(&mut self, o: &TrackingStats) {
        self.lookups += o.lookups;
        self.null_collisions += o.null_collisions;
        self.real_collisions += o.real_collisions;
        self.control_collisions += o.control_collisions;
        self.majorant_violations += o.majorant_violations;
        self.invalid_majorants += o.invalid_majorants;
        self.collision_cap_hits += o.collision_cap_hits;
        self.roulette_kills += o.roulette_kills;
        self.segments += o.segments;
        self.max_abs_weight = self.max_abs_weight.max(o.max_abs_weight);
    }

    /// True when something was counted that makes the estimates biased.
    pub fn is_biased(&self) -> bool {
        self.majorant_violations > 0 || self.invalid_majorants > 0 || self.collision_cap_hits > 0
    }

    #[inline]
    pub(crate) fn note_weight(&mut self, w: f32) {
        self.max_abs_weight = self.max_abs_weight.max(w.abs());
    }
}

/// One tentative collision handed to an estimator's callback.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collision {
    /// Ray parameter of the collision.
    pub t: f32,
    /// The majorant the step was sampled with (after scaling / control subtraction).
    pub sigma_maj: f32,
    /// The segment it lies in (its `sigma_maj`/`sigma_min` are the unscaled bounds).
    pub seg: MajorantSegment,
}

/// What a distance sampler decided. `W` is `f32` (grey) or `Vec3` (RGB); `weight` multiplies
/// the path throughput `beta` (1 for the analog trackers).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event<W> {
    /// Real absorption at `t`: the path ends (`weight` would multiply emission there).
    Absorb { t: f32, weight: W },
    /// Real scattering at `t`: sample the phase function and continue with `beta *= weight`.
    Scatter { t: f32, weight: W },
    /// No real collision before `t_max`: continue to the surface/background, `beta *= weight`.
    Escape { weight: W },
}

impl<W: Copy> Event<W> {
    pub fn t(&self) -> Option<f32> {
        match *self {
            Event::Absorb { t, .. } | Event::Scatter { t, .. } => Some(t),
            Event::Escape { .. } => None,
        }
    }

    pub fn weight(&self) -> W {
        match *self {
            Event::Absorb { weight, .. }
            | Event::Scatter { weight, .. }
            | Event::Escape { weight } => weight,
        }
    }
}

/// The majorant `b * seg.sigma_maj` of weighted tracking with majorant scale `b` (b = 1: the
/// bound itself).
#[inline]
pub fn scaled_majorant(b: f32) -> impl Fn(&MajorantSegment) -> f32 {
    move |seg| b * seg.sigma_maj
}

/// Residual majorant of weighted decomposition / residual ratio tracking over `seg` with
/// control `sigma_c`: `b * max(bound - sigma_c, sigma_c - seg.sigma_min)`.
///
/// The max is the tightest bound on `|sigma_r| = |sigma_t - sigma_c|` that the segment's
/// bounds give; the second term matters when the control exceeds the minorant (`m` above the
/// true minimum), where the residual is negative somewhere and must still be sampled. With
/// `b = 1` and `sigma_c <= sigma_min` it is the paper's `sigma_maj - sigma_c`. `b` scales the
/// residual's own bound (scaling the total instead, `b * bound - sigma_c`, could turn negative).
/// It is 0 only when `bound = sigma_c = sigma_min`, where the residual vanishes identically.
#[inline]
pub fn residual_majorant(b: f32, seg: &MajorantSegment, sigma_c: f32) -> f32 {
    b * (seg.sigma_maj - sigma_c)
        .max(sigma_c - seg.sigma_min)
        .max(0.0)
}

/// Whether `x` is positive (not 0) and finite, by one integer compare: the bit patterns of
/// those floats are exactly `1..=0x7f7f_ffff`. The same test written with float compares
/// (`x > 0.0 && x < f32::INFINITY`, or with `is_finite`) compiles to a float classification
/// of a dozen integer instructions, which the free-flight loop paid on every segment (callgrind,
/// the fire's per-leaf walk).
#[inline(always)]
pub fn positive_finite(x: f32) -> bool {
    x.to_bits().wrapping_sub(1) < 0x7f7f_ffff
}

/// Exponential step with rate `sigma` from uniform `u` in `[0, 1)`: `-ln(1 - u) / sigma`,
/// finite because `1 - u > 0`.
#[inline]
pub fn sample_exponential(u: f32, sigma: f32) -> f32 {
    -(1.0 - u).ln() / sigma
}

/// The shared free-flight loop (pbrt-v4 `SampleT_maj`).
///
/// Walks `segments` (sorted by `t_min`, non-overlapping; gaps are empty space) clipped to
/// `t <= t_max`. Tentative collisions form a Poisson process of rate `sigma_maj(t)`, piecewise
/// constant over the segments (`sigma_maj = majorant(seg)`): the loop draws an exponential
/// optical depth `tau = -ln(1 - u)` and places the next collision where the majorant optical
/// depth walked since the last one reaches `tau`, carrying what is left of `tau` from segment
/// to segment. That is the exact inverse CDF of the process, so it samples the same
/// collisions as one exponential step per segment (pbrt's way, and Brume's before) while
/// drawing a uniform and a logarithm per COLLISION instead of per segment and collision: a
/// walk through many small segments (per-leaf bounds) costs a multiply and a compare per
/// segment. At each collision it calls `callback(rng, stats, &collision)`; a `false` return
/// stops the walk. Segments with a zero majorant are crossed without drawing anything;
/// invalid majorants (negative, NaN, infinite) are skipped and counted. `t_max` and segment
/// ends may be `f32::INFINITY`.
///
/// Culling (thinning, Lewis & Shedler 1979, "Simulation of nonhomogeneous Poisson processes
/// by thinning"): `cull(t)` gives `r = sigma_fine(t) / sigma_maj` in `[0, 1]`, where
/// `sigma_fine` is a finer bound at the collision's point (the per-leaf cell's, under a
/// segment over the whole grid). With `r < 1` one more uniform `u` decides ([`thin`], which
/// hands a queued `u` on rescaled):
///
/// ```text
/// u >= r  -> culled: a null collision, no lookup, no callback
/// u <  r  -> callback with sigma_maj' = r * sigma_maj
/// ```
///
/// The kept collisions are a Poisson process of rate `sigma_fine(t)`, the one per-leaf
/// bounds would sample, so every estimator sees exactly the collisions and probabilities of a
/// walk over the finer bounds: the coarse walk's few segments, the fine bounds' few lookups.
/// A second stage thins the survivors the same way by the per-voxel bound:
/// `refine(t, seg, r * seg.sigma_maj)` gives `r2 = sigma_voxel(t) / (r * seg.sigma_maj)`
/// (`volume::cull::VoxelCulling`), one more uniform when `r2 < 1`, and the callback sees
/// `sigma_maj' = r2 * r * sigma_maj`. Thinning twice is thinning once by the product, and
/// reading the voxel bound only for the first stage's survivors keeps that read off the
/// collisions the cell bound already culls.
/// `r = 1` draws nothing, so a walk without culling keeps its random numbers.
///
/// Returns `T_maj`: the majorant transmittance from the last collision (or the start) to
/// `t_max` if the walk escaped, 1 if the callback stopped it. With exponential steps the escape
/// probability equals `T_maj`, so analog and weighted estimators never divide by it; it is
/// returned for estimators that sample differently (as in pbrt).
// Always inlined into its estimators: it is their whole loop, and the call and the state it
// would spill cost about 100 instructions a sample on the fire once the thinning's hand-on
// tipped the inliner against it (callgrind).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn sample_free_flight<I, M, K, R, C>(
    segments: I,
    t_max: f32,
    mut majorant: M,
    cull: K,
    refine: R,
    rng: &mut Rng,
    stats: &mut TrackingStats,
    mut callback: C,
) -> f32
where
    I: IntoIterator<Item = MajorantSegment>,
    M: FnMut(&MajorantSegment) -> f32,
    K: Fn(f32) -> f32,
    R: Fn(f32, &MajorantSegment, f32) -> f32,
    C: FnMut(&mut Rng, &mut TrackingStats, &Collision) -> bool,
{
    // Optical depth left before the next tentative collision (negative: none drawn yet), and
    // the majorant optical depth walked since the last collision (for T_maj).
    let mut tau_left = -1.0f32;
    let mut tau_since = 0.0f32;
    let mut n_collisions = 0u64;
    debug_assert!(!t_max.is_nan(), "a free flight needs an end");
    for seg in segments {
        if seg.t_min >= t_max {
            break;
        }
        // `seg.t_max.min(t_max)` for the non-NaN `t_max`, as one `minss`: `f32::min`'s NaN
        // handling cost four more instructions a segment.
        let t1 = if seg.t_max < t_max { seg.t_max } else { t_max };
        if !(t1 > seg.t_min) {
            continue;
        }
        stats.segments += 1;
        let sigma_maj = majorant(&seg);
        if !positive_finite(sigma_maj) {
            // A zero majorant is empty space; negative, NaN and infinite ones are invalid.
            if sigma_maj != 0.0 {
                stats.invalid_majorants += 1;
            }
            continue;
        }
        let mut t = seg.t_min;
        loop {
            if tau_left < 0.0 {
                tau_left = sample_exponential(rng.uniform_f32(), 1.0);
            }
            // The segment's optical depth decides first, with a multiply: most segments of a
            // fine walk end before the next collision, and they then cost no division. With
            // t1 = inf, tau_seg is inf and a collision always comes (no 0 * inf: sigma_maj > 0).
            let tau_seg = sigma_maj * (t1 - t);
            let t_next = if tau_left < tau_seg {
                t + tau_left / sigma_maj
            } else {
                t1
            };
            if !(t_next < t1) {
                // Escaped this segment: carry the rest of the depth into the next one.
                // Rounding may leave a hair below 0: the next collision is then at the next
                // segment's start.
                tau_left = (tau_left - tau_seg).max(0.0);
                tau_since += tau_seg;
                break;
            }
            t = t_next;
            tau_left = -1.0;
            tau_since = 0.0;
            n_collisions += 1;
            if n_collisions > MAX_TENTATIVE_COLLISIONS {
                stats.collision_cap_hits += 1;
                return 0.0;
            }
            let r = cull(t);
            let mut sigma_kept = sigma_maj;
            if r < 1.0 {
                // `!(u < r)`: a NaN ratio culls too (no lookup against an unknown bound).
                if !thin(rng, r) {
                    stats.null_collisions += 1;
                    continue;
                }
                sigma_kept = r * sigma_maj;
            }
            let r2 = refine(t, &seg, r * seg.sigma_maj);
            if r2 < 1.0 {
                if !thin(rng, r2) {
                    stats.null_collisions += 1;
                    continue;
                }
                sigma_kept *= r2;
            }
            let c = Collision {
                t,
                sigma_maj: sigma_kept,
                seg,
            };
            if !callback(rng, stats, &c) {
                return 1.0;
            }
        }
    }
    (-tau_since).exp()
}

/// Control optical depth beyond which `exp(-tau_c)` is 0 in f32 (`exp(-104) < 2^-150`): the
/// closed-form control factor, and with it every control-based transmittance estimate, is 0.
pub const CONTROL_DEPTH_CUTOFF: f32 = 104.0;

/// The segments of a walk, summing the control's optical depth `integral sigma_c dt` over the
/// clipped segments as the free-flight loop pulls them: the closed-form factor of
/// decomposition, weighted decomposition and residual ratio tracking in the same walk as the
/// residual, instead of a second walk before it. Stops the walk once the depth passes
/// [`CONTROL_DEPTH_CUTOFF`], where the estimate is 0 whatever follows.
pub struct ControlDepthWalk<I, C> {
    segments: I,
    t_max: f32,
    /// The control extinction over a segment ([`Medium::control`]).
    sigma_c: C,
    /// The control optical depth of the segments pulled so far.
    pub tau_c: f32,
}

impl<I, C: Fn(&MajorantSegment) -> f32> ControlDepthWalk<I, C> {
    pub fn new(segments: I, t_max: f32, sigma_c: C) -> Self {
        ControlDepthWalk {
            segments,
            t_max,
            sigma_c,
            tau_c: 0.0,
        }
    }

    /// `exp(-tau_c)`, 0 when the walk was cut.
    #[inline]
    pub fn control_transmittance(&self) -> f32 {
        if self.tau_c > CONTROL_DEPTH_CUTOFF {
            0.0
        } else if self.tau_c == 0.0 {
            // No control on the walk (the culled walk's one segment has minorant 0): exp(-0)
            // is exactly 1, and the libm call cost ~30 instructions a culled shadow ray.
            1.0
        } else {
            (-self.tau_c).exp()
        }
    }
}

impl<I: Iterator<Item = MajorantSegment>, C: Fn(&MajorantSegment) -> f32> Iterator
    for ControlDepthWalk<I, C>
{
    type Item = MajorantSegment;

    #[inline(always)]
    fn next(&mut self) -> Option<MajorantSegment> {
        if self.tau_c > CONTROL_DEPTH_CUTOFF {
            return None;
        }
        let seg = self.segments.next()?;
        if seg.t_min < self.t_max {
            let len = seg.t_max.min(self.t_max) - seg.t_min;
            let sigma_c = (self.sigma_c)(&seg);
            if len > 0.0 && sigma_c > 0.0 {
                self.tau_c += sigma_c * len;
            }
        }
        Some(seg)
    }
}

/// Unbiased Russian roulette on `|w|` (see [`ROULETTE_THRESHOLD`]): returns the new weight,
/// 0 when the path is killed. Draws one uniform only when `|w| < threshold`.
#[inline]
pub fn roulette(w: f32, threshold: f32, rng: &mut Rng, stats: &mut TrackingStats) -> f32 {
    let a = w.abs();
    if a >= threshold || a == 0.0 {
        return w;
    }
    if rng.uniform_f32() < a / threshold {
        threshold.copysign(w)
    } else {
        stats.roulette_kills += 1;
        0.0
    }
}

/// One counted density lookup.
#[inline]
pub(crate) fn lookup<M: Medium + ?Sized>(medium: &M, t: f32, stats: &mut TrackingStats) -> Coeffs {
    stats.lookups += 1;
    medium.coeffs(t)
}

/// Counts a majorant violation when `sigma_t` exceeds `sigma_maj` beyond the tolerance.
#[inline]
pub(crate) fn check_bound(sigma_t: f32, sigma_maj: f32, stats: &mut TrackingStats) {
    if sigma_t > sigma_maj * (1.0 + MAJORANT_TOLERANCE) {
        stats.majorant_violations += 1;
    }
}

/// One counted RGB density lookup.
#[inline]
pub(crate) fn lookup_rgb<M: MediumRgb + ?Sized>(
    medium: &M,
    t: f32,
    stats: &mut TrackingStats,
) -> CoeffsRgb {
    stats.lookups += 1;
    medium.coeffs(t)
}
