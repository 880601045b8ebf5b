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
use super::{
    lookup, record_choice, residual_majorant, sample_free_flight, voxel_stage, ControlDepthWalk,
    Event, Medium, TrackingStats,
};
use crate::sampling::discrete::ONE_MINUS_EPSILON;
use crate::sampling::{sample_discrete, Rng};
use crate::volume::MajorantSegment;

/// Samples a (control or residual) real collision with weights; `b` scales the residual
/// majorant.
pub fn sample_distance<I, M>(
    segments: I,
    t_max: f32,
    b: f32,
    medium: &M,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> Event<f32>
where
    I: IntoIterator<Item = MajorantSegment>,
    M: Medium + ?Sized,
{
    let mut w = 1.0f32;
    let mut event = None;
    let majorant = |seg: &MajorantSegment| {
        let sigma_c = medium.control(seg).sigma_t();
        sigma_c + residual_majorant(b, seg, sigma_c)
    };
    sample_free_flight(
        segments,
        t_max,
        majorant,
        |t| medium.cull_ratio(t),
        |t, seg, bound| voxel_stage(medium, b, true, t, seg, bound),
        rng,
        stats,
        |rng, stats, c| {
            medium.on_collision(c.t, c.sigma_maj, w);
            let ctl = medium.control(&c.seg);
            let sigma_c = ctl.sigma_t();
            let x = rng.uniform_f32() * c.sigma_maj;
            if x < sigma_c {
                stats.control_collisions += 1;
                event = Some(if x < ctl.sigma_a {
                    Event::Absorb { t: c.t, weight: w }
                } else {
                    Event::Scatter { t: c.t, weight: w }
                });
                return false;
            }
            // The residual majorant the collision was sampled with: without a control it is the
            // collision's majorant itself, which culling may have thinned below the segment's
            // (`sample_free_flight`); `0 + r` is `r`, so unculled walks keep their bits.
            let r_bar = if sigma_c == 0.0 {
                c.sigma_maj
            } else {
                residual_majorant(b, &c.seg, sigma_c)
            };
            if !(r_bar > 0.0) {
                // Only reachable through rounding of `x` at the top of the control interval.
                return true;
            }
            let u = ((x - sigma_c) / r_bar).clamp(0.0, ONE_MINUS_EPSILON);
            let k = lookup(medium, c.t, stats);
            let (r_a, r_s) = (k.sigma_a - ctl.sigma_a, k.sigma_s - ctl.sigma_s);
            let r_n = r_bar - r_a - r_s;
            let p = [r_a.abs(), r_s.abs(), r_n.abs()];
            let total = p[0] + p[1] + p[2];
            let Some(choice) = sample_discrete(&p, u) else {
                return true;
            };
            let sigma_x = [r_a, r_s, r_n][choice.index];
            w *= (total / r_bar).copysign(sigma_x);
            stats.note_weight(w);
            record_choice(choice.index, c.t, w, stats, &mut event)
        },
    );
    event.unwrap_or(Event::Escape { weight: w })
}

/// `exp(-int sigma_c) * w_residual` (signed when the control exceeds `sigma_t` or `b < 1`).
pub fn transmittance<I, M>(
    segments: I,
    t_max: f32,
    b: f32,
    medium: &M,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> f32
where
    I: IntoIterator<Item = MajorantSegment>,
    M: Medium + ?Sized,
{
    // The control factor is summed in the same walk (`ControlDepthWalk`).
    let mut walk = ControlDepthWalk::new(segments.into_iter(), t_max, medium);
    let mut w = 1.0f32;
    let majorant = |seg: &MajorantSegment| residual_majorant(b, seg, medium.control(seg).sigma_t());
    sample_free_flight(
        &mut walk,
        t_max,
        majorant,
        |t| medium.cull_ratio(t),
        |t, seg, bound| voxel_stage(medium, b, true, t, seg, bound),
        rng,
        stats,
        |rng, stats, c| {
            let sigma_r = lookup(medium, c.t, stats).sigma_t() - medium.control(&c.seg).sigma_t();
            let r_n = c.sigma_maj - sigma_r;
            let total = sigma_r.abs() + r_n.abs();
            if rng.uniform_f32() * total < sigma_r.abs() {
                stats.real_collisions += 1;
                w = 0.0;
                false
            } else {
                stats.null_collisions += 1;
                w *= (total / c.sigma_maj).copysign(r_n);
                stats.note_weight(w);
                true
            }
        },
    );
    let t_control = walk.control_transmittance();
    if t_control == 0.0 {
        // As in residual ratio tracking: a zero closed-form factor makes the estimate 0, and
        // the residual weight could overflow (0 * inf = NaN).
        return 0.0;
    }
    t_control * w
}
