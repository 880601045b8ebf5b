//! The CPU reference path tracer: one camera sample in, radiance out. Written for clarity
//! first; every physics step calls the shared routines (`media`, `lights`, `bsdf`,
//! `volume::tracking`). The const parameters are the scene's features (see
//! [`crate::render::prepare::FeatureFlags`]): a `false` removes that code from the compiled loop.
use glam::{Vec2, Vec3};

use super::bsdf::{fresnel_dielectric, refract, Principled};
use super::homogeneous::{sample_homogeneous, transmittance_homogeneous};
use super::media::{sample_vdb_in_turn, transmittance_vdb, Flight, MediumEvent};
use super::mixture::{sample_mixture, VdbSpan};
use super::nested::{nested_applies, sample_nested};
use crate::math::Ray;
use crate::render::lights::{emitted, power_heuristic};
use crate::render::media::{MediaStats, TrackingConfig};
use crate::render::prepare::{RenderScene, SurfaceKind};
use crate::render::stack::MediumStack;
use crate::sampling::sobol::{
    bounce_dim, DIM_DISTANCE, DIM_LIGHT, DIM_LIGHT_SELECT, DIM_LOBE, DIM_RR, DIM_SCATTER,
};
use crate::sampling::warp::Frame;
use crate::sampling::{Decision, Rng, Sampler};
use crate::volume::phase::HenyeyGreenstein;

/// Limits of one path.
#[derive(Clone, Copy, Debug)]
pub struct PathLimits {
    pub max_depth: u32,
    pub rr_depth: u32,
    /// Roulette also before `rr_depth` once `max(beta)` falls below this (0: never).
    pub rr_throughput: f32,
    pub max_collisions: u64,
    /// Guided light selection at medium events (`LightSelection::guided`).
    pub guided_lights: bool,
    /// The share of a constant sky left to the continuation ray there
    /// (`LightSelection::continuation_albedo`).
    pub continuation_albedo: f32,
}

/// What one path cost and did.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathStats {
    pub media: MediaStats,
    /// Scattering events (media and surfaces).
    pub depth: u64,
    /// Paths ended by the collision guard.
    pub guard_fired: u64,
    /// Largest channel of the throughput `beta` after any bounce's Russian roulette: how
    /// large a single sample's weight got (fireflies). With absorption as a weight and
    /// albedos at most 0.95 it never exceeds 1.
    pub max_beta: f32,
}

/// Relative offset that moves a new ray's origin off the surface it leaves.
fn offset(p: Vec3, n: Vec3, towards: Vec3) -> Vec3 {
    let eps = 1e-4 * (1.0 + p.abs().max_element());
    if n.dot(towards) >= 0.0 {
        p + n * eps
    } else {
        p - n * eps
    }
}

/// VDB media along one ray kept without allocating. Small on purpose: the spans are built,
/// zeroed and moved for every flight and shadow ray (with 16 that was 256 bytes a time, a few
/// percent of a sample), and scenes rarely cross more than a few media on one ray.
const INLINE_SPANS: usize = 4;

