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
use super::flight::{self, Outcome, Real, Rgb, Walk};
use super::{lookup_rgb, scaled_majorant, Event, MediumRgb, TrackingStats};
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

/// The walk of both functions: `b` times the bound, no per-voxel stage (see
/// `tracking::voxel_stage`), Russian roulette on `max |w|` after null collisions.
fn walk(b: f32) -> Walk<impl FnMut(&MajorantSegment) -> f32> {
    Walk {
        majorant: scaled_majorant(b),
        voxel: None,
        roulette: true,
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
    flight::distance(
        segments,
        t_max,
        Rgb(medium),
        walk(b),
        rng,
        stats,
        |rng, stats, c, w| {
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
                return Outcome::Dead;
            };
            let sigma_x = [k.sigma_a, k.sigma_s, sigma_n][choice.index];
            let factor = Some(sigma_x / (c.sigma_maj * choice.pmf));
            match choice.index {
                0 => Outcome::Real(Real::Absorb, factor),
                1 => Outcome::Real(Real::Scatter, factor),
                _ => Outcome::Null(factor),
            }
        },
    )
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
    flight::transmittance(
        segments,
        t_max,
        Rgb(medium),
        walk(b),
        rng,
        stats,
        |rng, stats, c, w| {
            let sigma_t = lookup_rgb(medium, c.t, stats).sigma_t();
            let sigma_n = Vec3::splat(c.sigma_maj) - sigma_t;
            let p_real = mode.reduce(sigma_t * w);
            let p_null = mode.reduce(sigma_n * w);
            let total = p_real + p_null;
            if !(total > 0.0) || rng.uniform_f32() * total < p_real {
                return Outcome::Real(Real::Absorb, None);
            }
            Outcome::Null(Some(sigma_n * (total / (c.sigma_maj * p_null))))
        },
    )
}
