//! Equiangular sampling of scattering distances towards point and spot lights (Kulla and
//! Fajardo 2012, "Importance Sampling Techniques for Path Tracing in Participating Media"),
//! combined with free-flight sampling by multiple importance sampling.
//!
//! Along a flight segment `x(t) = o + t d` (unit `d`), over `[a, b]` where its media are, the
//! light that point or spot light `k` (at `c`, intensity `I_k`) scatters once towards `-d` is
//!
//! ```text
//! L_k = int_a^b T(a, t) S(x) T(x, c) I_k / |c - x|^2 dt,    S(x) = sum_m sigma_s,m(x) p_m(wo, wi)
//! ```
//!
//! Free flight draws `t` with a density of about `T sigma_t`, which lacks the `1 / r^2` peak
//! around the light: a bulb inside smoke gives it infinite variance. The equiangular density
//!
//! ```text
//! p_e(t) = D / ((theta_b - theta_a) (D^2 + (t - t_c)^2)),    t = t_c + D tan(theta)
//! ```
//!
//! (`t_c` the ray parameter nearest `c`, `D` the distance from `c` to the ray, `theta` uniform
//! between the angles `theta_a`, `theta_b` under which `c` sees the segment's ends) cancels it.
//! Along such a ray the scattering cosine towards the light is `dot(wo, wi) = sin(theta)`, so
//! an anisotropic phase function still varies the estimate several times over (six for
//! `g = 0.3`, most of a bulb pixel's variance). Where the medium's mean cosine `g` is not 0,
//! `theta` is drawn instead from a lobe whose span matches Henyey-Greenstein's ([`lobe_of`]),
//! with `alpha = pi / 2 - theta` and `rho = (1 - h) / (1 + h)`:
//!
//! ```text
//! q(theta) = (1 - h^2) / ((1 + h^2 + 2 h sin(theta)) 2 (G(alpha_a) - G(alpha_b))),
//! G(alpha) = atan(rho tan(alpha / 2)),    p_e(t) = q(theta) D / (D^2 + (t - t_c)^2)
//! ```
//! One estimate per flight segment, the light drawn uniformly among the point and spot lights
//! (`q_k = 1 / n`):
//!
//! ```text
//! <L>_e = w_e(t, k) T^(a, t) S(x) T^(x, c) I_k / |c - x|^2 / (q_k p_e(t))
//! ```
//!
//! with ratio-tracked transmittances `T^` (unbiased, and independent of each other, so their
//! product is too). A free-flight event's next-event estimate of light `k` is multiplied by
//! `w_d(t, k) = 1 - w_e(t, k)`. Null-collision trackers have no closed-form distance density,
//! but the weights only need to sum to one at every `(t, k)` and be computed alike by both
//! strategies, not to use the true densities (the freedom Miller, Georgiev and Jarosz 2019
//! build on). The free-flight density is taken as a homogeneous medium's with the extinction
//! found at `x`,
//!
//! ```text
//! p_d(t) = sigma_t(x) exp(-sigma_t(x) (t - a))
//! w_e    = (q_k p_e)^2 / ((q_k p_e)^2 + (P_k p_d)^2)     (power heuristic, P_k = 1 / lights)
//! ```
//!
//! exact in a homogeneous medium, a local approximation in a heterogeneous one. A light many
//! mean free paths from a segment is left to free flight there (`density_towards`): its
//! equiangular samples, spread along the segment whatever the density, would only add noise.
//!
//! Where the light passes within `NEAR_LIGHT` mean free paths of the segment (`D sigma_max`),
//! what the equiangular density leaves is the medium's `S(x)` varying along its footprint
//! and the ratio trackers' noise. There the estimate resamples `M` distances `t_i` from `p_e`
//! (Talbot, Cline and Egbert 2005), keeps `t` with probability `r_i / sum r`, and averages `W`
//! independent transmittance walks:
//!
//! ```text
//! r_i    = p^(t_i) / (q_k p_e(t_i)),    p^(t) = max_channel(S(x) I_k / |c - x|^2)
//! <L>_e  = w_e(t) S(x) I_k / |c - x|^2 (1/W) sum_j T^_j(a, t) T^_j(x, c) sum_i r_i / (M p^(t))
//! ```
//!
//! unbiased for the same `w_e(t)`. The weight stays the one the free-flight side computes.
use glam::Vec3;
use std::f32::consts::FRAC_PI_2;

