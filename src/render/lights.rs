//! Light sampling for next-event estimation: punctual lights (delta), the environment
//! (constant or mapped, see [`super::envmap`]) and emissive triangles, one chosen per
//! estimate: uniformly, or at a medium scattering event by each light's unoccluded
//! contribution ([`Lights::phase_selection`]).
//!
//! Guided selection at medium events (scenes without area lights, at most
//! [`GUIDED_MAX_PUNCTUAL`] punctual lights): light `k` is chosen with probability
//!
//! ```text
//! q_k = w_k (1 - s) / sum_j w_j + s / n,     s = GUIDED_UNIFORM_SHARE, n = lights
//! w_k = lum(L_k(x)) p(wo, wi_k)              punctual: irradiance or I / r^2 (spot falloff)
//! w_env = lum(mean environment radiance)     (the phase function integrates to 1)
//! ```
//!
//! the next-event estimate divides by its probability, so it stays unbiased for any positive
//! weights (the uniform share keeps every light reachable whatever the weights say); the
//! weights only ignore occlusion. Where the phase function toward a sun is large, the sun is
//! chosen more often; looking away from it, the sky is. This is the light-tree idea of Cycles
//! (importance from emitted power and orientation) reduced to the few lights of a volume
//! scene, with the phase function in place of the BSDF bound.
//!
//! A constant environment is then mostly LEFT TO THE CONTINUATION RAY:
//!
//! ```text
//! P_env = (1 - a) q_env                      a = Lights::continuation_albedo
//! P_k   = q_k (1 + a q_env / sum_punctual q) the rest goes to the punctual lights
//! P_none = a q_env                           (no punctual light: no estimate)
//! ```
//!
//! Sampled at a medium event, a constant environment's best direction density is the phase
//! function itself (uniform sphere directions waste most samples on a g = 0.5 lobe), and that
//! is exactly how the continuation ray leaves the event: the two strategies draw the same
//! directions, and MIS between them (power heuristic, constant ratio `P_env`) cannot beat the
//! continuation alone by much. What next-event estimation adds is a smoother transmittance
//! (ratio tracking instead of escaping or not), and what the continuation adds is the
//! furnace property: in a medium of albedo `a` near 1 under a uniform sky, the path's weight
//! barely varies whatever it does. So the shadow ray pays where `a` is small (a dark medium,
//! where paths rarely escape), and elsewhere it is better spent on the punctual lights, whose
//! estimates are then not divided by a probability diluted by the sky. `a` is the
//! single-scattering albedo (largest channel) of the DARKEST scattering medium in the scene,
//! so no medium gets less sky estimation than it needs. Against estimating the sky at every
//! event (`--light-selection guided-full-sky`) it removes a quarter to three quarters of the
//! per-pixel variance in bright media and costs a few per cent in a dark one (`brume bench
//! peers`, docs/VALIDATION.md).
//!
//! When the environment is chosen it is sampled by the phase function, its light pdf
//! `P_env p(wo, wi)`, and the continuation ray that escapes from that event is weighted
//! against it by the power heuristic with the constant ratio `1 / (1 + P_env^2)` (1 where
//! `P_env` is 0). Surface events keep uniform selection (the BSDF is not evaluated per
//! light).
use glam::{Vec2, Vec3};

use super::envmap::luminance;
pub use super::envmap::{EnvLight, EnvSampling};
use crate::sampling::sample_discrete;
use crate::scene::lights::{LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT};
use crate::scene::{PunctualLight, Scene};

/// Emissive triangles, sampled by area times luminance of their emission.
pub struct AreaLights {
    /// Triangle indices into `Scene::triangles`.
    pub triangles: Vec<u32>,
    /// Cumulative `area * luminance`, normalised to end at 1.
    cdf: Vec<f32>,
    /// Sum of `area * luminance`.
    total: f32,
    /// `luminance(emission)` per entry of `triangles` (the pdf numerator).
    lum: Vec<f32>,
}

impl AreaLights {
    /// The selection CDF over `triangles` (cumulative `area * luminance`, ending at 1).
    pub fn cdf(&self) -> &[f32] {
        &self.cdf
    }

    /// The area density of choosing a point on entry `i` (`luminance / total`): its
    /// selection probability `area * luminance / total` over its area.
    pub fn selection_pdf(&self, i: usize) -> f32 {
        self.lum[i] / self.total
    }
}

