//! Next-event estimation: one light sample from a scattering point, its shadow ray's
//! transmittance through media and null interfaces (`Stage::TraceShadow`), weighted against the
//! scattering strategy by the power heuristic.
use glam::Vec3;

use super::features::Features;
use super::flight::vdb_intervals;
use super::homogeneous::transmittance_homogeneous;
use super::media::transmittance_vdb;
use crate::math::Ray;
use crate::render::lights::{power_heuristic, LightSource};
use crate::render::media::{MediaStats, TrackingConfig};
use crate::render::prepare::{RenderScene, SurfaceKind};
use crate::render::stack::MediumStack;
use crate::sampling::sobol::{bounce_dim, DIM_LIGHT, DIM_LIGHT_SELECT};
use crate::sampling::{Rng, Sampler};
use crate::volume::phases::Phase;

/// Transmittance along the shadow ray `ray` (unit direction) over distance `dist`, through
/// media and null interfaces; 0 when an opaque or refracting surface blocks. Overlapping media
/// multiply their transmittances (extinction adds), so each is estimated on its own (`F::MIX`: VDB
/// media inside a homogeneous one too).
pub(super) fn trace_shadow<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    ray: &Ray,
    dist: f32,
    mut media: MediumStack,
    rng: &mut Rng,
    stats: &mut MediaStats,
) -> Vec3 {
    let mut tr = Vec3::ONE;
    let mut t0 = 0.0f32;
    loop {
        let hit = if F::SURF {
            rs.scene.closest_hit(ray, t0, dist, cfg.time)
        } else {
            None
        };
        // A surface that scatters blocks the ray: the media before it are not tracked, as
        // their estimate would only be multiplied by 0 (pbrt-v4's `TraceTransmittance` tests
        // the surface first too). Where the light lies behind a refractive boundary (a smoke
        // in a water tank lit by the sun) every shadow ray from inside is such a ray.
        let mat_index = hit.map(|h| {
            let instance = rs.scene.triangle_instance(h.triangle as usize);
            rs.scene.instances[instance as usize].material as usize
        });
        if mat_index.is_some_and(|m| rs.kinds[m] != SurfaceKind::Null) {
            return Vec3::ZERO;
        }
        let t1 = hit.map_or(dist, |h| h.t);
        tr *= media_transmittance::<F>(rs, cfg, ray, t0, t1, media.top(), rng, stats);
        if tr == Vec3::ZERO {
            return tr;
        }
        let (Some(h), Some(mat_index)) = (hit, mat_index) else {
            return tr;
        };
        if F::HOM {
            let [a, b, c] = rs.scene.triangle_corners_at(h.triangle as usize, cfg.time);
            let entering = (b - a).cross(c - a).dot(ray.d) < 0.0;
            media.cross(rs.scene.materials[mat_index].interior_medium, entering);
        }
        t0 = h.t + 1e-4 * (1.0 + h.t);
        if t0 >= dist {
            return tr;
        }
    }
}

/// Transmittance along `ray` over `[t0, t1]` through the media there and no surface: the
/// homogeneous medium `medium` the ray is in and the VDB media it crosses (those inside the
/// homogeneous one with `F::MIX`), each estimated on its own.
#[allow(clippy::too_many_arguments)]
pub(super) fn media_transmittance<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    ray: &Ray,
    t0: f32,
    t1: f32,
    medium: Option<u32>,
    rng: &mut Rng,
    stats: &mut MediaStats,
) -> Vec3 {
    let mut tr = Vec3::ONE;
    if F::HOM {
        if let Some(h) = medium {
            tr *= transmittance_homogeneous(&rs.homogeneous[h as usize], t1 - t0);
        }
    }
    if F::HET && (F::MIX || medium.is_none()) {
        for &(m, a, b) in vdb_intervals(rs, ray, t0, t1).iter() {
            tr *= transmittance_vdb::<F>(m, ray, a, b, cfg, rng, stats);
            if tr == Vec3::ZERO {
                return tr;
            }
        }
    }
    tr
}

