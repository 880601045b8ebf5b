//! The CPU reference path tracer: one camera sample in, radiance out. Written for clarity
//! first; every physics step calls the shared routines (`media`, `lights`, `bsdf`,
//! `volume::tracking`). The type parameter `F` is the scene's features
//! ([`Features`], from [`crate::render::prepare::FeatureFlags`]): a `false` removes that code
//! from the compiled loop.
use glam::{Vec2, Vec3};

use super::bsdf::{fresnel_dielectric, refract, Principled};
use super::emitters::emitter_event;
use super::equiangular::{distance_weight, equiangular_estimate, media_extent};
use super::features::Features;
use super::flight::media_flight;
use super::media::{EmissionMis, Emitted, Flight, MediumEvent};
use super::next_event::{next_event, EnvChoice, Vertex};
use super::path_state::{group_of, PathState, ALBEDO, BACKGROUND, DEPTH, EMISSION, NORMAL};
pub use super::path_state::{PathLimits, BACKGROUND_DEPTH, DATA_PASS_COUNT, LIGHT_PASS_COUNT};
use crate::accel::Hit;
use crate::math::Ray;
use crate::render::light_groups::MAX_LIGHT_GROUPS;
use crate::render::lights::{emitted, power_heuristic, LightSource};
use crate::render::media::{MediaStats, TrackingConfig};
use crate::render::prepare::{RenderScene, SurfaceKind};
use crate::render::settings::VolumeSampling;
use crate::render::stack::MediumStack;
use crate::sampling::sobol::{bounce_dim, DIM_DISTANCE, DIM_LOBE, DIM_RR, DIM_SCATTER, DIM_TIME};
use crate::sampling::warp::Frame;
use crate::sampling::{Decision, Sampler};
use crate::volume::phases::Phase;

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

/// What one camera sample brings its pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSample {
    /// Radiance, W m^-2 sr^-1 per RGB channel.
    pub l: Vec3,
    /// Coverage: 1 minus the path's transmittance to the background (Cycles' alpha, from the
    /// throughput's channel mean where the camera ray escapes unscattered).
    pub alpha: f32,
    /// The radiance by light pass (`film::passes::LIGHT_PASSES` order), where
    /// `PathLimits::light_passes` asks for them; they add up to `l` to the float rounding.
    pub passes: [Vec3; LIGHT_PASS_COUNT],
    /// Albedo, normal and depth (`film::passes::DATA_PASSES` order), where
    /// `PathLimits::data_passes` asks for them.
    pub data: [Vec3; DATA_PASS_COUNT],
    /// The radiance by light group (`RenderScene::groups` order), where
    /// `PathLimits::light_groups` asks for them; they add up to `l` to the float rounding.
    pub groups: [Vec3; MAX_LIGHT_GROUPS],
}

impl CameraSample {
    /// Radiance and coverage as the film's channels (R, G, B, A).
    pub fn rgba(&self) -> [f32; 4] {
        [self.l.x, self.l.y, self.l.z, self.alpha]
    }

    /// Every channel times `w`: the sample's weight under glow sampling (`glow`).
    pub fn scale(&mut self, w: f32) {
        self.l *= w;
        self.alpha *= w;
        let channels = self.passes.iter_mut().chain(&mut self.data);
        for v in channels.chain(&mut self.groups) {
            *v *= w;
        }
    }
}

/// How a path scatters after shading, for [`sample_phase`] to draw the next direction.
enum Scatterer {
    /// At a medium event at `p`: the phase function and `wo`.
    Phase { phase: Phase, p: Vec3, wo: Vec3 },
    /// At an opaque surface: its BSDF in the shading frame, `wo` there, the offset origin and
    /// the side's normal (a direction below it ends the path).
    Bsdf {
        bsdf: Principled,
        frame: Frame,
        wo_l: Vec3,
        p_off: Vec3,
        n_side: Vec3,
    },
    /// A smooth dielectric already chose the ray (reflection or refraction).
    Chosen,
}