/// A light sample seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Distance to the light (`f32::INFINITY` for directional and environment light).
    pub dist: f32,
    /// Radiance (area, environment) or radiant intensity / r^2 (point, spot) or irradiance
    /// (directional) arriving along `-wi`, before visibility.
    pub li: Vec3,
    /// Solid-angle density of `wi` times the light-selection probability; for delta lights,
    /// the selection probability alone.
    pub pdf: f32,
    pub is_delta: bool,
    /// Which light was sampled (for its light group).
    pub source: LightSource,
}

/// The light a sample came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSource {
    /// Punctual light `k` (`Lights::punctual` order).
    Punctual(u32),
    Environment,
    /// An emissive triangle.
    Area,
    /// A point of emitting medium `k` (`RenderScene::vdb` order).
    Medium(u32),
}

pub struct Lights {
    /// The punctual lights at the frame's instant.
    pub punctual: Vec<PunctualLight>,
    /// Each punctual light's motion across the shutter, where it moves: a sample at time
    /// offset `dt` sees it at that pose ([`Lights::posed`]).
    pub motion: Vec<Option<crate::scene::motion::NodeMotion>>,
    /// The point and spot lights (indices into `punctual`): those equiangular sampling aims at
    /// (`integrator::equiangular`).
    pub positional: Vec<u32>,
    /// The environment, when it emits.
    pub environment: Option<EnvLight>,
    pub area: Option<AreaLights>,
    /// `a` of the module doc for this scene: the share of a constant environment's guided
    /// selection left to the continuation ray (0 until the scene's media are known:
    /// [`Lights::set_media_albedo`]); `--light-selection guided-full-sky` passes 0 instead.
    pub continuation_albedo: f32,
}

/// Guided selection weighs at most this many punctual lights (more: uniform selection).
pub const GUIDED_MAX_PUNCTUAL: usize = 4;
/// Share of a guided selection spread uniformly over the lights (defensive mixture).
pub const GUIDED_UNIFORM_SHARE: f32 = 0.2;

/// Selection probabilities at one event: the punctual lights in order, then the environment,
/// then "no estimate" (a constant environment's share left to the continuation ray when there
/// is no punctual light to give it to); they sum to 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Selection {
    pub pmf: [f32; GUIDED_MAX_PUNCTUAL + 2],
    /// The environment's probability (0 without one).
    pub env: f32,
    /// A constant environment is sampled by the phase function (guided selection).
    pub env_by_phase: bool,
}

impl Lights {
    pub fn new(scene: &Scene) -> Lights {
        let mut tris = Vec::new();
        let mut weights = Vec::new();
        let mut lum = Vec::new();
        for (i, inst) in scene.instances.iter().enumerate() {
            let mat = &scene.materials[inst.material as usize];
            // Weighted by the mean over its emissive texture: any positive weight where the
            // emission can be non-zero keeps the estimator unbiased; the mean keeps it efficient.
            let l = scene.mean_emission_luminance(mat);
            // A moving emitter is found by paths alone: `pdf_area` is then 0 and its MIS
            // weight 1, which stays unbiased where its position depends on the sample's time.
            if !(l > 0.0) || scene.instance_moves(i as u32) {
                continue;
            }
            let first = inst.first_triangle as usize;
            for k in first..first + inst.triangle_count as usize {
                let [a, b, c] = scene.triangle_corners(k);
                let area = 0.5 * (b - a).cross(c - a).length();
                if area > 0.0 {
                    tris.push(k as u32);
                    weights.push(area * l);
                    lum.push(l);
                }
            }
        }
        let area = (!tris.is_empty()).then(|| {
            let total: f32 = weights.iter().sum();
            let mut acc = 0.0;
            let cdf = weights
                .iter()
                .map(|w| {
                    acc += w / total;
                    acc
                })
                .collect();
            AreaLights {
                triangles: tris,
                cdf,
                total,
                lum,
            }
        });
        let positional = (scene.lights.iter().enumerate())
            .filter(|(_, l)| l.kind == LIGHT_POINT || l.kind == LIGHT_SPOT)
            .map(|(k, _)| k as u32)
            .collect();
        Lights {
            positional,
            punctual: scene.lights.clone(),
            motion: scene.light_motion.clone(),
            environment: EnvLight::new(&scene.environment),
            area,
            continuation_albedo: 0.0,
        }
    }

