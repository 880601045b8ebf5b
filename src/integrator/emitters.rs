//! Next-event estimation towards emitting media (`render::media_lights`): one point of the
//! emitting media per scattering event, its shadow ray ratio tracked through every medium,
//! weighed against the flights' own emission by the power heuristic.
use std::cell::Cell;

use glam::Vec3;

use super::features::Features;
use super::next_event::trace_shadow;
use crate::math::Ray;
use crate::render::lights::{power_heuristic, LightSource};
use crate::render::media::{MediaStats, TrackingConfig};
use crate::render::prepare::RenderScene;
use crate::render::stack::MediumStack;
use crate::sampling::Rng;

/// The media lights' estimate at shading point `p` (in `media`), whose scattering factor and
/// its direction pdf are `scatter(wi)`, and the medium it sampled; `None` without emitting
/// media or where the point drawn was rejected (`w_L f T Le / (p_V r^2 P_keep)`,
/// `render::media_lights`).
pub(super) fn emitter_event<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    p: Vec3,
    media: MediumStack,
    rng: &mut Rng,
    stats: &mut MediaStats,
    scatter: impl Fn(Vec3) -> (Vec3, f32),
) -> Option<(Vec3, LightSource)> {
    let lights = rs.media_lights.as_ref()?;
    let u_select = rng.uniform_f32();
    let u = Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
    let u_keep = rng.uniform_f32();
    let s = lights.sample(p, u_select, u)?;
    let vdb = lights.media[s.slot as usize].vdb;
    let e = rs.vdb[vdb as usize].emission.as_ref()?;
    let lookups = Cell::new(0);
    let le = e.radiance(s.y, &lookups);
    stats.emission_lookups += lookups.get();
    let keep = (le.max_element() / s.weight).min(1.0);
    if !(u_keep < keep) {
        return None;
    }
    let to = s.y - p;
    let d2 = to.length_squared();
    let dist = d2.sqrt();
    if !(dist > 0.0) {
        return None;
    }
    let wi = to / dist;
    let (f, pdf_dir) = scatter(wi);
    let p_l = s.pdf_volume * d2;
    if f == Vec3::ZERO || !(p_l > 0.0) {
        return None;
    }
    let w = power_heuristic(p_l, pdf_dir * s.sigma_maj);
    let tr = trace_shadow::<F>(rs, cfg, &Ray::new(p, wi), dist, media, rng, stats);
    let source = LightSource::Medium(vdb);
    Some((tr * f * le * (w / (p_l * keep)), source))
}
