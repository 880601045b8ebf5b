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
use super::flight::{self, Grey, Outcome, Walk};
use super::{lookup, scaled_majorant, Medium, TrackingStats};
use crate::sampling::Rng;
use crate::volume::MajorantSegment;

/// Ratio-tracking transmittance estimate; `b` scales the majorant.
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
        majorant: scaled_majorant(b),
        // No per-voxel stage: it would raise the variance ([`super::voxel_stage`]).
        voxel: None,
        roulette: true,
    };
    flight::transmittance(
        segments,
        t_max,
        Grey(medium),
        walk,
        rng,
        stats,
        |_, stats, c, _| {
            let sigma_t = lookup(medium, c.t, stats).sigma_t();
            Outcome::Null(Some(1.0 - sigma_t / c.sigma_maj))
        },
    )
}