/// What a medium flight left the path to do.
enum FlightEnd {
    /// No real collision before the surface (or the escape): shade it.
    Passed,
    /// A real scattering event at `t` with the medium's phase function.
    Scattered { t: f32, phase: Phase },
    /// Absorbed, zero throughput, or stopped by the collision guard.
    Ended,
}

/// What shading a surface left the path to do.
enum SurfaceEnd {
    /// A null interface: the ray goes on from just past it (no bounce).
    Crossed,
    Scatters(Scatterer),
    Ended,
}

fn collisions(s: &MediaStats) -> u64 {
    s.tracking.null_collisions + s.tracking.real_collisions + s.tracking.control_collisions
}

/// Radiance along the camera ray through film point `film` (in [0,1]^2): the stages of the GPU
/// wavefront (`shaders/stages/`, `backend::gpu::graph::Stage`) run in turn for one path.
pub fn radiance<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    limits: &PathLimits,
    film: Vec2,
    aspect: f32,
    sampler: &mut Sampler,
    stats: &mut PathStats,
) -> CameraSample {
    // A blurred scene's sample sees one instant of the shutter, drawn from its own dimension.
    let timed;
    let cfg = match rs.shutter {
        Some(shutter) => {
            timed = cfg.at_time(shutter.time(sampler.get1d(DIM_TIME)));
            &timed
        }
        None => cfg,
    };
    let mut ps = generate::<F>(rs, film, aspect, cfg.time);
    let start_collisions = collisions(&stats.media);
    loop {
        let hit = intersect::<F>(rs, &ps, cfg.time);
        if F::HET || F::HOM {
            let t_hit = hit.map_or(f32::INFINITY, |h| h.t);
            let end = sample_medium::<F>(
                rs,
                cfg,
                limits,
                &mut ps,
                t_hit,
                sampler,
                stats,
                start_collisions,
            );
            match end {
                FlightEnd::Ended => break,
                FlightEnd::Passed => {}
                FlightEnd::Scattered { t, phase } => {
                    let Some(scatterer) =
                        scatter_medium::<F>(rs, cfg, limits, &mut ps, t, phase, sampler, stats)
                    else {
                        break;
                    };
                    if !sample_phase(limits, &mut ps, scatterer, sampler, stats) {
                        break;
                    }
                    continue;
                }
            }
        }
        let Some(h) = hit else {
            escape(rs, limits, &mut ps);
            break;
        };
        match shade_surface::<F>(rs, cfg, limits, &mut ps, h, sampler, stats) {
            SurfaceEnd::Crossed => continue,
            SurfaceEnd::Ended => break,
            SurfaceEnd::Scatters(scatterer) => {
                if !sample_phase(limits, &mut ps, scatterer, sampler, stats) {
                    break;
                }
            }
        }
    }
    stats.depth += ps.depth as u64;
    CameraSample {
        l: ps.l,
        alpha: 1.0 - ps.background,
        passes: ps.passes,
        data: ps.data,
        groups: ps.groups,
    }
}

/// The camera ray through `film` at time offset `time` and the path's starting state
/// (`Stage::Generate`).
#[inline(always)]
fn generate<F: Features>(rs: &RenderScene, film: Vec2, aspect: f32, time: f32) -> PathState {
    let (ray, t0) = rs.pinhole_at(time).primary_ray(film.x, film.y, aspect);
    PathState {
        ray,
        t0,
        media: if F::HOM {
            rs.camera_media
        } else {
            MediumStack::EMPTY
        },
        beta: Vec3::ONE,
        l: Vec3::ZERO,
        depth: 0,
        flight_started: false,
        specular: true,
        prev_pdf: 0.0,
        prev_env: EnvChoice {
            pmf: rs.lights.uniform_env_pmf(),
            by_phase: false,
        },
        background: 0.0,
        passes: [Vec3::ZERO; LIGHT_PASS_COUNT],
        first_in_medium: false,
        data: [Vec3::ZERO; DATA_PASS_COUNT],
        albedo_seen: false,
        depth_seen: false,
        groups: [Vec3::ZERO; MAX_LIGHT_GROUPS],
        segment: None,
    }
}

