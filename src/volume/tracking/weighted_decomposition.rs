//! Weighted decomposition tracking.
//!
//! Kutz, Habel, Li & Novak (2017), "Spectral and Decomposition Tracking for Rendering
//! Heterogeneous Volumes", sec. 5, with the weighted (signed) events of sec. 3-4 so that the
//! control may exceed the minorant: e.g. `sigma_c = m * bound` with `m` above
//! `min sigma_t / bound`, where `sigma_r = sigma_t - sigma_c` turns negative.
//!
//! Tentative collisions at rate `sigma_maj = sigma_c + r_bar` with
//! `r_bar = residual_majorant(b, seg, sigma_c)`. One uniform `u`, one CDF, control first:
//!
//! ```text
//! u sigma_maj < sigma_c_a               -> control absorb,  w *= 1   (no lookup)
//! u sigma_maj < sigma_c                 -> control scatter, w *= 1   (no lookup)
//! otherwise: lookup, u' = (u sigma_maj - sigma_c) / r_bar, and over x in {r_a, r_s, r_n}
//!   (r_a = sigma_a - sigma_c_a, r_s = sigma_s - sigma_c_s, r_n = r_bar - r_a - r_s):
//!   P_x = |sigma_x| / (|r_a| + |r_s| + |r_n|)
//!   w  *= sigma_x / (r_bar P_x) = sign(sigma_x) (|r_a| + |r_s| + |r_n|) / r_bar
//!   r_a -> absorb, r_s -> scatter, r_n -> null (continue)
//! ```
//!
//! The control weight is exactly 1 because the control coefficients are non-negative and chosen
//! in proportion. Transmittance: `exp(-int sigma_c)` in closed form times the weighted
//! residual estimate (events {real: |sigma_r|, null: |r_n|}; `w` on escape, 0 on real).
use super::flight::{DistanceEstimator, Estimator, Outcome, Real, Tracker, TransmittanceEstimator};
use super::weighted_delta::{real_or_null, weighted_choice};
use super::{lookup, residual_majorant, Collision, Medium};
use crate::sampling::discrete::ONE_MINUS_EPSILON;
use crate::volume::MajorantSegment;

/// Weighted decomposition tracking, `b` scaling the residual majorant; the per-voxel stage where
/// the control is 0 and `b >= 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedDecomposition {
    /// The scale of the residual majorant, any `b > 0`.
    pub b: f32,
}

impl<M: Medium + ?Sized> Estimator<M> for WeightedDecomposition {
    type Weight = f32;
    const CONTROL: bool = true;
    fn b(&self) -> f32 {
        self.b
    }
    /// `sigma_c + r_bar`: the control, then the residual's majorant.
    #[inline]
    fn majorant(&self, medium: &M, seg: &MajorantSegment) -> f32 {
        let sigma_c = medium.control(seg).sigma_t();
        sigma_c + residual_majorant(self.b, seg, sigma_c)
    }
}

impl<M: Medium + ?Sized> DistanceEstimator<M> for WeightedDecomposition {
    /// A (control or residual) real collision with weights.
    #[inline]
    fn distance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let ctl = tr.medium.control(&c.seg);
        let sigma_c = ctl.sigma_t();
        let x = tr.rng.uniform_f32() * c.sigma_maj;
        if x < sigma_c {
            return Outcome::Control(if x < ctl.sigma_a {
                Real::Absorb
            } else {
                Real::Scatter
            });
        }
        // The residual majorant the collision was sampled with: without a control it is the
        // collision's majorant itself, which culling may have thinned below the segment's
        // (`sample_free_flight`); `0 + r` is `r`, so unculled walks keep their bits.
        let r_bar = if sigma_c == 0.0 {
            c.sigma_maj
        } else {
            residual_majorant(self.b, &c.seg, sigma_c)
        };
        if !(r_bar > 0.0) {
            // Only reachable through rounding of `x` at the top of the control interval.
            return Outcome::Skip;
        }
        let u = ((x - sigma_c) / r_bar).clamp(0.0, ONE_MINUS_EPSILON);
        let k = lookup(tr.medium, c.t, tr.stats);
        let (r_a, r_s) = (k.sigma_a - ctl.sigma_a, k.sigma_s - ctl.sigma_s);
        let r_n = r_bar - r_a - r_s;
        weighted_choice([r_a, r_s, r_n], r_bar, u)
    }
}

impl<M: Medium + ?Sized> TransmittanceEstimator<M> for WeightedDecomposition {
    /// The residual's majorant `r_bar`.
    #[inline]
    fn transmittance_majorant(&self, medium: &M, seg: &MajorantSegment) -> f32 {
        residual_majorant(self.b, seg, medium.control(seg).sigma_t())
    }

    /// The weighted estimate of the residual, signed when the control exceeds `sigma_t` or
    /// `b < 1`.
    #[inline]
    fn transmittance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let sigma_r =
            lookup(tr.medium, c.t, tr.stats).sigma_t() - tr.medium.control(&c.seg).sigma_t();
        real_or_null(sigma_r, c.sigma_maj, tr.rng)
    }
}