use super::features::{Features, NoFeatures};
use super::flight::{vdb_intervals, Spans};
use super::next_event::{media_transmittance, trace_shadow};
use super::views::GreyView;
use crate::math::Ray;
use crate::render::lights::{power_heuristic, LightSource};
use crate::render::media::{MediaStats, TrackingConfig};
use crate::render::prepare::RenderScene;
use crate::render::settings::VolumeSampling;
use crate::render::stack::MediumStack;
use crate::sampling::Rng;

/// The equiangular density of one segment `[a, b]` of a ray towards a light, its angle
/// shaped by the phase function (module doc).
#[derive(Clone, Copy, Debug)]
pub struct Equiangular {
    t_c: f32,
    d: f32,
    theta_a: f32,
    theta_b: f32,
    /// `h`: the lobe of the angle's density (0: uniform in `theta`).
    h: f32,
    /// `rho = (1 - h) / (1 + h)`, and `G(alpha) = atan(rho tan(alpha / 2))` at the segment's
    /// far end (`alpha_b = pi / 2 - theta_b`) and near end.
    rho: f32,
    g_b: f32,
    g_a: f32,
}

impl Equiangular {
    /// The density along `ray` (unit direction) over `[a, b]` (`b` may be infinite) towards
    /// `light`, its angle shaped by the lobe `h` ([`lobe_of`]); `None` where the light lies on
    /// the ray's line (a density of no width).
    pub fn new(ray: &Ray, light: Vec3, a: f32, b: f32, h: f32) -> Option<Equiangular> {
        let t_c = (light - ray.o).dot(ray.d);
        let d = (ray.at(t_c) - light).length();
        let scale = 1.0 + light.abs().max_element();
        if !(d > 1e-6 * scale) || !(b > a) {
            return None;
        }
        let theta_a = (a - t_c).atan2(d);
        let theta_b = (b - t_c).atan2(d);
        let rho = (1.0 - h) / (1.0 + h);
        let g = |theta: f32| (rho * (0.5 * (FRAC_PI_2 - theta)).tan()).atan();
        (theta_b > theta_a).then_some(Equiangular {
            t_c,
            d,
            theta_a,
            theta_b,
            h,
            rho,
            g_b: g(theta_b),
            g_a: g(theta_a),
        })
    }

    /// The distance for uniform `u`.
    pub fn sample(&self, u: f32) -> f32 {
        if self.h == 0.0 {
            let theta = self.theta_a + u * (self.theta_b - self.theta_a);
            return self.t_c + self.d * theta.tan();
        }
        let g = self.g_b + u * (self.g_a - self.g_b);
        let alpha = 2.0 * (g.tan() / self.rho).atan();
        self.t_c + self.d / alpha.tan()
    }

    /// The density of `t` (in `[a, b]`).
    pub fn pdf(&self, t: f32) -> f32 {
        let s = t - self.t_c;
        let r2 = self.d * self.d + s * s;
        if self.h == 0.0 {
            return self.d / ((self.theta_b - self.theta_a) * r2);
        }
        let h = self.h;
        let sin = s / r2.sqrt();
        let angle = (1.0 - h * h) / ((1.0 + h * h + 2.0 * h * sin) * 2.0 * (self.g_a - self.g_b));
        angle * self.d / r2
    }
}

/// The lobe `h` of the equiangular angle's density for a medium whose phase function has the
/// mean cosine `g`: the density `(1 - h^2) / (1 + h^2 + 2 h sin theta)` spans as many times
/// from its peak to its trough as Henyey-Greenstein's `((1 + g) / (1 - g))^3` does, so
/// `(1 + |h|) / (1 - |h|) = ((1 + |g|) / (1 - |g|))^(3/2)`; at most 0.9.
pub fn lobe_of(g: f32) -> f32 {
    let g_abs = g.abs().min(0.99);
    let r = ((1.0 + g_abs) / (1.0 - g_abs)).powf(1.5);
    ((r - 1.0) / (r + 1.0)).min(0.9).copysign(g)
}

