//! Residual ratio tracking for transmittance.
//!
//! Novak, Selle & Jarosz (2014), "Residual ratio tracking for estimating attenuation in
//! participating media", ACM TOG 33(6), sec. 4. A control extinction `sigma_c` known without a
//! lookup (`Medium::control`) is attenuated analytically; ratio tracking handles only the
//! residual `sigma_r = sigma_t - sigma_c` against the residual majorant
//! `r_bar = residual_majorant(b, seg, sigma_c)`:
//!
//! ```text
//! <T> = exp(-int sigma_c dt) * prod_i (1 - (sigma_t(t_i) - sigma_c) / r_bar)
//! ```
//!
//! With a good control the residual is small, so there are few collisions and each factor is
//! near 1: far less variance and fewer lookups than plain ratio tracking. Any `sigma_c` is
//! unbiased (the factors may be negative). Russian roulette as in ratio tracking, applied to the
//! residual product (the closed-form factor is not random).
use super::flight::{Estimator, Outcome, Tracker, TransmittanceEstimator};
use super::{lookup, residual_majorant, Collision, Medium};
use crate::volume::MajorantSegment;

/// Residual ratio tracking, `b` scaling the residual majorant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResidualRatio {
    /// The scale of the residual majorant, any `b > 0`.
    pub b: f32,
}

impl<M: Medium + ?Sized> Estimator<M> for ResidualRatio {
    type Weight = f32;
    const CONTROL: bool = true;
    // No per-voxel stage: it would raise the variance ([`super::voxel_stage`]).
    const VOXEL_STAGE: bool = false;
    const ROULETTE: bool = true;
    fn b(&self) -> f32 {
        self.b
    }
    /// The residual's majorant `r_bar`.
    #[inline]
    fn majorant(&self, medium: &M, seg: &MajorantSegment) -> f32 {
        residual_majorant(self.b, seg, medium.control(seg).sigma_t())
    }
}

impl<M: Medium + ?Sized> TransmittanceEstimator<M> for ResidualRatio {
    /// Every collision multiplies the residual's estimate by its null probability.
    #[inline]
    fn transmittance_rule(&self, tr: &mut Tracker<'_, M, f32>, c: &Collision) -> Outcome<f32> {
        let sigma_r =
            lookup(tr.medium, c.t, tr.stats).sigma_t() - tr.medium.control(&c.seg).sigma_t();
        Outcome::Null(Some(1.0 - sigma_r / c.sigma_maj))
    }
}
