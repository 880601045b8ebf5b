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
use super::flight::{self, Grey, Outcome, Real, Walk};
use super::{check_bound, lookup, Event, Medium, TrackingStats, MAJORANT_TOLERANCE};
use crate::sampling::Rng;
use crate::volume::MajorantSegment;

/// Counts a violation when the control exceeds a component of the looked-up coefficients.
#[inline]
fn check_residual(r_a: f32, r_s: f32, sigma_maj: f32, stats: &mut TrackingStats) {
    let slack = -MAJORANT_TOLERANCE * sigma_maj;
    if r_a < slack || r_s < slack {
        stats.majorant_violations += 1;
    }
}

/// The walk with majorant `majorant`, with the per-voxel stage where the control is 0.
fn walk<Mj: FnMut(&MajorantSegment) -> f32>(majorant: Mj) -> Walk<Mj> {
    Walk {
        majorant,
        voxel: Some((1.0, true)),
        roulette: false,
    }
}

/// Samples the first real (control or residual) collision; weights are 1.
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
        walk(|seg: &MajorantSegment| seg.sigma_maj),
        rng,
        stats,
        |rng, stats, c, _| {
            let ctl = medium.control(&c.seg);
            let x = rng.uniform_f32() * c.sigma_maj;
            if x < ctl.sigma_a {
                return Outcome::Control(Real::Absorb);
            }
            if x < ctl.sigma_t() {
                return Outcome::Control(Real::Scatter);
            }
            let k = lookup(medium, c.t, stats);
            check_bound(k.sigma_t(), c.sigma_maj, stats);
            let (r_a, r_s) = (k.sigma_a - ctl.sigma_a, k.sigma_s - ctl.sigma_s);
            check_residual(r_a, r_s, c.sigma_maj, stats);
            let x = x - ctl.sigma_t();
            if x < r_a {
                Outcome::Real(Real::Absorb, None)
            } else if x < r_a + r_s {
                Outcome::Real(Real::Scatter, None)
            } else {
                Outcome::Null(None)
            }
        },
    )
}

/// `exp(-int sigma_c) * (Bernoulli residual estimate)`: either 0 or the control transmittance.
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
    // The residual is delta-tracked against the bound minus the control; the estimate is the
    // control factor (a residual weight of 1) unless a real residual collision zeroes it.
    let residual_majorant =
        |seg: &MajorantSegment| (seg.sigma_maj - medium.control(seg).sigma_t()).max(0.0);
    flight::control_transmittance(
        segments,
        t_max,
        medium,
        walk(residual_majorant),
        rng,
        stats,
        |rng, stats, c, _| {
            let ctl = medium.control(&c.seg);
            let k = lookup(medium, c.t, stats);
            check_bound(k.sigma_t(), c.seg.sigma_maj, stats);
            check_residual(
                k.sigma_a - ctl.sigma_a,
                k.sigma_s - ctl.sigma_s,
                c.seg.sigma_maj,
                stats,
            );
            bernoulli(k.sigma_t() - ctl.sigma_t(), c.sigma_maj, rng)
        },
    )
}
