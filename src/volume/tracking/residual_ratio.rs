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
use super::flight::{self, Outcome, Walk};
use super::{lookup, residual_majorant, Medium, TrackingStats};
use crate::sampling::Rng;
use crate::volume::MajorantSegment;

/// Residual-ratio-tracking transmittance estimate; `b` scales the residual majorant.
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
    let walk = Walk {
        majorant: |seg: &MajorantSegment| residual_majorant(b, seg, medium.control(seg).sigma_t()),
        // No per-voxel stage: it would raise the variance ([`super::voxel_stage`]).
        voxel: None,
        roulette: true,
    };
    flight::control_transmittance(
        segments,
        t_max,
        medium,
        walk,
        rng,
        stats,
        |_, stats, c, _| {
            let sigma_r = lookup(medium, c.t, stats).sigma_t() - medium.control(&c.seg).sigma_t();
            Outcome::Null(Some(1.0 - sigma_r / c.sigma_maj))
        },
    )
}
