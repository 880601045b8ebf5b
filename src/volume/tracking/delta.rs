//! Analog delta tracking.
//!
//! Woodcock, Murphy, Hemmings & Longworth (1965), "Techniques used in the GEM code for Monte
//! Carlo neutronics calculations"; in rendering terms Kutz, Habel, Li & Novak (2017),
//! "Spectral and Decomposition Tracking for Rendering Heterogeneous Volumes", sec. 3.
//!
//! Tentative collisions come at rate `sigma_maj >= sigma_t`; at each one, with one uniform `u`:
//!
//! ```text
//! P_a = sigma_a / sigma_maj      -> absorb
//! P_s = sigma_s / sigma_maj      -> scatter
//! P_n = sigma_n / sigma_maj      -> null, continue   (sigma_n = sigma_maj - sigma_t >= 0)
//! ```
//!
//! The first real collision is distributed exactly as `sigma_t(t) T(t)`; every weight is 1.
//! Transmittance (track-length / Bernoulli estimator): `<T> = 1` if the walk escapes, else 0.
//!
//! The estimator REQUIRES a bounding majorant. If a lookup finds
//! `sigma_t > sigma_maj (1 + MAJORANT_TOLERANCE)` the probabilities above are wrong (the
//! real-collision probability is capped at 1); this is counted in
//! `TrackingStats::majorant_violations` so the caller can report biased results. Use weighted
//! delta tracking when the majorant does not bound.
use super::flight::{self, Grey, Outcome, Real, Walk};
use super::{check_bound, lookup, scaled_majorant, Event, Medium, TrackingStats};
use crate::sampling::Rng;
use crate::volume::MajorantSegment;

/// The walk of both functions: the bound itself, with the per-voxel stage.
fn walk() -> Walk<impl FnMut(&MajorantSegment) -> f32> {
    Walk {
        majorant: scaled_majorant(1.0),
        voxel: Some((1.0, false)),
        roulette: false,
    }
}

/// Samples the first real collision along the segments (analog: weights are 1).
pub fn sample_distance<I, M>(
    segments: I,
    t_max: f32,
    medium: &M,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> Event<f32>
where
    I: IntoIterator<Item = MajorantSegment>,
    M: Medium + ?Sized,
{
    flight::distance(
        segments,
        t_max,
        Grey(medium),
        walk(),
        rng,
        stats,
        |rng, stats, c, _| {
            let k = lookup(medium, c.t, stats);
            check_bound(k.sigma_t(), c.sigma_maj, stats);
            // One uniform against the CDF [sigma_a, sigma_a + sigma_s, sigma_maj].
            let x = rng.uniform_f32() * c.sigma_maj;
            if x < k.sigma_a {
                Outcome::Real(Real::Absorb, None)
            } else if x < k.sigma_a + k.sigma_s {
                Outcome::Real(Real::Scatter, None)
            } else {
                Outcome::Null(None)
            }
        },
    )
}

/// Bernoulli transmittance estimate over `[segments, t_max]`: 1 or 0.
pub fn transmittance<I, M>(
    segments: I,
    t_max: f32,
    medium: &M,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> f32
where
    I: IntoIterator<Item = MajorantSegment>,
    M: Medium + ?Sized,
{
    flight::transmittance(
        segments,
        t_max,
        Grey(medium),
        walk(),
        rng,
        stats,
        |rng, stats, c, _| {
            let sigma_t = lookup(medium, c.t, stats).sigma_t();
            check_bound(sigma_t, c.sigma_maj, stats);
            bernoulli(sigma_t, c.sigma_maj, rng)
        },
    )
}

/// The transmittance rule of delta tracking, and of decomposition tracking on the residual:
/// a real collision with probability `sigma / sigma_maj` (one uniform), else a null one.
#[inline]
pub(super) fn bernoulli(sigma: f32, sigma_maj: f32, rng: &mut Rng) -> Outcome<f32> {
    if rng.uniform_f32() * sigma_maj < sigma {
        Outcome::Real(Real::Absorb, None)
    } else {
        Outcome::Null(None)
    }
}