/// The first surface along the path's ray at time offset `dt` (`Stage::Intersect`).
#[inline(always)]
fn intersect<F: Features>(rs: &RenderScene, ps: &PathState, dt: f32) -> Option<Hit> {
    if F::SURF {
        rs.scene.closest_hit(&ps.ray, ps.t0, f32::INFINITY, dt)
    } else {
        None
    }
}

/// The free flight up to the surface at `t_hit` through the media the ray is in or crosses,
/// gathering their emission (`Stage::SampleMedium`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sample_medium<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    limits: &PathLimits,
    ps: &mut PathState,
    t_hit: f32,
    sampler: &mut Sampler,
    stats: &mut PathStats,
    start_collisions: u64,
) -> FlightEnd {
    // The equiangular estimate over the flight's span comes first, from the path's stream:
    // it needs only the span, and the GPU runs it in a stage of its own before the flight.
    ps.segment = None;
    if limits.volume_sampling != VolumeSampling::Distance && ps.depth < limits.max_depth {
        equiangular::<F>(rs, cfg, limits, ps, t_hit, sampler, stats);
    }
    // The first flight after each scattering event starts from the sampler's stratified
    // point; one continued past a null interface does not reuse it.
    if !ps.flight_started {
        sampler.queue_on_stream(bounce_dim(ps.depth, DIM_DISTANCE));
        ps.flight_started = true;
    }
    let before = ps.l;
    let (ev, phase) = media_flight::<F>(
        rs,
        &ps.ray,
        ps.t0,
        t_hit,
        ps.media.top(),
        ps.beta,
        Flight {
            cfg,
            rng: &mut sampler.rng,
            stats: &mut stats.media,
            l: Emitted {
                l: &mut ps.l,
                groups: limits.light_groups.then_some(&mut ps.groups),
                // After a scattering event, emission is weighed against the media lights.
                mis: rs
                    .media_lights
                    .as_ref()
                    .filter(|_| !ps.specular)
                    .map(|lights| EmissionMis {
                        lights,
                        pdf_dir: ps.prev_pdf,
                    }),
            },
        },
    );
    if limits.light_passes {
        // The flight's emission, as the radiance took it (to the float rounding).
        let k = ps.pass_of(EMISSION);
        ps.passes[k] += ps.l - before;
    }
    sampler.rng.clear_queue();
    if collisions(&stats.media) - start_collisions > limits.max_collisions {
        stats.guard_fired += 1;
        return FlightEnd::Ended;
    }
    match ev {
        MediumEvent::Absorb => FlightEnd::Ended,
        MediumEvent::Escape { weight } => {
            ps.beta *= weight;
            FlightEnd::Passed
        }
        MediumEvent::Scatter { t, weight } => {
            ps.beta *= weight;
            // A zero throughput (absorption as a weight in an albedo-0 medium) ends the path
            // before it counts as a bounce, as an absorption event would.
            if ps.beta == Vec3::ZERO {
                FlightEnd::Ended
            } else {
                FlightEnd::Scattered { t, phase }
            }
        }
    }
}

/// The equiangular strategy's estimate over the flight up to `t_hit` (`integrator::equiangular`),
/// gathered as the next event's, with the path's throughput before the flight.
#[inline(never)]
fn equiangular<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    limits: &PathLimits,
    ps: &mut PathState,
    t_hit: f32,
    sampler: &mut Sampler,
    stats: &mut PathStats,
) {
    ps.segment = media_extent::<F>(rs, &ps.ray, ps.t0, t_hit, ps.media);
    let Some(seg) = &ps.segment else {
        return;
    };
    let mode = limits.volume_sampling;
    let rng = &mut sampler.rng;
    if let Some((l, source)) = equiangular_estimate::<F>(rs, cfg, mode, seg, rng, &mut stats.media)
    {
        if l != Vec3::ZERO {
            let group = group_of(rs, Some(source));
            ps.gather_next(limits, ps.beta * l, group);
        }
    }
}

