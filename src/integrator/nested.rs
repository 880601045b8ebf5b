//! Free flight through VDB media that lie inside a homogeneous medium and do not overlap one
//! another (a smoke in a water tank, a cache in a fog-filled room): the homogeneous flight in
//! closed form, then each VDB medium's own flight cut short where the homogeneous one
//! collided. No merged segment stream, so each VDB medium keeps its own walk (the culled walk
//! and the per-voxel stage included), and the homogeneous medium costs no lookups at all.
//!
//! Why it is the sum's free flight. Extinction adds, so the sum's transmittance is the product
//! `T(t) = T_h(t) T_v(t)`, and the first real collision of the sum is the earlier of the first
//! real collisions of the parts, drawn independently (superposed Poisson processes, Lewis &
//! Shedler 1979; the "minimum of independent flights" of Galtier et al. 2013 and Kutz et al.
//! 2017's decomposition, one part sampled analytically). With `t_h` the homogeneous medium's
//! collision (or `t1`) and the VDB flights run over `[a, min(b, t_h)]`:
//!
//! ```text
//! VDB event at t_v < t_h:  weight = w_v * T_h(t_v) / S_h(t_v)
//! VDB escape up to t_h:    the homogeneous event at t_h, weight = w_v * w_h
//! ```
//!
//! `S_h(t) = P(t_h > t)` is the survival of the homogeneous draw: `T_h(t)` for grey extinction
//! (the ratio is 1), `mean_c exp(-sigma_t,c t)` for chromatic extinction, whose distance is
//! drawn from one channel with the one-sample MIS pdf (`sample_homogeneous`); `w_h` is that
//! draw's own weight. Every VDB estimator only has to be unbiased over its own (random) range
//! `[a, min(b, t_h)]`, which each is: delta, the weighted ones, decomposition and spectral
//! tracking alike. Emission met on the VDB flights is counted with probability `S_h(t)` where
//! it needs `T_h(t)`: exact for grey extinction; chromatic extinction with emitting media goes
//! to the merged flight (`mixture`) instead, as do absorption events in the homogeneous
//! medium (its absorption carries no distance back) and VDB media that overlap one another.
use glam::Vec3;

use super::features::Features;
use super::homogeneous::exp_neg;
use super::homogeneous::sample_homogeneous;
use super::media::{sample_vdb_in_turn, Flight, MediumEvent};
use super::mixture::{RayMedia, VdbSpan};
use crate::render::media::HomogeneousMedium;
use crate::render::settings::Absorption;
use crate::volume::phases::Phase;

/// Whether [`sample_nested`] takes the flight through `vdb` (sorted, non-overlapping spans)
/// inside `hom` under `absorption` (see the module doc for what it leaves to the mixture).
#[inline]
pub fn nested_applies(vdb: &[VdbSpan], hom: &HomogeneousMedium, absorption: Absorption) -> bool {
    let sigma_t = hom.sigma_t();
    let grey = sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z;
    absorption == Absorption::Weight && (grey || vdb.iter().all(|(m, _, _)| m.emission.is_none()))
}

/// `T_h(t) / S_h(t)` per channel for the homogeneous draw of `sample_homogeneous` (1 for grey
/// extinction, where the draw's survival is the transmittance itself).
#[inline]
fn transmittance_over_survival<F: Features>(h: &HomogeneousMedium, t: f32) -> Vec3 {
    let sigma_t = h.sigma_t();
    if !F::CHROM || (sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z) {
        return Vec3::ONE;
    }
    let tr = exp_neg(sigma_t, t);
    let survival = tr.element_sum() / 3.0;
    if survival > 0.0 {
        tr / survival
    } else {
        Vec3::ZERO
    }
}

/// The free flight through `media`: VDB media (sorted, non-overlapping) inside a homogeneous
/// one (see the module doc). Emission met on the way is added to `l` (weighted by `beta`).
/// Call only where [`nested_applies`].
pub fn sample_nested<F: Features>(media: RayMedia, beta: Vec3, f: Flight) -> (MediumEvent, Phase) {
    let (vdb, ray, t0, t1) = (media.vdb, media.ray, media.t0, media.t1);
    let Some(hom) = media.hom else {
        // Nothing around them: the VDB media in turn.
        return sample_vdb_in_turn::<F>(vdb.iter().copied(), t1, ray, beta, f);
    };
    // The homogeneous part first: its collision (or t1) ends every VDB flight.
    let (t_h, hom_event) = match sample_homogeneous::<F>(hom, t1 - t0, f.cfg.absorption, f.rng) {
        MediumEvent::Scatter { t, weight } => (t0 + t, MediumEvent::Scatter { t: t0 + t, weight }),
        escape @ MediumEvent::Escape { .. } => (t1, escape),
        // Not with absorption as a weight (`nested_applies`); no distance to cut at.
        MediumEvent::Absorb => return (MediumEvent::Absorb, hom.phase),
    };
    // Then the VDB media in turn, each cut at t_h.
    let weight = match sample_vdb_in_turn::<F>(vdb.iter().copied(), t_h, ray, beta, f) {
        (MediumEvent::Escape { weight }, _) => weight,
        (MediumEvent::Scatter { t, weight }, phase) => {
            let f = transmittance_over_survival::<F>(hom, t - t0);
            return (
                MediumEvent::Scatter {
                    t,
                    weight: weight * f,
                },
                phase,
            );
        }
        absorb => return absorb,
    };
    let event = match hom_event {
        MediumEvent::Scatter { t, weight: w } => MediumEvent::Scatter {
            t,
            weight: weight * w,
        },
        MediumEvent::Escape { weight: w } => MediumEvent::Escape { weight: weight * w },
        MediumEvent::Absorb => MediumEvent::Absorb,
    };
    (event, hom.phase)
}