/// One flight segment as both strategies weigh it: the ray, the part `[a, b]` of the flight
/// where its media are, and the media the ray is in.
#[derive(Clone, Copy)]
pub(super) struct Segment {
    pub(super) ray: Ray,
    pub(super) a: f32,
    pub(super) b: f32,
    pub(super) media: MediumStack,
    /// The largest extinction of its media (their majorants' global bounds).
    pub(super) sigma_max: f32,
    /// The lobe of the equiangular angle's density ([`lobe_of`]): from the homogeneous
    /// medium's phase function where the segment is in one, else from the first VDB medium's.
    pub(super) h: f32,
}

/// The part of the flight `[t0, t1]` along `ray` where it crosses media: all of it inside a
/// homogeneous medium, else from the first VDB medium's entry to the last one's exit.
pub(super) fn media_extent<F: Features>(
    rs: &RenderScene,
    ray: &Ray,
    t0: f32,
    t1: f32,
    media: MediumStack,
) -> Option<Segment> {
    let hom = media
        .top()
        .filter(|_| F::HOM)
        .map(|h| &rs.homogeneous[h as usize]);
    let spans = if F::HET && (F::MIX || hom.is_none()) {
        vdb_intervals(rs, ray, t0, t1)
    } else {
        Spans::Heap(Vec::new())
    };
    let sigma_vdb = spans
        .iter()
        .map(|s| s.0.bounds().global.max * s.0.sigma_t_bound)
        .fold(0.0f32, f32::max);
    let sigma_max = hom.map_or(0.0, |h| h.sigma_t().max_element()) + sigma_vdb;
    let phase = match hom {
        Some(h) => Some(&h.phase),
        None => rs.vdb.first().map(|m| &m.phase),
    };
    let h = lobe_of(phase.map_or(0.0, |p| p.mean_cosine()));
    let seg = |a, b| Segment {
        ray: *ray,
        a,
        b,
        media,
        sigma_max,
        h,
    };
    if hom.is_some() {
        return Some(seg(t0, t1));
    }
    let a = spans.first()?.1;
    let b = spans.iter().fold(a, |b, s| b.max(s.2));
    Some(seg(a, b))
}

/// Light `c`'s equiangular density over `seg`, where the strategy is used: not where its
/// largest density, `q / ((theta_b - theta_a) D)`, is below [`EQUIANGULAR_REACH`] times the
/// media's largest extinction. There the light is many mean free paths from the segment, free
/// flight samples its scattering well, and an equiangular sample, spread along the segment
/// whatever the density, only adds its variance and a shadow ray. Both strategies ask this,
/// so the MIS weights still sum to one.
fn density_towards(seg: &Segment, c: Vec3, q: f32) -> Option<Equiangular> {
    let eq = Equiangular::new(&seg.ray, c, seg.a, seg.b, seg.h)?;
    let peak = q / ((eq.theta_b - eq.theta_a) * eq.d);
    (peak >= EQUIANGULAR_REACH * seg.sigma_max).then_some(eq)
}

/// See [`density_towards`]: equiangular sampling is used where its peak density reaches this
/// share of the free-flight density in the densest medium.
const EQUIANGULAR_REACH: f32 = 0.3;

/// Sums `each(sigma_s, sigma_t, phase)` over the media at `ray.at(t)`: the homogeneous medium
/// the segment is in and the VDB media whose bounds hold the point, with their coefficients
/// there as the trackers read them (motion and blur at `cfg.time`).
fn media_at<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    seg: &Segment,
    t: f32,
    mut each: impl FnMut(Vec3, Vec3, &crate::volume::phases::Phase),
) {
    if F::HOM {
        if let Some(h) = seg.media.top() {
            let h = &rs.homogeneous[h as usize];
            each(h.sigma_s, h.sigma_t(), &h.phase);
            if !F::MIX {
                return;
            }
        }
    }
    if F::HET {
        let x = seg.ray.at(t);
        for m in rs.vdb.iter() {
            let b = &m.world_bounds;
            if x.cmpge(b.min).all() && x.cmple(b.max).all() {
                let view = GreyView::<NoFeatures, false>::new(m, &seg.ray, cfg, Vec3::ONE);
                let d = view.density_at(t);
                if d > 0.0 {
                    each(m.sigma_s * d, (m.sigma_s + m.sigma_a) * d, &m.phase);
                }
            }
        }
    }
}

