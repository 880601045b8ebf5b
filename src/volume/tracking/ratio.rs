//! Ratio tracking for transmittance.
//!
//! Cramer (1978), "Application of the fictitious scattering radiation transport model for
//! deep-penetration Monte Carlo calculations"; introduced to rendering by Novak, Selle & Jarosz
//! (2014), "Residual ratio tracking for estimating attenuation in participating media",
//! ACM TOG 33(6), sec. 3.
//!
//! Tentative collisions at rate `sigma_maj = b * bound`; instead of deciding real vs null,
//! every collision multiplies the estimate by the null probability:
//!
//! ```text
//! <T> = prod_i (1 - sigma_t(t_i) / sigma_maj)
//! ```
//!
//! Unbiased for any `sigma_maj > 0` (factors are negative where it does not bound). Used on
//! shadow rays; it does not sample distances. Russian roulette on `|T| < ROULETTE_THRESHOLD`
//! (survive with probability `|T| / threshold`, then carry `sign(T) threshold`) ends walks whose
//! contribution has become small without biasing.
use super::flight::{Estimator, Outcome, Tracker, TransmittanceEstimator};
use super::{lookup, Collision, Medium};

/// Ratio tracking with majorant `b * bound`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ratio {
    /// The majorant scale, any `b > 0`.
    pub b: f32,
}

impl<M: Medium + ?Sized> Estimator<M> for Ratio {
    type Weight = f32;
    // No per-voxel stage: it would raise the variance ([`super::voxel_stage`]).
    const VOXEL_STAGE: bool = false;
    const ROULETTE: bool = true;
    fn b(&self) -> f32 {
        self.b
    }
}

impl<M: Medium + ?Sized> TransmittanceEstimator<M> for Ratio {
    /// Every collision multiplies the estimate by its null probability.
    #[inline]
    fn transmittance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let sigma_t = lookup(tr.medium, c.t, tr.stats).sigma_t();
        Outcome::Null(Some(1.0 - sigma_t / c.sigma_maj))
    }
}
