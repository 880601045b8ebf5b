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
use super::{
    control_optical_depth, lookup, residual_majorant, roulette, sample_free_flight, Medium,
    TrackingStats, ROULETTE_THRESHOLD,
};
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
    I::IntoIter: Clone,
    M: Medium + ?Sized,
{
    let segments = segments.into_iter();
    let t_control = (-control_optical_depth(segments.clone(), t_max, medium)).exp();
    if t_control == 0.0 {
        // The closed-form factor underflowed: the estimate is 0 whatever the residual walk
        // gives. Stop here, because that walk (a control above the density makes its factors
        // exceed 1) could overflow to infinity, and 0 * inf is NaN.
        return 0.0;
    }
    let mut tr = 1.0f32;
    let majorant = |seg: &MajorantSegment| residual_majorant(b, seg, medium.control(seg).sigma_t());
    sample_free_flight(segments, t_max, majorant, rng, stats, |rng, stats, c| {
        let sigma_r = lookup(medium, c.t, stats).sigma_t() - medium.control(&c.seg).sigma_t();
        stats.null_collisions += 1;
        tr *= 1.0 - sigma_r / c.sigma_maj;
        stats.note_weight(tr);
        tr = roulette(tr, ROULETTE_THRESHOLD, rng, stats);
        tr != 0.0
    });
    t_control * tr
}