/// Next-event estimation towards the emitting media from the event at `p`
/// (`integrator::emitters`), gathered as the event's.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn emitters<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    limits: &PathLimits,
    ps: &mut PathState,
    p: Vec3,
    sampler: &mut Sampler,
    stats: &mut PathStats,
    scatter: impl Fn(Vec3) -> (Vec3, f32),
) {
    let rng = &mut sampler.rng;
    if let Some((l, source)) =
        emitter_event::<F>(rs, cfg, p, ps.media, rng, &mut stats.media, scatter)
    {
        ps.gather(limits, ps.beta * l, EMISSION, group_of(rs, Some(source)));
    }
}

/// The depth limit and next-event estimation with the phase function at a medium scattering
/// event at `t` (`Stage::ScatterMedium`). `None` ends the path.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn scatter_medium<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    limits: &PathLimits,
    ps: &mut PathState,
    t: f32,
    phase: Phase,
    sampler: &mut Sampler,
    stats: &mut PathStats,
) -> Option<Scatterer> {
    ps.depth += 1;
    ps.flight_started = false;
    if ps.depth > limits.max_depth {
        return None;
    }
    if ps.depth == 1 {
        ps.first_in_medium = true;
    }
    if limits.data_passes && !ps.albedo_seen {
        // Cycles' volume features: the throughput past the event's albedo, and the view
        // direction as normal; a camera ray that scatters first sees no surface (depth 0).
        ps.data[ALBEDO] = ps.beta;
        ps.data[NORMAL] = -ps.ray.d;
        ps.albedo_seen = true;
        ps.depth_seen = true;
    }
    let p = ps.ray.at(t);
    let wo = -ps.ray.d;
    let guided = limits
        .guided_lights
        .then_some((&phase, wo, limits.continuation_albedo));
    let scatter = |wi| {
        let f = phase.p(wo, wi);
        (Vec3::splat(f), limits.lamps.mixture_pdf(p, wi, f))
    };
    let (mut ld, choice, source) = next_event::<F>(
        rs,
        cfg,
        Vertex {
            p,
            media: ps.media,
            phase: guided,
        },
        sampler,
        ps.depth - 1,
        &mut stats.media,
        scatter,
    );
    if let Some(seg) = &ps.segment {
        ld *= distance_weight::<F>(rs, cfg, limits.volume_sampling, seg, t, source);
    }
    ps.gather(limits, ps.beta * ld, EMISSION, group_of(rs, source));
    ps.prev_env = choice;
    if F::EMIT {
        emitters::<F>(rs, cfg, limits, ps, p, sampler, stats, scatter);
    }
    Some(Scatterer::Phase { phase, p, wo })
}

/// Emission `le` of the surface hit `h` (cosine `cos_o` towards the path), weighed against
/// the area lights' sampling unless a delta distribution chose the ray.
#[inline(always)]
fn surface_emission(
    rs: &RenderScene,
    limits: &PathLimits,
    ps: &mut PathState,
    h: Hit,
    le: Vec3,
    cos_o: f32,
) {
    if le == Vec3::ZERO {
        return;
    }
    let w = if ps.specular {
        1.0
    } else {
        power_heuristic(
            ps.prev_pdf,
            rs.lights.pdf_area(rs.scene, h.triangle, h.t, cos_o),
        )
    };
    let group = rs.light_group(LightSource::Area);
    ps.gather(limits, ps.beta * le * w, EMISSION, group);
}