    /// Sets [`Lights::continuation_albedo`] from the single-scattering albedos
    /// `sigma_s / sigma_t` (RGB) of the scene's scattering media: the largest channel of the
    /// darkest medium, clamped to [0, 1] (no scattering media: 0, nothing changes).
    pub fn set_media_albedo(&mut self, albedos: impl IntoIterator<Item = Vec3>) {
        let a = albedos
            .into_iter()
            .map(|a| a.max_element())
            .fold(f32::INFINITY, f32::min);
        self.continuation_albedo = if a.is_finite() {
            a.clamp(0.0, 1.0)
        } else {
            0.0
        };
    }

    /// A constant environment (guided selection samples it by the phase function and leaves
    /// most of it to the continuation ray).
    pub fn constant_environment(&self) -> bool {
        self.environment.as_ref().is_some_and(|e| e.map.is_none())
    }

    /// How many light choices there are (punctual lights, the environment, the area group).
    pub fn count(&self) -> usize {
        self.punctual.len() + self.environment.is_some() as usize + self.area.is_some() as usize
    }

    /// The probability of each light under uniform selection.
    pub fn uniform_pmf(&self) -> f32 {
        1.0 / self.count() as f32
    }

    /// Whether medium events select lights by contribution ([`Lights::phase_selection`]):
    /// no area lights, at most [`GUIDED_MAX_PUNCTUAL`] punctual lights, and at least two
    /// choices or a constant environment (which may be left to the continuation ray).
    pub fn guided(&self) -> bool {
        self.area.is_none()
            && self.punctual.len() <= GUIDED_MAX_PUNCTUAL
            && (self.count() >= 2 || self.constant_environment())
    }

    /// The uniform selection's probability of the environment (0 without one).
    pub fn uniform_env_pmf(&self) -> f32 {
        if self.environment.is_some() {
            self.uniform_pmf()
        } else {
            0.0
        }
    }

    /// The environment's selection weight: the luminance of its mean radiance (a map: its
    /// scale's luminance times the mean of its sampling function over the sphere,
    /// `(pi / 2) * integral` of the sin(theta)-weighted distribution).
    pub fn env_weight(&self) -> f32 {
        match &self.environment {
            None => 0.0,
            Some(EnvLight {
                map: None,
                radiance,
            }) => luminance(*radiance),
            Some(EnvLight { map: Some(m), .. }) => {
                luminance(m.scale) * (0.5 * std::f32::consts::PI) * m.distribution.integral
            }
        }
    }

