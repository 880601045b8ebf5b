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
use super::flight::{DistanceEstimator, Estimator, Outcome, Real, Tracker, TransmittanceEstimator};
use super::{lookup_rgb, Collision, MediumRgb};
use crate::sampling::sample_discrete;
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

/// Spectral tracking with majorant `b * bound`, no per-voxel stage (see
/// `tracking::voxel_stage`), Russian roulette on `max |w|` after null collisions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spectral {
    /// The majorant scale, any `b > 0`.
    pub b: f32,
    /// How the channels reduce to one event probability.
    pub mode: SpectralProbabilities,
    /// The path throughput before a distance-sampling flight, which only weighs its
    /// history-aware probabilities (the returned weight multiplies it). Transmittance weighs
    /// by its own weight alone: `Vec3::ONE` there.
    pub beta: Vec3,
}

impl<M: MediumRgb + ?Sized> Estimator<M> for Spectral {
    type Weight = Vec3;
    const VOXEL_STAGE: bool = false;
    const ROULETTE: bool = true;
    fn b(&self) -> f32 {
        self.b
    }
}

impl<M: MediumRgb + ?Sized> DistanceEstimator<M> for Spectral {
    /// A real collision for RGB extinction. A path whose history is all zero ends with
    /// `Absorb { weight: 0 }`.
    #[inline]
    fn distance_rule(&self, tr: &mut Tracker<'_, M, Vec3>, c: &Collision) -> Outcome<Vec3> {
        let k = lookup_rgb(tr.medium, c.t, tr.stats);
        let sigma_n = Vec3::splat(c.sigma_maj) - k.sigma_t();
        let h = self.beta * tr.w;
        let p = [
            self.mode.reduce(k.sigma_a * h),
            self.mode.reduce(k.sigma_s * h),
            self.mode.reduce(sigma_n * h),
        ];
        let u = tr.rng.uniform_f32();
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
    }
}

impl<M: MediumRgb + ?Sized> TransmittanceEstimator<M> for Spectral {
    /// The RGB estimate: history-aware real or null, the history its own weight.
    #[inline]
    fn transmittance_rule(&self, tr: &mut Tracker<'_, M, Vec3>, c: &Collision) -> Outcome<Vec3> {
        let sigma_t = lookup_rgb(tr.medium, c.t, tr.stats).sigma_t();
        let sigma_n = Vec3::splat(c.sigma_maj) - sigma_t;
        let p_real = self.mode.reduce(sigma_t * tr.w);
        let p_null = self.mode.reduce(sigma_n * tr.w);
        let total = p_real + p_null;
        if !(total > 0.0) || tr.rng.uniform_f32() * total < p_real {
            return Outcome::Real(Real::Absorb, None);
        }
        Outcome::Null(Some(sigma_n * (total / (c.sigma_maj * p_null))))
    }
}
