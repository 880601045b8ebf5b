//! Spectral tracking for chromatic (RGB) extinction.
//!
//! Kutz, Habel, Li & Novak (2017), "Spectral and Decomposition Tracking for Rendering
//! Heterogeneous Volumes", sec. 4. One scalar majorant `sigma_maj = b * bound` (the bound of
//! the largest channel) drives tentative collisions for all channels at once; the RGB null
//! coefficient `sigma_n = sigma_maj - sigma_t` may be negative in some channels. Event
//! probabilities are "history-aware": they weigh each channel by the current path throughput
//! `h = beta * w` so that channels already carrying little energy do not dictate the walk:
//!
//! ```text
//! P_x = R(|sigma_x * h|) / (R(|sigma_a * h|) + R(|sigma_s * h|) + R(|sigma_n * h|))
//! w  *= sigma_x / (sigma_maj * P_x)              (per channel, signed)
//! R = max over channels   (SpectralProbabilities::HistoryAwareMax, the paper's default)
//! R = mean over channels  (SpectralProbabilities::HistoryAwareAverage)
//! ```
//!
//! Absorb / scatter end the flight, null continues. `P_x > 0` whenever any channel of
//! `sigma_x * h` is non-zero, which keeps the estimator unbiased. Because `w` can shrink at null
//! collisions, Russian roulette on `max |w| < ROULETTE_THRESHOLD` (survive with probability
//! `max |w| / threshold`, then rescale) ends paths cheaply without bias.
//!
//! Transmittance: events {real: R(|sigma_t * h|), null: R(|sigma_n * h|)}, `h = w`;
//! `<T> = w` on escape (an RGB estimate of every channel's transmittance), 0 on a real event.
use super::{
    lookup_rgb, sample_free_flight, scaled_majorant, Event, MediumRgb, TrackingStats,
    ROULETTE_THRESHOLD,
};
use crate::sampling::{sample_discrete, Rng};
use crate::volume::MajorantSegment;
use glam::Vec3;

/// How the channels of `|sigma_x * h|` are reduced to one event probability.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectralProbabilities {
    /// `R = max` (Kutz et al. 2017, eq. 19-21 with the max norm).
    HistoryAwareMax,
    /// `R = average`.
    HistoryAwareAverage,
}

impl SpectralProbabilities {
    #[inline]
    fn reduce(self, v: Vec3) -> f32 {
        let a = v.abs();
        match self {
            SpectralProbabilities::HistoryAwareMax => a.max_element(),
            SpectralProbabilities::HistoryAwareAverage => (a.x + a.y + a.z) * (1.0 / 3.0),
        }
    }
}

/// Unbiased Russian roulette on `max |w|` of an RGB weight.
#[inline]
fn roulette_rgb(w: Vec3, rng: &mut Rng, stats: &mut TrackingStats) -> Vec3 {
    let m = w.abs().max_element();
    if m >= ROULETTE_THRESHOLD || m == 0.0 {
        return w;
    }
    if rng.uniform_f32() < m / ROULETTE_THRESHOLD {
        w * (ROULETTE_THRESHOLD / m)
    } else {
        stats.roulette_kills += 1;
        Vec3::ZERO
    }
}

/// Samples a real collision for RGB extinction. `beta` is the path throughput before this
/// flight (only used for the history-aware probabilities); the returned weight multiplies it.
/// A path whose history is all zero ends with `Absorb { weight: 0 }`.
#[allow(clippy::too_many_arguments)]
pub fn sample_distance<I, M>(
    segments: I,
    t_max: f32,
    b: f32,
    medium: &M,
    beta: Vec3,
    mode: SpectralProbabilities,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> Event<Vec3>
where
    I: IntoIterator<Item = MajorantSegment>,
    M: MediumRgb + ?Sized,
{
    let mut w = Vec3::ONE;
    let mut event = None;
    sample_free_flight(
        segments,
        t_max,
        scaled_majorant(b),
        |t| medium.cull_ratio(t),
        // No per-voxel stage (see `tracking::voxel_stage`).
        |_, _, _| 1.0,
        rng,
        stats,
        |rng, stats, c| {
            medium.on_collision(c.t, c.sigma_maj, w);
            let k = lookup_rgb(medium, c.t, stats);
            let sigma_n = Vec3::splat(c.sigma_maj) - k.sigma_t();
            let h = beta * w;
            let p = [
                mode.reduce(k.sigma_a * h),
                mode.reduce(k.sigma_s * h),
                mode.reduce(sigma_n * h),
            ];
            let u = rng.uniform_f32();
            let Some(choice) = sample_discrete(&p, u) else {
                // All history is zero: nothing can contribute any more.
                event = Some(Event::Absorb {
                    t: c.t,
                    weight: Vec3::ZERO,
                });
                return false;
            };
            let sigma_x = [k.sigma_a, k.sigma_s, sigma_n][choice.index];
            w *= sigma_x / (c.sigma_maj * choice.pmf);
            stats.note_weight(w.abs().max_element());
            match choice.index {
                0 => {
                    stats.real_collisions += 1;
                    event = Some(Event::Absorb { t: c.t, weight: w });
                    false
                }
                1 => {
                    stats.real_collisions += 1;
                    event = Some(Event::Scatter { t: c.t, weight: w });
                    false
                }
                _ => {
                    stats.null_collisions += 1;
                    w = roulette_rgb(w, rng, stats);
                    if w == Vec3::ZERO {
                        event = Some(Event::Absorb {
                            t: c.t,
                            weight: Vec3::ZERO,
                        });
                        return false;
                    }
                    true
                }
            }
        },
    );
    event.unwrap_or(Event::Escape { weight: w })
}

/// RGB transmittance estimate by spectral tracking.
pub fn transmittance<I, M>(
    segments: I,
    t_max: f32,
    b: f32,
    medium: &M,
    mode: SpectralProbabilities,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> Vec3
where
    I: IntoIterator<Item = MajorantSegment>,
    M: MediumRgb + ?Sized,
{
    let mut w = Vec3::ONE;
    sample_free_flight(
        segments,
        t_max,
        scaled_majorant(b),
        |t| medium.cull_ratio(t),
        // No per-voxel stage (see `tracking::voxel_stage`).
        |_, _, _| 1.0,
        rng,
        stats,
        |rng, stats, c| {
            let sigma_t = lookup_rgb(medium, c.t, stats).sigma_t();
            let sigma_n = Vec3::splat(c.sigma_maj) - sigma_t;
            let p_real = mode.reduce(sigma_t * w);
            let p_null = mode.reduce(sigma_n * w);
            let total = p_real + p_null;
            if !(total > 0.0) || rng.uniform_f32() * total < p_real {
                stats.real_collisions += 1;
                w = Vec3::ZERO;
                return false;
            }
            stats.null_collisions += 1;
            w *= sigma_n * (total / (c.sigma_maj * p_null));
            stats.note_weight(w.abs().max_element());
            w = roulette_rgb(w, rng, stats);
            w != Vec3::ZERO
        },
    );
    w
}