/// How the last event chose its light for next-event estimation: what the escape of the ray
/// sampled from it needs for its MIS weight against the environment.
#[derive(Clone, Copy, Debug)]
pub(super) struct EnvChoice {
    /// The environment's selection probability at the event.
    pub(super) pmf: f32,
    /// The (constant) environment was sampled by the phase function there.
    pub(super) by_phase: bool,
}

/// Where a next-event estimate starts.
#[derive(Clone, Copy)]
pub(super) struct Vertex<'a> {
    /// The point (offset off a surface already).
    pub(super) p: Vec3,
    /// The media it lies in.
    pub(super) media: MediumStack,
    /// At a medium event: its phase function, `wo` and the continuation albedo, for the guided
    /// light selection; `None` at a surface.
    pub(super) phase: Option<(&'a Phase, Vec3, f32)>,
}

/// Next-event estimation from `v`: one light sample, its visibility and transmittance, weighted
/// against the scattering strategy by the power heuristic. `scatter(wi)` gives the scattering
/// factor (phase value, or BSDF times cosine) and its sampling pdf. `bounce` picks the
/// sampler's light-selection and light-sample blocks. At a medium event (`v.phase`) the light
/// is chosen by the guided selection of [`Lights::phase_selection`] (uniformly elsewhere).
/// Returns the estimate, how the environment was chosen and, where a light was sampled, which.
pub(super) fn next_event<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    v: Vertex,
    sampler: &mut Sampler,
    bounce: u32,
    stats: &mut MediaStats,
    scatter: impl Fn(Vec3) -> (Vec3, f32),
) -> (Vec3, EnvChoice, Option<LightSource>) {
    let Vertex { p, media, phase } = v;
    // Selection before position: the independent sampler draws in this order.
    let u_select = sampler.get1d(bounce_dim(bounce, DIM_LIGHT_SELECT));
    let u_light = sampler.get2d(bounce_dim(bounce, DIM_LIGHT));
    let lights = &rs.lights;
    let dt = cfg.time;
    let guided = phase.and_then(|(ph, wo, a)| {
        Some((ph, wo, lights.phase_selection(p, a, |wi| ph.p(wo, wi), dt)?))
    });
    let (ls, choice) = match guided {
        Some((ph, wo, sel)) => {
            let rng = &mut sampler.rng;
            let phase_sample = |u| {
                // A rejection-sampled phase (Draine) draws its further points from the path's
                // own random stream.
                let s = ph.sample(wo, u, &mut || rng.uniform_vec2());
                (s.wi, s.pdf)
            };
            let ls = lights.sample_selected(&sel, p, u_select, u_light, phase_sample, dt);
            let choice = EnvChoice {
                pmf: sel.env,
                by_phase: sel.env_by_phase,
            };
            (ls, choice)
        }
        _ => (
            lights.sample(rs.scene, p, u_select, u_light, dt),
            EnvChoice {
                pmf: lights.uniform_env_pmf(),
                by_phase: false,
            },
        ),
    };
    let Some(ls) = ls else {
        return (Vec3::ZERO, choice, None);
    };
    let (f, pdf_scatter) = scatter(ls.wi);
    if f == Vec3::ZERO || !(ls.pdf > 0.0) {
        return (Vec3::ZERO, choice, None);
    }
    // Stop short of an area light's own triangle.
    let dist = if ls.dist.is_finite() {
        ls.dist * (1.0 - 1e-4)
    } else {
        f32::INFINITY
    };
    let tr = trace_shadow::<F>(
        rs,
        cfg,
        &Ray::new(p, ls.wi),
        dist,
        media,
        &mut sampler.rng,
        stats,
    );
    let w = if ls.is_delta {
        1.0
    } else {
        power_heuristic(ls.pdf, pdf_scatter)
    };
    (tr * ls.li * f * (w / ls.pdf), choice, Some(ls.source))
}