/// Emission, null interfaces, smooth dielectrics and next-event estimation at opaque surfaces
/// (`Stage::ShadeSurface`).
#[inline(always)]
fn shade_surface<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    limits: &PathLimits,
    ps: &mut PathState,
    h: Hit,
    sampler: &mut Sampler,
    stats: &mut PathStats,
) -> SurfaceEnd {
    let scene = rs.scene;
    let p = ps.ray.at(h.t);
    let wo = -ps.ray.d;
    let mat_index =
        scene.instances[scene.triangle_instance(h.triangle as usize) as usize].material as usize;
    let mat = &scene.materials[mat_index];
    let [a, b, c] = scene.triangle_corners_at(h.triangle as usize, cfg.time);
    let ng = (b - a).cross(c - a).normalize_or_zero();
    let cos_o = ng.dot(wo);
    let uv = scene.material_uv(mat, h.triangle as usize, h.b1, h.b2);
    if mat.emission != [0.0; 3] {
        surface_emission(rs, limits, ps, h, emitted(scene, mat, uv, cos_o), cos_o);
    }
    let kind = rs.kinds[mat_index];
    if kind == SurfaceKind::Null {
        if F::HOM {
            ps.media.cross(mat.interior_medium, cos_o > 0.0);
        }
        ps.t0 = h.t + 1e-4 * (1.0 + h.t);
        return SurfaceEnd::Crossed;
    }
    if limits.data_passes && !ps.depth_seen {
        // The camera ray's first surface: its camera-space Z (Cycles' Z pass).
        ps.data[DEPTH] = Vec3::splat((p - rs.pinhole.position).dot(rs.pinhole.forward));
        ps.depth_seen = true;
    }
    ps.depth += 1;
    ps.flight_started = false;
    if ps.depth > limits.max_depth {
        return SurfaceEnd::Ended;
    }
    if kind == SurfaceKind::Dielectric {
        let entering = cos_o > 0.0;
        let n = if entering { ng } else { -ng };
        let eta = if entering { mat.ior } else { 1.0 / mat.ior };
        let f = fresnel_dielectric(n.dot(wo), eta);
        let wi = if sampler.get1d(bounce_dim(ps.depth - 1, DIM_LOBE)) < f {
            2.0 * n.dot(wo) * n - wo
        } else {
            match refract(wo, n, eta) {
                Some(wt) => {
                    // Radiance is compressed by eta^2 entering a denser medium.
                    ps.beta *= scene.base_color_at(mat, uv) / (eta * eta);
                    if F::HOM {
                        ps.media.cross(mat.interior_medium, entering);
                    }
                    wt
                }
                None => 2.0 * n.dot(wo) * n - wo,
            }
        };
        ps.ray = Ray::new(offset(p, ng, wi), wi);
        ps.t0 = 0.0;
        ps.specular = true;
        return SurfaceEnd::Scatters(Scatterer::Chosen);
    }
    let n_side = if cos_o >= 0.0 { ng } else { -ng };
    let ns = shading_normal(rs, h.triangle as usize, h.b1, h.b2, n_side, cfg.time);
    let frame = Frame::from_z(ns);
    let base_color = scene.base_color_at(mat, uv);
    if limits.data_passes && !ps.albedo_seen {
        ps.data[ALBEDO] = ps.beta * base_color;
        ps.data[NORMAL] = ns;
        ps.albedo_seen = true;
    }
    let bsdf = Principled::new(base_color, mat.metallic, mat.roughness);
    let wo_l = frame.to_local(wo);
    let p_off = offset(p, n_side, n_side);
    let scatter = |wi: Vec3| {
        if n_side.dot(wi) <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let wi_l = frame.to_local(wi);
        let pdf = limits
            .lamps
            .surface_mixture_pdf(p_off, wi, bsdf.pdf(wo_l, wi_l));
        (bsdf.eval(wo_l, wi_l) * wi_l.z.abs(), pdf)
    };
    let (ld, choice, source) = next_event::<F>(
        rs,
        cfg,
        Vertex {
            p: p_off,
            media: ps.media,
            phase: None,
        },
        sampler,
        ps.depth - 1,
        &mut stats.media,
        scatter,
    );
    ps.gather(limits, ps.beta * ld, EMISSION, group_of(rs, source));
    ps.prev_env = choice;
    if F::EMIT {
        emitters::<F>(rs, cfg, limits, ps, p_off, sampler, stats, scatter);
    }
    SurfaceEnd::Scatters(Scatterer::Bsdf {
        bsdf,
        frame,
        wo_l,
        p_off,
        n_side,
    })
}