/// The free-flight density that MIS weighs against the equiangular one at `t` (module doc).
/// `sigma_t` is the media's mean extinction at the point ([`sigma_t_at`]), `dt` its distance
/// from the segment's start.
fn distance_pdf(sigma_t: f32, dt: f32) -> f32 {
    sigma_t * (-sigma_t * dt.max(0.0)).exp()
}

/// The media's extinction at `ray.at(t)`, the mean of its channels, summed over the media there.
fn sigma_t_at<F: Features>(rs: &RenderScene, cfg: &TrackingConfig, seg: &Segment, t: f32) -> f32 {
    let mut sigma_t = 0.0;
    media_at::<F>(rs, cfg, seg, t, |_, st, _| {
        sigma_t += st.element_sum() / 3.0
    });
    sigma_t
}

/// The equiangular strategy's weight at `(t, k)` (1 without MIS), for light `k`'s density
/// `eq_pdf` (with its selection probability among the point and spot lights) and the media's
/// extinction `sigma_t` there (read only under MIS).
fn equiangular_weight(
    rs: &RenderScene,
    mode: VolumeSampling,
    seg: &Segment,
    t: f32,
    sigma_t: impl FnOnce() -> f32,
    eq_pdf: f32,
) -> f32 {
    match mode {
        VolumeSampling::Mis => {
            let p_d = rs.lights.uniform_pmf() * distance_pdf(sigma_t(), t - seg.a);
            power_heuristic(eq_pdf, p_d)
        }
        _ => 1.0,
    }
}

/// The weight of a free-flight event's next-event estimate of light `source` at `t` in the
/// segment `seg`: 1 for lights the equiangular strategy does not sample, `1 - w_e` for those
/// it does.
pub(super) fn distance_weight<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    mode: VolumeSampling,
    seg: &Segment,
    t: f32,
    source: Option<LightSource>,
) -> f32 {
    let Some(LightSource::Punctual(k)) = source else {
        return 1.0;
    };
    let positional = &rs.lights.positional;
    if mode == VolumeSampling::Distance || !positional.contains(&k) {
        return 1.0;
    }
    let c = Vec3::from(rs.lights.posed(k as usize, cfg.time).position);
    let q = 1.0 / positional.len() as f32;
    let Some(eq) = density_towards(seg, c, q) else {
        return 1.0;
    };
    let sigma_t = || sigma_t_at::<F>(rs, cfg, seg, t);
    1.0 - equiangular_weight(rs, mode, seg, t, sigma_t, q * eq.pdf(t))
}

