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
use super::flight::{DistanceEstimator, Estimator, Outcome, Real, Tracker, TransmittanceEstimator};
use super::{check_bound, lookup, Collision, Medium};
use crate::sampling::Rng;

/// Analog delta tracking: the bound itself is the majorant, with the per-voxel stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Delta;

impl<M: Medium + ?Sized> Estimator<M> for Delta {
    type Weight = f32;
}

impl<M: Medium + ?Sized> DistanceEstimator<M> for Delta {
    /// The first real collision (analog: weights are 1).
    #[inline]
    fn distance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let k = lookup(tr.medium, c.t, tr.stats);
        check_bound(k.sigma_t(), c.sigma_maj, tr.stats);
        // One uniform against the CDF [sigma_a, sigma_a + sigma_s, sigma_maj].
        let x = tr.rng.uniform_f32() * c.sigma_maj;
        if x < k.sigma_a {
            Outcome::Real(Real::Absorb, None)
        } else if x < k.sigma_a + k.sigma_s {
            Outcome::Real(Real::Scatter, None)
        } else {
            Outcome::Null(None)
        }
    }
}

impl<M: Medium + ?Sized> TransmittanceEstimator<M> for Delta {
    /// The Bernoulli estimate: 1 or 0.
    #[inline]
    fn transmittance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let sigma_t = lookup(tr.medium, c.t, tr.stats).sigma_t();
        check_bound(sigma_t, c.sigma_maj, tr.stats);
        bernoulli(sigma_t, c.sigma_maj, tr.rng)
    }
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