/// The VDB media along a ray: `(medium, t_min, t_max)` sorted by `t_min`; up to
/// [`INLINE_SPANS`] inline (no allocation on the hot path), any number on the heap. (The size
/// difference is the point: the inline variant lives on the stack of one flight.)
#[allow(clippy::large_enum_variant)]
enum Spans<'a> {
    Inline([VdbSpan<'a>; INLINE_SPANS], usize),
    Heap(Vec<VdbSpan<'a>>),
}

impl<'a> std::ops::Deref for Spans<'a> {
    type Target = [VdbSpan<'a>];
    fn deref(&self) -> &Self::Target {
        match self {
            Spans::Inline(a, n) => &a[..*n],
            Spans::Heap(v) => v,
        }
    }
}

/// The intervals of every VDB medium whose bounds `ray` crosses within `[t0, t1]`, with the
/// medium, sorted by start (disjoint unless media overlap).
fn vdb_intervals<'a>(rs: &'a RenderScene, ray: &Ray, t0: f32, t1: f32) -> Spans<'a> {
    // `1 / d` once for every medium (`intersect_inv` is `intersect` bit for bit).
    let inv_d = [0, 1, 2].map(|a| 1.0 / ray.d[a]);
    let mut hits = rs.vdb.iter().filter_map(|m| {
        let (a, b) = m.world_bounds.intersect_inv(ray.o, inv_d, t0, t1)?;
        // NaN ends are skipped too.
        (b > a).then_some((m, a, b))
    });
    // Most rays of a scene miss its media (nine in ten of the smoke tank's): an empty `Vec`
    // costs nothing to build or return, where filling the inline slots cost a fifth of the
    // call (callgrind).
    let Some(first) = hits.next() else {
        return Spans::Heap(Vec::new());
    };
    let mut out = Spans::Inline([first; INLINE_SPANS], 1);
    for span in hits {
        match &mut out {
            Spans::Inline(arr, n) if *n < arr.len() => {
                arr[*n] = span;
                *n += 1;
            }
            Spans::Inline(arr, n) => {
                let mut v = arr[..*n].to_vec();
                v.push(span);
                out = Spans::Heap(v);
            }
            Spans::Heap(v) => v.push(span),
        }
    }
    match &mut out {
        Spans::Inline(arr, n) if *n > 1 => arr[..*n].sort_unstable_by(|x, y| x.1.total_cmp(&y.1)),
        Spans::Inline(..) => {}
        Spans::Heap(v) => v.sort_unstable_by(|x, y| x.1.total_cmp(&y.1)),
    }
    out
}

/// Whether sorted intervals overlap one another.
fn intervals_overlap(iv: &[VdbSpan]) -> bool {
    iv.windows(2).any(|w| w[1].1 < w[0].2)
}

/// The free flight along `ray` over `[t0, t1]` through whatever media lie there: the
/// homogeneous medium the path is in, the VDB media the ray crosses, or, with `MIX` (a scene
/// with overlapping or nested media), VDB media side by side inside the homogeneous medium by
/// its closed-form flight cutting theirs short (`nested`), else their sum where they overlap
/// (`mixture`).
#[inline]
fn sample_media<
    const HET: bool,
    const HOM: bool,
    const EMIT: bool,
    const ABS: bool,
    const CHROM: bool,
    const MIX: bool,
>(
    rs: &RenderScene,
    ray: &Ray,
    t0: f32,
    t1: f32,
    medium: Option<u32>,
    beta: Vec3,
    f: Flight,
) -> (MediumEvent, HenyeyGreenstein) {
    let cfg = f.cfg;
    // The VDB spans, found once: the mixture test's are the flights' in turn below.
    let mut spans = None;
    if MIX && HET {
        let iv = spans.insert(vdb_intervals(rs, ray, t0, t1));
        let n = iv.len();
        let hom = medium.filter(|_| HOM).map(|h| &rs.homogeneous[h as usize]);
        let overlap = intervals_overlap(iv);
        if (hom.is_some() && n > 0) || overlap {
            // VDB media side by side inside the homogeneous one: its closed-form flight cuts
            // theirs short (`nested`); overlapping VDB media need the merged sum.
            if let Some(h) = hom.filter(|h| !overlap && nested_applies(iv, h, cfg.absorption)) {
                return sample_nested::<EMIT, ABS, CHROM>(iv, h, ray, t0, t1, beta, f);
            }
            return sample_mixture::<EMIT, ABS, CHROM>(iv, hom, ray, t0, t1, beta, f);
        }
    }
    if HOM {
        if let Some(h) = medium {
            let h = &rs.homogeneous[h as usize];
            let ev = match sample_homogeneous::<CHROM>(h, t1 - t0, cfg.absorption, f.rng) {
                MediumEvent::Scatter { t, weight } => MediumEvent::Scatter { t: t0 + t, weight },
                other => other,
            };
            return (ev, h.phase);
        }
    }
    if HET {
        let spans = spans.unwrap_or_else(|| vdb_intervals(rs, ray, t0, t1));
        return sample_vdb_in_turn::<EMIT, ABS, CHROM>(spans.iter().copied(), t1, ray, beta, f);
    }
    (
        MediumEvent::Escape { weight: Vec3::ONE },
        HenyeyGreenstein::new(0.0),
    )
}

/// Transmittance along the shadow ray `ray` (unit direction) over distance `dist`, through
/// media and null interfaces; 0 when an opaque or refracting surface blocks. Overlapping media
/// multiply their transmittances (extinction adds), so each is estimated on its own (`MIX`: VDB
/// media inside a homogeneous one too).
fn transmittance<
    const SURF: bool,
    const HET: bool,
    const HOM: bool,
    const CHROM: bool,
    const MIX: bool,
>(
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
        let hit = if SURF {
            rs.scene.bvh.closest_hit(ray, t0, dist)
        } else {
            None
        };
        // A surface that scatters blocks the ray: the media before it are not tracked, as
        // their estimate would only be multiplied by 0 (pbrt-v4's `TraceTransmittance` tests
        // the surface first too). Where the light lies behind a refractive boundary (a smoke
        // in a water tank lit by the sun) every shadow ray from inside is such a ray.
        let mat_index = hit.map(|h| {
            let tri = &rs.scene.triangles[h.triangle as usize];
            rs.scene.instances[tri.instance as usize].material as usize
        });
        if mat_index.is_some_and(|m| rs.kinds[m] != SurfaceKind::Null) {
            return Vec3::ZERO;
        }
        let t1 = hit.map_or(dist, |h| h.t);
        let medium = media.top();
        if HOM {
            if let Some(h) = medium {
                tr *= transmittance_homogeneous(&rs.homogeneous[h as usize], t1 - t0);
            }
        }
        if HET && (MIX || medium.is_none()) {
            for &(m, a, b) in vdb_intervals(rs, ray, t0, t1).iter() {
                tr *= transmittance_vdb::<CHROM>(m, ray, a, b, cfg, rng, stats);
                if tr == Vec3::ZERO {
                    return tr;
                }
            }
        }
        let (Some(h), Some(mat_index)) = (hit, mat_index) else {
            return tr;
        };
        if HOM {
            let [a, b, c] = rs.scene.triangle_corners(h.triangle as usize);
            let entering = (b - a).cross(c - a).dot(ray.d) < 0.0;
            media.cross(rs.scene.materials[mat_index].interior_medium, entering);
        }
        t0 = h.t + 1e-4 * (1.0 + h.t);
        if t0 >= dist {
            return tr;
        }
    }
}