    /// Punctual light `k` at time offset `dt`: its position and direction at that pose (the
    /// light itself, borrowed, where it stands still).
    #[inline]
    pub fn posed(&self, k: usize, dt: f32) -> std::borrow::Cow<'_, PunctualLight> {
        let Some(Some(m)) = self.motion.get(k) else {
            return std::borrow::Cow::Borrowed(&self.punctual[k]);
        };
        let mut l = self.punctual[k];
        let world = m.world_from_node(dt);
        l.position = world.transform_point3(Vec3::ZERO).to_array();
        let d = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        if d != Vec3::ZERO {
            l.direction = d.to_array();
        }
        std::borrow::Cow::Owned(l)
    }

    /// Whether some punctual light moves during the shutter.
    pub fn moving(&self) -> bool {
        self.motion.iter().any(Option::is_some)
    }

    /// Direction, distance and arriving radiant intensity / r^2 (or irradiance) of punctual
    /// light `k` at `p` at time offset `dt` (`None` at the light's own position).
    pub fn punctual_incident(&self, k: usize, p: Vec3, dt: f32) -> Option<(Vec3, f32, Vec3)> {
        let l = &*self.posed(k, dt);
        let intensity = Vec3::from(l.intensity);
        if l.kind == LIGHT_DIRECTIONAL {
            return Some((-Vec3::from(l.direction), f32::INFINITY, intensity));
        }
        let to = Vec3::from(l.position) - p;
        let d2 = to.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let mut li = intensity / d2;
        if l.kind == LIGHT_SPOT {
            li *= spot_falloff(l, -wi);
        } else {
            debug_assert_eq!(l.kind, LIGHT_POINT);
        }
        Some((wi, dist, li))
    }

    /// Punctual light `k` seen from `p`, chosen with probability `pmf`.
    fn punctual_sample(&self, k: usize, p: Vec3, pmf: f32, dt: f32) -> Option<LightSample> {
        let (wi, dist, li) = self.punctual_incident(k, p, dt)?;
        Some(LightSample {
            wi,
            dist,
            li,
            pdf: pmf,
            is_delta: true,
            source: LightSource::Punctual(k as u32),
        })
    }

    /// The selection at a medium event at `p` whose phase function takes the value
    /// `phase(wi)`, leaving the share `continuation_albedo` of a constant environment to the
    /// continuation ray (see the module doc; [`Lights::continuation_albedo`] by default);
    /// `None` when the scene is not [`Lights::guided`]. Moving lights are weighed at their pose
    /// at time offset `dt`.
    pub fn phase_selection(
        &self,
        p: Vec3,
        continuation_albedo: f32,
        phase: impl Fn(Vec3) -> f32,
        dt: f32,
    ) -> Option<Selection> {
        if !self.guided() {
            return None;
        }
        let n = self.count();
        let np = self.punctual.len();
        let mut sel = Selection {
            pmf: [0.0; GUIDED_MAX_PUNCTUAL + 2],
            env: 0.0,
            env_by_phase: false,
        };
        let mut w = [0.0f32; GUIDED_MAX_PUNCTUAL + 1];
        for (k, wk) in w.iter_mut().enumerate().take(np) {
            if let Some((wi, _, li)) = self.punctual_incident(k, p, dt) {
                *wk = luminance(li) * phase(wi);
            }
        }
        w[np] = self.env_weight();
        let sum: f32 = w[..=np].iter().sum();
        let uniform = 1.0 / n as f32;
        if sum > 0.0 && sum <= f32::MAX {
            let scale = (1.0 - GUIDED_UNIFORM_SHARE) / sum;
            let floor = GUIDED_UNIFORM_SHARE * uniform;
            for (q, &wk) in sel.pmf[..n].iter_mut().zip(&w[..n]) {
                *q = wk * scale + floor;
            }
        } else {
            sel.pmf[..n].fill(uniform);
        }
        if self.constant_environment() {
            // The continuation ray's share of the sky goes to the punctual lights, or to no
            // estimate at all.
            let q_env = sel.pmf[np];
            let moved = continuation_albedo * q_env;
            sel.pmf[np] = q_env - moved;
            let q_punctual: f32 = sel.pmf[..np].iter().sum();
            if q_punctual > 0.0 {
                let f = 1.0 + moved / q_punctual;
                sel.pmf[..np].iter_mut().for_each(|q| *q *= f);
            } else {
                sel.pmf[n] = moved;
            }
        }
        if self.environment.is_some() {
            sel.env = sel.pmf[np];
            sel.env_by_phase = self.constant_environment();
        }
        Some(sel)
    }

    /// Samples one light with the guided selection `sel` at medium point `p`: `u_select`
    /// picks the light, `u` its direction; a constant environment takes the direction and
    /// its density from `phase_sample(u)`; a moving light at its pose at time offset `dt`.
    #[allow(clippy::too_many_arguments)]
    pub fn sample_selected(
        &self,
        sel: &Selection,
        p: Vec3,
        u_select: f32,
        u: Vec2,
        mut phase_sample: impl FnMut(Vec2) -> (Vec3, f32),
        dt: f32,
    ) -> Option<LightSample> {
        let np = self.punctual.len();
        // The light by the selection's CDF, "no estimate" last; its probability is the
        // selection's own (the escape's MIS weight uses `sel.env`).
        let n = self.count();
        let k = sample_discrete(&sel.pmf[..=n], u_select)?.index;
        if k == n {
            return None;
        }
        let pmf = sel.pmf[k];
        if k < np {
            return self.punctual_sample(k, p, pmf, dt);
        }
        let env = self.environment.as_ref()?;
        if sel.env_by_phase {
            let (wi, pdf) = phase_sample(u);
            return Some(LightSample {
                wi,
                dist: f32::INFINITY,
                li: env.radiance,
                pdf: pmf * pdf,
                is_delta: false,
                source: LightSource::Environment,
            });
        }
        let s = env.sample(u)?;
        Some(LightSample {
            wi: s.wi,
            dist: f32::INFINITY,
            li: s.le,
            pdf: pmf * s.pdf,
            is_delta: false,
            source: LightSource::Environment,
        })
    }

    /// Samples one light for the shading point `p` with uniforms `u_select` and `u`.
    pub fn sample(
        &self,
        scene: &Scene,
        p: Vec3,
        u_select: f32,
        u: Vec2,
        dt: f32,
    ) -> Option<LightSample> {
        let n = self.count();
        if n == 0 {
            return None;
        }
        let pmf = self.uniform_pmf();
        let mut k = ((u_select * n as f32) as usize).min(n - 1);
        if k < self.punctual.len() {
            return self.punctual_sample(k, p, pmf, dt);
        }
        k -= self.punctual.len();
        if let Some(env) = &self.environment {
            if k == 0 {
                let s = env.sample(u)?;
                return Some(LightSample {
                    wi: s.wi,
                    dist: f32::INFINITY,
                    li: s.le,
                    pdf: pmf * s.pdf,
                    is_delta: false,
                    source: LightSource::Environment,
                });
            }
        }
        let area = self.area.as_ref()?;
        // Reuse u.x for the triangle choice and remap it, keeping u.y for the position.
        let i = area
            .cdf
            .partition_point(|&c| c <= u.x)
            .min(area.cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { area.cdf[i - 1] };
        let ux = ((u.x - lo) / (area.cdf[i] - lo)).clamp(0.0, 1.0 - f32::EPSILON);
        let t = area.triangles[i] as usize;
        let [a, b, c] = scene.triangle_corners(t);
        // Uniform point on the triangle (square-root parameterisation).
        let su = ux.sqrt();
        let (b1, b2) = (1.0 - su, u.y * su);
        let q = a * (1.0 - b1 - b2) + b * b1 + c * b2;
        let cross = (b - a).cross(c - a);
        let area_t = 0.5 * cross.length();
        let n_l = cross / (2.0 * area_t);
        let to = q - p;
        let d2 = to.length_squared();
        let dist = d2.sqrt();
        if !(dist > 0.0) {
            return None;
        }
        let wi = to / dist;
        let mat = &scene.materials
            [scene.instances[scene.triangle_instance(t) as usize].material as usize];
        let cos_l = n_l.dot(-wi);
        let li = emitted(scene, mat, scene.material_uv(mat, t, b1, b2), cos_l);
        let pdf_area = area.lum[i] / area.total;
        let pdf = pmf * pdf_area * d2 / cos_l.abs().max(1e-8);
        Some(LightSample {
            wi,
            dist,
            li,
            pdf,
            is_delta: false,
            source: LightSource::Area,
        })
    }

    /// Selection-weighted solid-angle density of sampling direction `wi` towards the
    /// environment (for MIS of paths that escape).
    pub fn pdf_environment(&self, wi: Vec3) -> f32 {
        match &self.environment {
            Some(env) => self.uniform_pmf() * env.pdf(wi),
            None => 0.0,
        }
    }

    /// How next-event estimation draws environment-map directions (no effect on a constant
    /// environment, which is sampled uniformly).
    pub fn set_env_sampling(&mut self, sampling: EnvSampling) {
        if let Some(m) = self.environment.as_mut().and_then(|e| e.map.as_mut()) {
            m.sampling = sampling;
        }
    }

    /// Selection-weighted solid-angle density of reaching emissive triangle `t` at distance
    /// `dist` with cosine `cos_l` at the light (for MIS of paths that hit an emitter).
    pub fn pdf_area(&self, scene: &Scene, t: u32, dist: f32, cos_l: f32) -> f32 {
        let Some(area) = &self.area else { return 0.0 };
        let Ok(i) = area.triangles.binary_search(&t) else {
            return 0.0;
        };
        let _ = scene;
        self.uniform_pmf() * (area.lum[i] / area.total) * dist * dist / cos_l.abs().max(1e-8)
    }
}

/// Radiance leaving an emissive surface at texture coordinate `uv` and cosine `cos_l` with its
/// front normal: glTF materials emit from the front face, both faces when double-sided.
#[inline]
pub fn emitted(scene: &Scene, mat: &crate::scene::Material, uv: Vec2, cos_l: f32) -> Vec3 {
    let double = mat.flags & crate::scene::material::MATERIAL_DOUBLE_SIDED != 0;
    if cos_l > 0.0 || (double && cos_l < 0.0) {
        scene.emission_at(mat, uv)
    } else {
        Vec3::ZERO
    }
}

/// glTF's recommended spot falloff (KHR_lights_punctual): linear in the cosine between the
/// outer and inner cone, squared.
fn spot_falloff(l: &PunctualLight, w_from_light: Vec3) -> f32 {
    let cd = Vec3::from(l.direction).dot(w_from_light);
    let scale = 1.0 / (l.cos_inner - l.cos_outer).max(1e-3);
    let a = ((cd - l.cos_outer) * scale).clamp(0.0, 1.0);
    a * a
}

/// Power heuristic (beta = 2) for two strategies.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a + b > 0.0 && a.is_finite() {
        a / (a + b)
    } else if a.is_infinite() {
        1.0
    } else {
        0.0
    }
}