/// The next direction (phase function or BSDF) and Russian roulette (`Stage::SamplePhase`).
/// `false` ends the path.
#[inline(always)]
fn sample_phase(
    limits: &PathLimits,
    ps: &mut PathState,
    scatterer: Scatterer,
    sampler: &mut Sampler,
    stats: &mut PathStats,
) -> bool {
    // The roulette reads the throughput the direction would carry under the phase function or
    // BSDF alone where the lamps' cones drew it more often (`rr_scale`, 1 without cones).
    let mut rr_scale = 1.0;
    match scatterer {
        Scatterer::Phase { phase, p, wo } => {
            let u = sampler.get2d(bounce_dim(ps.depth - 1, DIM_SCATTER));
            let s = if limits.lamps.count == 0 {
                phase.sample(wo, u, &mut || sampler.rng.uniform_vec2())
            } else {
                // glow::Lamps: a share of the directions drawn towards lamps inside media.
                let u_c = sampler.rng.uniform_f32();
                let more = &mut || sampler.rng.uniform_vec2();
                let s = limits.lamps.sample_phase(&phase, p, wo, u, u_c, more);
                rr_scale = cone_scale(s.pdf, phase.p(wo, s.wi));
                s
            };
            ps.beta *= s.weight;
            ps.ray = Ray::new(p, s.wi);
            ps.t0 = 0.0;
            ps.prev_pdf = s.pdf;
            ps.specular = false;
        }
        Scatterer::Bsdf {
            bsdf,
            frame,
            wo_l,
            p_off,
            n_side,
        } => {
            let u_lobe = sampler.get1d(bounce_dim(ps.depth - 1, DIM_LOBE));
            let u_dir = sampler.get2d(bounce_dim(ps.depth - 1, DIM_SCATTER));
            let s = if !limits.lamps.guides_surfaces() {
                bsdf.sample(wo_l, u_lobe, u_dir)
            } else {
                // glow::Lamps: a share of the directions drawn towards lamps inside media and
                // towards the media that emitting media light.
                let u_c = sampler.rng.uniform_f32();
                limits
                    .lamps
                    .sample_bsdf(&bsdf, &frame, wo_l, p_off, (u_lobe, u_dir), u_c)
                    .inspect(|s| rr_scale = cone_scale(s.pdf, bsdf.pdf(wo_l, s.wi)))
            };
            let Some(s) = s else {
                return false;
            };
            let wi = frame.from_local(s.wi);
            if n_side.dot(wi) <= 0.0 {
                return false;
            }
            ps.beta *= s.weight;
            ps.ray = Ray::new(p_off, wi);
            ps.t0 = 0.0;
            ps.prev_pdf = s.pdf;
            ps.specular = false;
        }
        Scatterer::Chosen => {}
    }
    let rr = &mut Decision::new(sampler, bounce_dim(ps.depth - 1, DIM_RR));
    if !russian_roulette(&mut ps.beta, rr_scale, ps.depth, limits, rr) {
        return false;
    }
    stats.max_beta = stats.max_beta.max(ps.beta.max_element());
    true
}

/// The environment's light for a ray that leaves the scene, MIS-weighted against how the last
/// event chose its light (`Stage::Escape`). A camera ray escaping unscattered records its
/// transmittance to the background (the coverage) and, on a transparent film, gathers nothing.
#[inline(always)]
fn escape(rs: &RenderScene, limits: &PathLimits, ps: &mut PathState) {
    // Seen straight through, the sky is the background, which a transparent film leaves out.
    let seen_straight = ps.depth == 0;
    let gathers = !(seen_straight && limits.film_transparent);
    // One lookup of the sky's radiance, for the radiance and the albedo pass alike.
    let env = rs.lights.environment.as_ref().filter(|_| gathers);
    let le = env.map(|e| e.le(ps.ray.d));
    if limits.data_passes && !ps.depth_seen {
        ps.data[DEPTH] = Vec3::splat(BACKGROUND_DEPTH);
        ps.depth_seen = true;
    }
    if limits.data_passes && !ps.albedo_seen && gathers {
        // The sky seen (through smooth dielectrics at most) is its own albedo, as Cycles
        // gives it to the denoiser.
        if let Some(le) = le {
            ps.data[ALBEDO] = ps.beta * le;
        }
        ps.albedo_seen = true;
    }
    if seen_straight {
        ps.background = ps.beta.element_sum() / 3.0;
    }
    let (Some(env), Some(le)) = (env, le) else {
        return;
    };
    let w = if ps.specular {
        1.0
    } else if ps.prev_env.by_phase {
        // Both strategies drew this direction from the phase function: the light pdf is
        // P_env times the continuation's.
        power_heuristic(1.0, ps.prev_env.pmf)
    } else {
        power_heuristic(ps.prev_pdf, ps.prev_env.pmf * env.pdf(ps.ray.d))
    };
    let group = rs.light_group(LightSource::Environment);
    ps.gather(limits, ps.beta * le * w, BACKGROUND, group);
}