/// How the last event chose its light for next-event estimation: what the escape of the ray
/// sampled from it needs for its MIS weight against the environment.
#[derive(Clone, Copy, Debug)]
struct EnvChoice {
    /// The environment's selection probability at the event.
    pmf: f32,
    /// The (constant) environment was sampled by the phase function there.
    by_phase: bool,
}

/// Where a next-event estimate starts.
#[derive(Clone, Copy)]
struct Vertex<'a> {
    /// The point (offset off a surface already).
    p: Vec3,
    /// The media it lies in.
    media: MediumStack,
    /// At a medium event: its phase function, `wo` and the continuation albedo, for the guided
    /// light selection; `None` at a surface.
    phase: Option<(&'a HenyeyGreenstein, Vec3, f32)>,
}

/// Next-event estimation from `v`: one light sample, its visibility and transmittance, weighted
/// against the scattering strategy by the power heuristic. `scatter(wi)` gives the scattering
/// factor (phase value, or BSDF times cosine) and its sampling pdf. `bounce` picks the
/// sampler's light-selection and light-sample blocks. At a medium event (`v.phase`) the light
/// is chosen by the guided selection of [`Lights::phase_selection`] (uniformly elsewhere).
/// Returns the estimate and how the environment was chosen.
fn next_event<
    const SURF: bool,
    const HET: bool,
    const HOM: bool,
    const CHROM: bool,
    const MIX: bool,