/// The equiangular strategy's estimate over `seg` (module doc), before the path's throughput,
/// and the light it sampled; `None` without point or spot lights or where the light lies on
/// the ray's line. Near the light ([`NEAR_LIGHT`]) it resamples [`CANDIDATES`] distances and
/// averages [`SHADOW_WALKS`] transmittance walks (module doc).
pub(super) fn equiangular_estimate<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    mode: VolumeSampling,
    seg: &Segment,
    rng: &mut Rng,
    stats: &mut MediaStats,
) -> Option<(Vec3, LightSource)> {
    let positional = &rs.lights.positional;
    let n = positional.len();
    let u_select = rng.uniform_f32();
    let u_t = rng.uniform_f32();
    let k = *positional.get(((u_select * n as f32) as usize).min(n.checked_sub(1)?))?;
    let source = LightSource::Punctual(k);
    let c = Vec3::from(rs.lights.posed(k as usize, cfg.time).position);
    let eq = density_towards(seg, c, 1.0 / n as f32)?;
    let near = eq.d * seg.sigma_max < NEAR_LIGHT;
    let (candidates, walks) = if near {
        (CANDIDATES, SHADOW_WALKS)
    } else {
        (1, 1)
    };
    let zero = Some((Vec3::ZERO, source));
    let Some((c, w_sum)) = resample::<F>(rs, cfg, seg, &eq, k, n, u_t, candidates, rng) else {
        return zero;
    };
    let pdf = eq.pdf(c.t) / n as f32;
    let w = equiangular_weight(rs, mode, seg, c.t, || c.sigma_t, pdf);
    if !(w > 0.0) {
        return zero;
    }
    let ray_a = Ray::new(seg.ray.at(seg.a), seg.ray.d);
    let shadow = Ray::new(seg.ray.at(c.t), c.wi);
    let mut tr = Vec3::ZERO;
    for _ in 0..walks {
        let tr_a = media_transmittance::<F>(
            rs,
            cfg,
            &ray_a,
            0.0,
            c.t - seg.a,
            seg.media.top(),
            rng,
            stats,
        );
        if tr_a != Vec3::ZERO {
            let tr_c = trace_shadow::<F>(
                rs,
                cfg,
                &shadow,
                c.dist * (1.0 - 1e-4),
                seg.media,
                rng,
                stats,
            );
            tr += tr_a * tr_c;
        }
    }
    let resampled = w_sum / candidates as f32 / c.p_hat;
    Some((tr * c.s * c.li * (w * resampled / walks as f32), source))
}

/// Resampling ([`resample`]) and averaged transmittance walks apply where the light's
/// distance `D` from the segment is below this many mean free paths of its densest medium
/// (`D sigma_max`): there the light's `1 / D` dominates the pixel, and the density's
/// variation along the equiangular footprint and the ratio trackers' noise are most of what
/// is left.
pub(crate) const NEAR_LIGHT: f32 = 0.3;
/// `M`: the equiangular distances drawn near a light, one kept by resampling.
pub(crate) const CANDIDATES: usize = 8;
/// The transmittance walks averaged near a light.
pub(crate) const SHADOW_WALKS: usize = 4;

/// One candidate distance of [`resample`]: the point's distance along the ray, the light's
/// direction, distance and incident radiance there, the media's `sum sigma_s p`, their
/// extinction (as [`sigma_t_at`], for the MIS weight) and the target `p_hat`.
struct Candidate {
    t: f32,
    wi: Vec3,
    dist: f32,
    li: Vec3,
    s: Vec3,
    sigma_t: f32,
    p_hat: f32,
}

