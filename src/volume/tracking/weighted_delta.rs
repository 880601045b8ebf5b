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
use super::{
    lookup, record_choice, sample_free_flight, scaled_majorant, voxel_stage, Event, Medium,
    TrackingStats,
};
use crate::sampling::{sample_discrete, Rng};
use crate::volume::MajorantSegment;

/// Samples a real collision with weights; `b` is the majorant scale.
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
    sample_free_flight(
        segments,
        t_max,
        scaled_majorant(b),
        |t| medium.cull_ratio(t),
        |t, seg, bound| voxel_stage(medium, b, false, t, seg, bound),
        rng,
        stats,
        |rng, stats, c| {
            medium.on_collision(c.t, c.sigma_maj, w);
            let k = lookup(medium, c.t, stats);
            let sigma_n = c.sigma_maj - k.sigma_t();
            let p = [k.sigma_a.abs(), k.sigma_s.abs(), sigma_n.abs()];
            let total = p[0] + p[1] + p[2];
            let u = rng.uniform_f32();
            // total >= |sigma_a + sigma_s + sigma_n| = sigma_maj > 0, so a choice always exists.
            let Some(choice) = sample_discrete(&p, u) else {
                return true;
            };
            let sigma_x = [k.sigma_a, k.sigma_s, sigma_n][choice.index];
            w *= (total / c.sigma_maj).copysign(sigma_x);
            stats.note_weight(w);
            record_choice(choice.index, c.t, w, stats, &mut event)
        },
    );
    event.unwrap_or(Event::Escape { weight: w })
}

/// Weighted transmittance estimate (may be negative when `b < 1`; unbiased).
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
    let mut w = 1.0f32;
    sample_free_flight(
        segments,
        t_max,
        scaled_majorant(b),
        |t| medium.cull_ratio(t),
        |t, seg, bound| voxel_stage(medium, b, false, t, seg, bound),
        rng,
        stats,
        |rng, stats, c| {
            let sigma_t = lookup(medium, c.t, stats).sigma_t();
            let sigma_n = c.sigma_maj - sigma_t;
            let total = sigma_t.abs() + sigma_n.abs();
            if rng.uniform_f32() * total < sigma_t.abs() {
                stats.real_collisions += 1;
                w = 0.0;
                false
            } else {
                stats.null_collisions += 1;
                w *= (total / c.sigma_maj).copysign(sigma_n);
                stats.note_weight(w);
                true
            }
        },
    );
    w
}