>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    v: Vertex,
    sampler: &mut Sampler,
    bounce: u32,
    stats: &mut MediaStats,
    scatter: impl Fn(Vec3) -> (Vec3, f32),
) -> (Vec3, EnvChoice) {
    let Vertex { p, media, phase } = v;
    // Selection before position: the independent sampler draws in this order.
    let u_select = sampler.get1d(bounce_dim(bounce, DIM_LIGHT_SELECT));
    let u_light = sampler.get2d(bounce_dim(bounce, DIM_LIGHT));
    let lights = &rs.lights;
    let guided = phase
        .and_then(|(ph, wo, a)| Some((ph, wo, lights.phase_selection(p, a, |wi| ph.p(wo, wi))?)));
    let (ls, choice) = match guided {
        Some((ph, wo, sel)) => {
            let ls = lights.sample_selected(&sel, p, u_select, u_light, |u| {
                let s = ph.sample(wo, u);
                (s.wi, s.pdf)
            });
            let choice = EnvChoice {
                pmf: sel.env,
                by_phase: sel.env_by_phase,
            };
            (ls, choice)
        }
        _ => (
            lights.sample(rs.scene, p, u_select, u_light),
            EnvChoice {
                pmf: lights.uniform_env_pmf(),
                by_phase: false,
            },
        ),
    };
    let Some(ls) = ls else {
        return (Vec3::ZERO, choice);
    };
    let (f, pdf_scatter) = scatter(ls.wi);
    if f == Vec3::ZERO || !(ls.pdf > 0.0) {
        return (Vec3::ZERO, choice);
    }
    // Stop short of an area light's own triangle.
    let dist = if ls.dist.is_finite() {
        ls.dist * (1.0 - 1e-4)
    } else {
        f32::INFINITY
    };
    let tr = transmittance::<SURF, HET, HOM, CHROM, MIX>(
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
    (tr * ls.li * f * (w / ls.pdf), choice)
}

/// Radiance along the camera ray through film point `film` (in [0,1]^2).
pub fn radiance<
    const SURF: bool,
    const HET: bool,
    const HOM: bool,
    const EMIT: bool,
    const ABS: bool,
    const CHROM: bool,
    const MIX: bool,
>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    limits: &PathLimits,
    film: Vec2,
    aspect: f32,
    sampler: &mut Sampler,
    stats: &mut PathStats,
) -> Vec3 {
    let scene = rs.scene;
    let (mut ray, mut t0) = rs.pinhole.primary_ray(film.x, film.y, aspect);
    let mut media = if HOM {
        rs.camera_media
    } else {
        MediumStack::EMPTY
    };
    let mut beta = Vec3::ONE;
    let mut l = Vec3::ZERO;
    let mut depth = 0u32;
    // Whether this bounce's free flight has drawn its sampler point (DIM_DISTANCE).
    let mut flight_started = false;
    // Whether the last direction was chosen by a delta distribution (no MIS), and its pdf.
    let mut specular = true;
    let mut prev_pdf = 0.0f32;
    // How the last event chose the environment (the escape's MIS weight).
    let mut prev_env = EnvChoice {
        pmf: rs.lights.uniform_env_pmf(),
        by_phase: false,
    };
    let collisions = |s: &MediaStats| {
        s.tracking.null_collisions + s.tracking.real_collisions + s.tracking.control_collisions
    };
    let start_collisions = collisions(&stats.media);
    loop {
        let hit = if SURF {
            scene.bvh.closest_hit(&ray, t0, f32::INFINITY)
        } else {
            None
        };
        let t_hit = hit.map_or(f32::INFINITY, |h| h.t);
        if HET || HOM {
            // The first flight after each scattering event starts from the sampler's
            // stratified point; one continued past a null interface does not reuse it.
            if !flight_started {
                sampler.queue_on_stream(bounce_dim(depth, DIM_DISTANCE));
                flight_started = true;
            }
            let (ev, phase) = sample_media::<HET, HOM, EMIT, ABS, CHROM, MIX>(
                rs,
                &ray,
                t0,
                t_hit,
                media.top(),
                beta,
                Flight {
                    cfg,
                    rng: &mut sampler.rng,
                    stats: &mut stats.media,
                    l: &mut l,
                },
            );
            sampler.rng.clear_queue();
            if collisions(&stats.media) - start_collisions > limits.max_collisions {
                stats.guard_fired += 1;
                break;
            }
            match ev {
                MediumEvent::Absorb => break,
                MediumEvent::Escape { weight } => beta *= weight,
                MediumEvent::Scatter { t, weight } => {
                    beta *= weight;
                    // A zero throughput (absorption as a weight in an albedo-0 medium) ends
                    // the path before it counts as a bounce, as an absorption event would.
                    if beta == Vec3::ZERO {
                        break;
                    }
                    depth += 1;
                    flight_started = false;
                    if depth > limits.max_depth {
                        break;
                    }
                    let p = ray.at(t);
                    let wo = -ray.d;
                    // Next-event estimation with the phase function.
                    let (ld, choice) = next_event::<SURF, HET, HOM, CHROM, MIX>(
                        rs,
                        cfg,
                        Vertex {
                            p,
                            media,
                            phase: limits.guided_lights.then_some((
                                &phase,
                                wo,
                                limits.continuation_albedo,
                            )),
                        },
                        sampler,
                        depth - 1,
                        &mut stats.media,
                        |wi| {
                            let f = phase.p(wo, wi);
                            (Vec3::splat(f), f)
                        },
                    );
                    l += beta * ld;
                    prev_env = choice;
                    let ps = phase.sample(wo, sampler.get2d(bounce_dim(depth - 1, DIM_SCATTER)));
                    beta *= ps.weight;
                    ray = Ray::new(p, ps.wi);
                    t0 = 0.0;
                    prev_pdf = ps.pdf;
                    specular = false;
                    let rr = &mut Decision::new(sampler, bounce_dim(depth - 1, DIM_RR));
                    if !russian_roulette(&mut beta, depth, limits, rr) {
                        break;
                    }
                    stats.max_beta = stats.max_beta.max(beta.max_element());
                    continue;
                }
            }
        }
        let Some(h) = hit else {
            if let Some(env) = &rs.lights.environment {
                let w = if specular {
                    1.0
                } else if prev_env.by_phase {
                    // Both strategies drew this direction from the phase function: the light
                    // pdf is P_env times the continuation's.
                    power_heuristic(1.0, prev_env.pmf)
                } else {
                    power_heuristic(prev_pdf, prev_env.pmf * env.pdf(ray.d))
                };
                l += beta * env.le(ray.d) * w;
            }
            break;
        };
        let p = ray.at(h.t);
        let wo = -ray.d;
        let tri = &scene.triangles[h.triangle as usize];
        let mat_index = scene.instances[tri.instance as usize].material as usize;
        let mat = &scene.materials[mat_index];
        let [a, b, c] = scene.triangle_corners(h.triangle as usize);
        let ng = (b - a).cross(c - a).normalize_or_zero();
        let cos_o = ng.dot(wo);
        let uv = scene.material_uv(mat, h.triangle as usize, h.b1, h.b2);
        if mat.emission != [0.0; 3] {
            let le = emitted(scene, mat, uv, cos_o);
            if le != Vec3::ZERO {
                let w = if specular {
                    1.0
                } else {
                    power_heuristic(prev_pdf, rs.lights.pdf_area(scene, h.triangle, h.t, cos_o))
                };
                l += beta * le * w;
            }
        }
        match rs.kinds[mat_index] {
            SurfaceKind::Null => {
                if HOM {
                    media.cross(mat.interior_medium, cos_o > 0.0);
                }
                t0 = h.t + 1e-4 * (1.0 + h.t);
                continue;
            }
            SurfaceKind::Dielectric => {
                depth += 1;
                flight_started = false;
                if depth > limits.max_depth {
                    break;
                }
                let entering = cos_o > 0.0;
                let n = if entering { ng } else { -ng };
                let eta = if entering { mat.ior } else { 1.0 / mat.ior };
                let f = fresnel_dielectric(n.dot(wo), eta);
                let wi = if sampler.get1d(bounce_dim(depth - 1, DIM_LOBE)) < f {
                    2.0 * n.dot(wo) * n - wo
                } else {
                    match refract(wo, n, eta) {
                        Some(wt) => {
                            // Radiance is compressed by eta^2 entering a denser medium.
                            beta *= scene.base_color_at(mat, uv) / (eta * eta);
                            if HOM {
                                media.cross(mat.interior_medium, entering);
                            }
                            wt
                        }
                        None => 2.0 * n.dot(wo) * n - wo,
                    }
                };
                ray = Ray::new(offset(p, ng, wi), wi);
                t0 = 0.0;
                specular = true;
            }
            SurfaceKind::Opaque => {
                depth += 1;
                flight_started = false;
                if depth > limits.max_depth {
                    break;
                }
                let n_side = if cos_o >= 0.0 { ng } else { -ng };
                let ns = shading_normal(rs, h.triangle as usize, h.b1, h.b2, n_side);
                let frame = Frame::from_z(ns);
                let bsdf =
                    Principled::new(scene.base_color_at(mat, uv), mat.metallic, mat.roughness);
                let wo_l = frame.to_local(wo);
                let p_off = offset(p, n_side, n_side);
                let (ld, choice) = next_event::<SURF, HET, HOM, CHROM, MIX>(
                    rs,
                    cfg,
                    Vertex {
                        p: p_off,
                        media,
                        phase: None,
                    },
                    sampler,
                    depth - 1,
                    &mut stats.media,
                    |wi| {
                        if n_side.dot(wi) <= 0.0 {
                            return (Vec3::ZERO, 0.0);
                        }
                        let wi_l = frame.to_local(wi);
                        (bsdf.eval(wo_l, wi_l) * wi_l.z.abs(), bsdf.pdf(wo_l, wi_l))
                    },
                );
                l += beta * ld;
                prev_env = choice;
                let u_lobe = sampler.get1d(bounce_dim(depth - 1, DIM_LOBE));
                let u_dir = sampler.get2d(bounce_dim(depth - 1, DIM_SCATTER));
                let Some(s) = bsdf.sample(wo_l, u_lobe, u_dir) else {
                    break;
                };
                let wi = frame.from_local(s.wi);
                if n_side.dot(wi) <= 0.0 {
                    break;
                }
                beta *= s.weight;
                ray = Ray::new(p_off, wi);
                t0 = 0.0;
                prev_pdf = s.pdf;
                specular = false;
            }
        }
        let rr = &mut Decision::new(sampler, bounce_dim(depth - 1, DIM_RR));
        if !russian_roulette(&mut beta, depth, limits, rr) {
            break;
        }
        stats.max_beta = stats.max_beta.max(beta.max_element());
    }
    stats.depth += depth as u64;
    l
}

