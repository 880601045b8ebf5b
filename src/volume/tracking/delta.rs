//! Analog delta tracking.
//!
//! Woodcock, Murphy, Hemmings & Longworth (1965), "Techniques used in the GEM code for Monte
//! Carlo neutronics calculations"; in rendering terms Kutz, Habel, Li & Novak (2017),
//! "Spectral and Decomposition Tracking for Rendering Heterogeneous Volumes", sec. 3.
//!
//! Tentative collisions come at rate `sigma_maj >= sigma_t`; at each one, with one uniform `u`:
//!
//! ```text
//! P_a = sigma_a / sigma_maj      -> absorb
//! P_s = sigma_s / sigma_maj      -> scatter
//! P_n = sigma_n / sigma_maj      -> null, continue   (sigma_n = sigma_maj - sigma_t >= 0)
//! ```
//!
//! The first real collision is distributed exactly as `sigma_t(t) T(t)`; every weight is 1.
//! Transmittance (track-length / Bernoulli estimator): `<T> = 1` if the walk escapes, else 0.
//!
//! The estimator REQUIRES a bounding majorant. If a lookup finds
//! `sigma_t > sigma_maj (1 + MAJORANT_TOLERANCE)` the probabilities above are wrong (the
//! real-collision probability is capped at 1); this is counted in
//! `TrackingStats::majorant_violations` so the caller can report biased results. Use weighted
//! delta tracking when the majorant does not bound.
use super::{
    check_bound, lookup, sample_free_flight, scaled_majorant, voxel_stage, Event, Medium,
    TrackingStats,
};
use crate::sampling::Rng;
use crate::volume::MajorantSegment;

/// Samples the first real collision along the segments (analog: weights are 1).
pub fn sample_distance<I, M>(
    segments: I,
    t_max: f32,
    medium: &M,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> Event<f32>
where
    I: IntoIterator<Item = MajorantSegment>,
    M: Medium + ?Sized,
{
    let mut event = Event::Escape { weight: 1.0 };
    sample_free_flight(
        segments,
        t_max,
        scaled_majorant(1.0),
        |t| medium.cull_ratio(t),
        |t, seg, bound| voxel_stage(medium, 1.0, false, t, seg, bound),
        rng,
        stats,
        |rng, stats, c| {
            medium.on_collision(c.t, c.sigma_maj, 1.0);
            let k = lookup(medium, c.t, stats);
            check_bound(k.sigma_t(), c.sigma_maj, stats);
            // One uniform against the CDF [sigma_a, sigma_a + sigma_s, sigma_maj].
            let x = rng.uniform_f32() * c.sigma_maj;
            if x < k.sigma_a {
                stats.real_collisions += 1;
                event = Event::Absorb {
                    t: c.t,
                    weight: 1.0,
                };
                false
            } else if x < k.sigma_a + k.sigma_s {
                stats.real_collisions += 1;
                event = Event::Scatter {
                    t: c.t,
                    weight: 1.0,
                };
                false
            } else {
                stats.null_collisions += 1;
                true
            }
        },
    );
    event
}

/// Bernoulli transmittance estimate over `[segments, t_max]`: 1 or 0.
pub fn transmittance<I, M>(
    segments: I,
    t_max: f32,
    medium: &M,
    rng: &mut Rng,
    stats: &mut TrackingStats,
) -> f32
where
    I: IntoIterator<Item = MajorantSegment>,
    M: Medium + ?Sized,
{
    let mut tr = 1.0;
    sample_free_flight(
        segments,
        t_max,
        scaled_majorant(1.0),
        |t| medium.cull_ratio(t),
        |t, seg, bound| voxel_stage(medium, 1.0, false, t, seg, bound),
        rng,
        stats,
        |rng, stats, c| {
            let sigma_t = lookup(medium, c.t, stats).sigma_t();
            check_bound(sigma_t, c.sigma_maj, stats);
            if rng.uniform_f32() * c.sigma_maj < sigma_t {
                stats.real_collisions += 1;
                tr = 0.0;
                false
            } else {
                stats.null_collisions += 1;
                true
            }
        },
    );
    tr
}
