//! Weighted delta tracking with a majorant scale `b`.
//!
//! Galtier, Blanco, Caliot, Coustet, Dauchet, El Hafi, Eymet, Fournier, Gautrais, Khuong,
//! Piaud & Terrée (2013), "Integral formulation of null-collision Monte Carlo algorithms",
//! JQSRT 125; Kutz, Habel, Li & Novak (2017), "Spectral and Decomposition Tracking for
//! Rendering Heterogeneous Volumes", sec. 3-4 (the weighted form and its probabilities).
//!
//! The majorant is `sigma_maj = b * bound` for any `b > 0`; it need not bound `sigma_t`, so the
//! null coefficient `sigma_n = sigma_maj - sigma_t` may be negative. At each tentative collision
//! (rate `sigma_maj`), with one uniform over the CDF of
//!
//! ```text
//! P_x = |sigma_x| / (|sigma_a| + |sigma_s| + |sigma_n|),   x in {a, s, n}
//! w  *= sigma_x / (sigma_maj * P_x)  = sign(sigma_x) * (|sigma_a| + |sigma_s| + |sigma_n|) / sigma_maj
//! ```
//!
//! absorb or scatter end the flight, null continues. Where `b * bound >= sigma_t` every factor
//! is 1 and this is analog delta tracking. With `b < 1` every factor has magnitude >= 1, so
//! `|w|` only grows (Russian roulette on small weights never fires here; nothing is clamped);
//! the largest `|w|` is recorded in `TrackingStats::max_abs_weight`.
//!
//! Transmittance: events {real: |sigma_t|, null: |sigma_n|}; `<T> = w` on escape, 0 on a real
//! event, with `w *= sigma_n / (sigma_maj P_n)` at nulls.
use super::flight::{DistanceEstimator, Estimator, Outcome, Real, Tracker, TransmittanceEstimator};
use super::{lookup, Collision, Medium};
use crate::sampling::{sample_discrete, Rng};

/// Weighted delta tracking with majorant `b * bound`, the per-voxel stage under `b >= 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedDelta {
    /// The majorant scale, any `b > 0`.
    pub b: f32,
}

impl<M: Medium + ?Sized> Estimator<M> for WeightedDelta {
    type Weight = f32;
    fn b(&self) -> f32 {
        self.b
    }
}

impl<M: Medium + ?Sized> DistanceEstimator<M> for WeightedDelta {
    /// A real collision with weights.
    #[inline]
    fn distance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let k = lookup(tr.medium, c.t, tr.stats);
        let sigma_n = c.sigma_maj - k.sigma_t();
        // total >= |sigma_a + sigma_s + sigma_n| = sigma_maj > 0, so a choice always exists.
        weighted_choice(
            [k.sigma_a, k.sigma_s, sigma_n],
            c.sigma_maj,
            tr.rng.uniform_f32(),
        )
    }
}

impl<M: Medium + ?Sized> TransmittanceEstimator<M> for WeightedDelta {
    /// The weighted estimate (may be negative when `b < 1`; unbiased).
    #[inline]
    fn transmittance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        real_or_null(
            lookup(tr.medium, c.t, tr.stats).sigma_t(),
            c.sigma_maj,
            tr.rng,
        )
    }
}

/// The distance rule of weighted delta tracking over the coefficients `[sigma_a, sigma_s,
/// sigma_n]` (of weighted decomposition tracking over the residual's), with uniform `u`:
/// `x` with probability `|sigma_x| / total`, the weight times
/// `sign(sigma_x) total / sigma_maj`. No choice (all 0) is skipped.
#[inline]
pub(super) fn weighted_choice(sigma: [f32; 3], sigma_maj: f32, u: f32) -> Outcome<f32> {
    let p = [sigma[0].abs(), sigma[1].abs(), sigma[2].abs()];
    let total = p[0] + p[1] + p[2];
    let Some(choice) = sample_discrete(&p, u) else {
        return Outcome::Skip;
    };
    let factor = Some((total / sigma_maj).copysign(sigma[choice.index]));
    match choice.index {
        0 => Outcome::Real(Real::Absorb, factor),
        1 => Outcome::Real(Real::Scatter, factor),
        _ => Outcome::Null(factor),
    }
}

/// The transmittance rule of weighted delta tracking with extinction `sigma` (of weighted
/// decomposition tracking with the residual): events {real: `|sigma|`, null: `|sigma_n|`},
/// `sigma_n = sigma_maj - sigma`, one uniform; a null weighted by
/// `sign(sigma_n) total / sigma_maj`.
#[inline]
pub(super) fn real_or_null(sigma: f32, sigma_maj: f32, rng: &mut Rng) -> Outcome<f32> {
    let sigma_n = sigma_maj - sigma;
    let total = sigma.abs() + sigma_n.abs();
    if rng.uniform_f32() * total < sigma.abs() {
        Outcome::Real(Real::Absorb, None)
    } else {
        Outcome::Null(Some((total / sigma_maj).copysign(sigma_n)))
    }
}
