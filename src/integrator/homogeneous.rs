//! Homogeneous media inside closed meshes (`KHR_materials_volume`): sampled in closed form, no
//! tracking and no lookups.
use glam::Vec3;

use super::features::Features;
use super::media::MediumEvent;
use crate::render::media::HomogeneousMedium;
use crate::render::settings::Absorption;
use crate::sampling::Rng;
use crate::volume::tracking;

/// Closed-form free flight through a homogeneous medium over `[0, t_max]` (no tracking, no
/// lookups). Grey extinction: an exponential step, then (absorption as an event) absorb or
/// scatter in proportion to the mean albedo with `albedo / mean` as weight, or (absorption as
/// a weight) scatter with the RGB albedo as weight, drawing no uniform. Chromatic extinction: the distance is drawn from
/// one channel chosen uniformly and weighted by the one-sample MIS (balance heuristic) over
/// channels, `pdf(t) = mean_c sigma_t,c exp(-sigma_t,c t)`; absorption is a weight then, so
/// no absorption events occur. Chromatic extinction is compiled in if `F::CHROM`.
#[inline]
pub fn sample_homogeneous<F: Features>(
    h: &HomogeneousMedium,
    t_max: f32,
    absorption: Absorption,
    rng: &mut Rng,
) -> MediumEvent {
    let sigma_t = h.sigma_t();
    if !F::CHROM || (sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z) {
        let st = sigma_t.x;
        if !(st > 0.0) {
            return MediumEvent::Escape { weight: Vec3::ONE };
        }
        let t = tracking::sample_exponential(rng.uniform_f32(), st);
        if t >= t_max {
            return MediumEvent::Escape { weight: Vec3::ONE };
        }
        let albedo = h.sigma_s / st;
        if absorption == Absorption::Weight {
            return MediumEvent::Scatter { t, weight: albedo };
        }
        let p_scatter = (albedo.x + albedo.y + albedo.z) / 3.0;
        if rng.uniform_f32() < p_scatter {
            return MediumEvent::Scatter {
                t,
                weight: albedo / p_scatter,
            };
        }
        return MediumEvent::Absorb;
    }
    let c = ((rng.uniform_f32() * 3.0) as usize).min(2);
    let st_c = sigma_t[c];
    let t = if st_c > 0.0 {
        tracking::sample_exponential(rng.uniform_f32(), st_c)
    } else {
        f32::INFINITY
    };
    if t < t_max {
        let tr = exp_neg(sigma_t, t);
        let pdf = (sigma_t * tr).element_sum() / 3.0;
        MediumEvent::Scatter {
            t,
            weight: h.sigma_s * tr / pdf,
        }
    } else {
        let tr = exp_neg(sigma_t, t_max);
        let p_escape = tr.element_sum() / 3.0;
        MediumEvent::Escape {
            weight: tr / p_escape,
        }
    }
}

/// `exp(-sigma_t d)`: exact.
#[inline]
pub fn transmittance_homogeneous(h: &HomogeneousMedium, d: f32) -> Vec3 {
    exp_neg(h.sigma_t(), d)
}

/// `exp(-sigma_t d)` per channel, with a clear channel (`sigma_t = 0`) transmitting 1 even over
/// an infinite distance, where `0 * inf` would be NaN (an open mesh, a ray that never leaves).
#[inline]
pub(super) fn exp_neg(sigma_t: Vec3, d: f32) -> Vec3 {
    Vec3::select(sigma_t.cmpeq(Vec3::ZERO), Vec3::ONE, (-sigma_t * d).exp())
}