/// Interpolated vertex normal on `side`'s hemisphere; the geometric normal when the file
/// gave none.
fn shading_normal(rs: &RenderScene, t: usize, b1: f32, b2: f32, side: Vec3) -> Vec3 {
    let v = rs.scene.triangles[t].vertices;
    let n = |i: usize| Vec3::from(rs.scene.vertices[v[i] as usize].normal);
    let ns = (n(0) * (1.0 - b1 - b2) + n(1) * b1 + n(2) * b2).normalize_or_zero();
    if ns == Vec3::ZERO {
        side
    } else if ns.dot(side) < 0.0 {
        -ns
    } else {
        ns
    }
}

/// Unbiased Russian roulette on the throughput after `rr_depth` events, or earlier once the
/// throughput's largest channel is below `rr_throughput` (a path darkened by absorption
/// weights): survive with probability `min(sqrt(max(beta)), 0.95)`, then divide by it.
///
/// The square root (Cycles' `path_state_continuation_probability`) kills fewer dim paths than
/// `max(beta)` itself: a survivor's weight grows to `sqrt(max(beta))` instead of 1, which is
/// still at most 1, so the bound on the throughput is unchanged. It pays most in dark media,
/// where every bounce meets the roulette (`brume bench peers` on the dark scenes of
/// `scenes/ablation/`).
fn russian_roulette(beta: &mut Vec3, depth: u32, limits: &PathLimits, rng: &mut Decision) -> bool {
    let q = beta.abs().max_element();
    if depth < limits.rr_depth && !(q < limits.rr_throughput) {
        return true;
    }
    let q = q.sqrt().min(0.95);
    if !(q > 0.0) || rng.uniform_f32() >= q {
        return false;
    }
    *beta /= q;
    true
}
