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
    lookup, residual_majorant, roulette, sample_free_flight, ControlDepthWalk, Medium,
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
    M: Medium + ?Sized,
{
    // The control factor is summed in the same walk (`ControlDepthWalk`); a walk cut at the
    // depth where it underflows returns 0, as the estimate is then 0.
    let mut walk = ControlDepthWalk::new(segments.into_iter(), t_max, medium);
    let mut tr = 1.0f32;
    let majorant = |seg: &MajorantSegment| residual_majorant(b, seg, medium.control(seg).sigma_t());
    sample_free_flight(
        &mut walk,
        t_max,
        majorant,
        |t| medium.cull_ratio(t),
        // No per-voxel stage: it would raise the variance ([`super::voxel_stage`]).
        |_, _, _| 1.0,
        rng,
        stats,
        |rng, stats, c| {
            let sigma_r = lookup(medium, c.t, stats).sigma_t() - medium.control(&c.seg).sigma_t();
            stats.null_collisions += 1;
            tr *= 1.0 - sigma_r / c.sigma_maj;
            stats.note_weight(tr);
            tr = roulette(tr, ROULETTE_THRESHOLD, rng, stats);
            tr != 0.0
        },
    );
    let t_control = walk.control_transmittance();
    if t_control == 0.0 {
        return 0.0;
    }
    t_control * tr
}
