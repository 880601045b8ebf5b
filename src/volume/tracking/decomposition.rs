//! Analog decomposition tracking.
//!
//! Kutz, Habel, Li & Novak (2017), "Spectral and Decomposition Tracking for Rendering
//! Heterogeneous Volumes", sec. 5. The extinction is split into a homogeneous control
//! component `sigma_c <= sigma_t` known without a lookup (see `Medium::control`) and a residual
//! `sigma_r = sigma_t - sigma_c >= 0` bounded by `sigma_maj - sigma_c`.
//!
//! The paper samples a control collision in closed form and delta-tracks the residual up to it,
//! keeping the nearer. Superposing the two Poisson processes gives the same distribution with
//! ONE stream of tentative collisions at rate `sigma_maj = bound` and one uniform per collision
//! over the CDF of
//!
//! ```text
//! P_ca = sigma_c_a / sigma_maj                      -> control absorb   (no lookup)
//! P_cs = sigma_c_s / sigma_maj                      -> control scatter  (no lookup)
//! P_ra = sigma_r_a / sigma_maj                      -> residual absorb  (lookup)
//! P_rs = sigma_r_s / sigma_maj                      -> residual scatter (lookup)
//! P_n  = (sigma_maj - sigma_c - sigma_r) / sigma_maj -> null             (lookup)
//! ```
//!
//! The uniform is compared with the control part FIRST, so a control collision, a fraction
//! `sigma_c / sigma_maj` of all collisions, never calls `Medium::coeffs`. All weights are 1.
//!
//! Transmittance: `T = exp(-int sigma_c) * T_r`; the control factor is taken in closed form
//! (a control collision would score 0, so its expectation is exactly that factor: lower variance
//! than sampling it) and `T_r` is the Bernoulli delta-tracking estimate of the residual against
//! `sigma_maj - sigma_c`.
//!
//! Requirements: `sigma_c_a <= sigma_a`, `sigma_c_s <= sigma_s` and `sigma_t <= bound`; a
//! lookup that breaks one counts a `majorant_violation`. For controls above the minorant use
//! weighted decomposition tracking.
use super::delta::bernoulli;
use super::flight::{DistanceEstimator, Estimator, Outcome, Real, Tracker, TransmittanceEstimator};
use super::{check_bound, lookup, Collision, Medium, TrackingStats, MAJORANT_TOLERANCE};
use crate::volume::MajorantSegment;

/// Counts a violation when the control exceeds a component of the looked-up coefficients.
#[inline]
fn check_residual(r_a: f32, r_s: f32, sigma_maj: f32, stats: &mut TrackingStats) {
    let slack = -MAJORANT_TOLERANCE * sigma_maj;
    if r_a < slack || r_s < slack {
        stats.majorant_violations += 1;
    }
}

/// Analog decomposition tracking: the bound itself is the majorant of distance sampling, the
/// bound minus the control that of the residual's transmittance, with the per-voxel stage where
/// the control is 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Decomposition;

impl<M: Medium + ?Sized> Estimator<M> for Decomposition {
    type Weight = f32;
    const CONTROL: bool = true;
}

impl<M: Medium + ?Sized> DistanceEstimator<M> for Decomposition {
    /// The first real (control or residual) collision; weights are 1.
    #[inline]
    fn distance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let ctl = tr.medium.control(&c.seg);
        let x = tr.rng.uniform_f32() * c.sigma_maj;
        if x < ctl.sigma_a {
            return Outcome::Control(Real::Absorb);
        }
        if x < ctl.sigma_t() {
            return Outcome::Control(Real::Scatter);
        }
        let k = lookup(tr.medium, c.t, tr.stats);
        check_bound(k.sigma_t(), c.sigma_maj, tr.stats);
        let (r_a, r_s) = (k.sigma_a - ctl.sigma_a, k.sigma_s - ctl.sigma_s);
        check_residual(r_a, r_s, c.sigma_maj, tr.stats);
        let x = x - ctl.sigma_t();
        if x < r_a {
            Outcome::Real(Real::Absorb, None)
        } else if x < r_a + r_s {
            Outcome::Real(Real::Scatter, None)
        } else {
            Outcome::Null(None)
        }
    }
}

impl<M: Medium + ?Sized> TransmittanceEstimator<M> for Decomposition {
    /// The residual is delta-tracked against the bound minus the control.
    #[inline]
    fn transmittance_majorant(&self, medium: &M, seg: &MajorantSegment) -> f32 {
        (seg.sigma_maj - medium.control(seg).sigma_t()).max(0.0)
    }

    /// The Bernoulli estimate of the residual: the whole estimate is the control factor (a
    /// residual weight of 1) unless a real residual collision zeroes it.
    #[inline]
    fn transmittance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let ctl = tr.medium.control(&c.seg);
        let k = lookup(tr.medium, c.t, tr.stats);
        check_bound(k.sigma_t(), c.seg.sigma_maj, tr.stats);
        check_residual(
            k.sigma_a - ctl.sigma_a,
            k.sigma_s - ctl.sigma_s,
            c.seg.sigma_maj,
            tr.stats,
        );
        bernoulli(k.sigma_t() - ctl.sigma_t(), c.sigma_maj, tr.rng)
    }
}