/// Resampled importance sampling (Talbot, Cline and Egbert 2005, "Importance Resampling for
/// Global Illumination") of light `k`'s equiangular distances: `candidates` distances from
/// `eq` (the first from `u_t`), one kept in proportion to `p_hat / p_e`, with the target
/// `p_hat = max_channel(S(x) I_k / |c - x|^2)` (the integrand without its transmittances).
/// Returns the kept candidate and the sum of `p_hat / p_e` over all of them; the estimate then
/// weighs the integrand at the kept point by `sum / (M p_hat)`, which is unbiased for any
/// weight the MIS gives it. One candidate is plain equiangular sampling, with no extra number
/// drawn.
#[allow(clippy::too_many_arguments)]
fn resample<F: Features>(
    rs: &RenderScene,
    cfg: &TrackingConfig,
    seg: &Segment,
    eq: &Equiangular,
    k: u32,
    n: usize,
    u_t: f32,
    candidates: usize,
    rng: &mut Rng,
) -> Option<(Candidate, f32)> {
    let wo = -seg.ray.d;
    let mut kept = None;
    let mut w_sum = 0.0f32;
    for i in 0..candidates {
        let u = if i == 0 { u_t } else { rng.uniform_f32() };
        let t = eq.sample(u).clamp(seg.a, seg.b);
        let Some((wi, dist, li)) = rs
            .lights
            .punctual_incident(k as usize, seg.ray.at(t), cfg.time)
        else {
            continue;
        };
        let (mut s, mut sigma_t) = (Vec3::ZERO, 0.0);
        media_at::<F>(rs, cfg, seg, t, |sigma_s, st, phase| {
            s += sigma_s * phase.p(wo, wi);
            sigma_t += st.element_sum() / 3.0;
        });
        let p_e = eq.pdf(t) / n as f32;
        let p_hat = (s * li).max_element();
        if !(p_hat > 0.0 && p_e > 0.0) {
            continue;
        }
        let w_i = p_hat / p_e;
        w_sum += w_i;
        if candidates == 1 || rng.uniform_f32() * w_sum < w_i {
            kept = Some(Candidate {
                t,
                wi,
                dist,
                li,
                s,
                sigma_t,
                p_hat,
            });
        }
    }
    kept.map(|c| (c, w_sum))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The density integrates to 1 over its segment, and a sampled distance lies inside it
    /// with the density the sample's cumulative distribution gives, uniform in angle and
    /// shaped by forward and backward lobes.
    #[test]
    fn equiangular_density_is_normalised_and_matches_its_samples() {
        let ray = Ray::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0));
        let light = Vec3::new(0.7, 0.3, -0.1);
        let (a, b) = (0.2, 2.5);
        for h in [0.0, lobe_of(0.6), lobe_of(-0.5)] {
            let eq = Equiangular::new(&ray, light, a, b, h).unwrap();
            let n = 200_000;
            let dt = (b - a) / n as f32;
            let integral: f64 = (0..n)
                .map(|k| eq.pdf(a + (k as f32 + 0.5) * dt) as f64 * dt as f64)
                .sum();
            assert!((integral - 1.0).abs() < 1e-4, "h {h}: integral {integral}");
            for u in [0.0, 0.1, 0.5, 0.9, 1.0] {
                let t = eq.sample(u);
                assert!(t >= a - 1e-5 && t <= b + 1e-5, "h {h}: {t}");
                // The cumulative distribution at t is u (from a) or 1 - u (from b).
                let m = 20_000;
                let cdf: f64 = (0..m)
                    .map(|k| eq.pdf(a + (k as f32 + 0.5) * (t - a) / m as f32) as f64)
                    .sum::<f64>()
                    * ((t - a) / m as f32) as f64;
                let expected = if h == 0.0 { u } else { 1.0 - u };
                assert!(
                    (cdf - expected as f64).abs() < 1e-3,
                    "h {h}, u {u}: cdf {cdf}"
                );
            }
            // A light on the ray's line gives no density; an infinite segment still has one.
            assert!(Equiangular::new(&ray, Vec3::new(1.0, 0.0, 0.0), a, b, h).is_none());
            let far = Equiangular::new(&ray, light, a, f32::INFINITY, h).unwrap();
            assert!(far.sample(0.999).is_finite() && far.pdf(1e3) > 0.0);
        }
    }

    /// The shaped density follows Henyey-Greenstein's angle: along a ray passing a light, the
    /// phase function over the density varies less than under the uniform angle.
    #[test]
    fn the_lobe_flattens_the_phase_over_the_density() {
        let ray = Ray::new(Vec3::new(-5.0, 0.0, 0.0), Vec3::X);
        let light = Vec3::new(0.0, 0.01, 0.0);
        let wo = -ray.d;
        for g in [0.3f32, 0.7, -0.4] {
            let phase = crate::volume::phases::Phase::hg(g);
            let spread = |h: f32| {
                let eq = Equiangular::new(&ray, light, 0.0, 10.0, h).unwrap();
                let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
                for k in 0..1000 {
                    let t = eq.sample((k as f32 + 0.5) / 1000.0);
                    let wi = (light - ray.at(t)).normalize();
                    // The single-scattering integrand's angular part over the density.
                    let r2 = (light - ray.at(t)).length_squared();
                    let v = phase.p(wo, wi) / (r2 * eq.pdf(t));
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                hi / lo
            };
            let (uniform, shaped) = (spread(0.0), spread(lobe_of(g)));
            assert!(
                shaped < 0.2 * uniform && shaped < 3.0,
                "g {g}: {shaped} against {uniform}"
            );
        }
    }
}