/// Interpolated vertex normal on `side`'s hemisphere; the geometric normal when the file
/// gave none.
fn shading_normal(rs: &RenderScene, t: usize, b1: f32, b2: f32, side: Vec3, dt: f32) -> Vec3 {
    let v = rs.scene.triangle_vertices(t);
    let n = |i: usize| Vec3::from(v[i].normal);
    let mut ns = n(0) * (1.0 - b1 - b2) + n(1) * b1 + n(2) * b2;
    if let Some(f) = rs.scene.triangle_motion(t, dt) {
        // Normals map by the inverse transpose of the motion's linear part.
        ns = (f.matrix3.inverse().transpose() * glam::Vec3A::from(ns)).into();
    }
    let ns = ns.normalize_or_zero();
    if ns == Vec3::ZERO {
        side
    } else if ns.dot(side) < 0.0 {
        -ns
    } else {
        ns
    }
}

/// `russian_roulette`'s scale for a direction of mixture density `pdf` whose phase function
/// or BSDF alone has density `pdf_alone` there: their ratio, at least 1.
#[inline(always)]
fn cone_scale(pdf: f32, pdf_alone: f32) -> f32 {
    if pdf_alone > 0.0 {
        (pdf / pdf_alone).max(1.0)
    } else {
        1.0
    }
}

/// The first event after which the early roulette (`PathLimits::rr_throughput`) may end a
/// path. The early roulette stands in for the analog absorption that weighted collisions
/// replace, which pays in long chains of events in a dark medium; a path's first two events
/// are where a dim throughput still finds most of its light. The floor under a fire (albedo
/// 0.2) is lit in part by the smoke its bounces reach, and the smoke (albedo 0.3) by the flame
/// just past it: rouletted after either event, the survivors' weights double that light's
/// second moment (`brume bench peers scenes/fire.gltf`, `brume-no-rr-guard`).
pub const EARLY_RR_DEPTH: u32 = 3;

/// Unbiased Russian roulette on the throughput after `rr_depth` events, or earlier, from the
/// [`EARLY_RR_DEPTH`]th event on, once the throughput's largest channel is below
/// `rr_throughput` (a path darkened by absorption weights): survive with probability
/// `min(sqrt(max(beta)), 0.95)`, then divide by it.
///
/// The square root (Cycles' `path_state_continuation_probability`) kills fewer dim paths than
/// `max(beta)` itself: a survivor's weight grows to `sqrt(max(beta))` instead of 1, which is
/// still at most 1, so the bound on the throughput is unchanged. It pays most in dark media,
/// where every bounce meets the roulette (`brume bench peers` on the dark scenes of
/// `scenes/ablation/`).
///
/// The throughput it reads is `beta` times `scale`: how much more often the lamps' cones drew
/// the direction than the phase function or BSDF would have. A direction that passes a lamp
/// carries a small `beta` because its density is large, and the light it then meets grows as
/// that density does; judged by `beta` alone it would be killed and its survivors weighted up
/// into fireflies. Any survival probability keeps the estimate unbiased.
fn russian_roulette(
    beta: &mut Vec3,
    scale: f32,
    depth: u32,
    limits: &PathLimits,
    rng: &mut Decision,
) -> bool {
    let q = beta.abs().max_element() * scale;
    let early = depth >= EARLY_RR_DEPTH && q < limits.rr_throughput;
    if depth < limits.rr_depth && !early {
        return true;
    }
    let q = q.sqrt().min(0.95);
    if !(q > 0.0) || rng.uniform_f32() >= q {
        return false;
    }
    *beta /= q;
    true
}
