//! Pixel jitter drawn towards the film points of point and spot lights inside media ("glow
//! sampling"), so that the pixels holding a lamp seen through smoke keep a finite variance.
//!
//! A camera ray passing at distance `D` from a point light in a medium scatters about
//! `pi sigma_s p T^2 I / D` of it towards the camera, whatever its distance sampling does
//! along the ray: the light's glow falls off as `1 / d` across the film from its film point
//! `c`. Jittered uniformly over a pixel that holds `c`, the sample's value `f(q) ~ 1 / |q - c|`
//! has an infinite second moment (the integral of `1 / d^2` over a disc diverges), so no
//! number of samples makes that pixel's variance estimate settle.
//!
//! Glow sampling draws a share `a` of the jitter of every pixel within `R` of some `c_k` from a
//! density proportional to `1 / d` around one of them, restricted to the pixel, the rest
//! uniformly, and weighs each sample by the mixture's density (one-sample MIS, balance
//! heuristic), in pixel units. The glow's density takes the directions from `c_k` that meet
//! the pixel (a fan of angle `Phi_k`: all of them where `c_k` is inside it), its angle `phi`
//! uniform in the fan and its distance `r` uniform along the chord `[t_in, t_out]` that the
//! pixel cuts from the ray at `phi`:
//!
//! ```text
//! p(q) = (1 - a) + (a / n) sum_k g_k(q),    g_k(q) = 1 / (Phi_k |q - c_k| (t_out - t_in))
//! <I>  = f(q) / p(q)
//! ```
//!
//! with `n` the glows that reach the pixel. Every sample lands in its pixel, and near `c_k`,
//! `f / p` is bounded by `n Phi_k (t_out - t_in) f(q) |q - c_k| / a`, so the pixel's variance
//! is finite. Every other pixel keeps its uniform jitter bit for bit. The estimate is unbiased
//! for any `c_k`, so the film points are taken once per render, at the render's time: a moving
//! camera or light only makes the density less well aimed.
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

use super::bsdf::{BsdfSample, Principled};
use super::lit_media::{LitMedia, LIT_SHARE};
use crate::render::prepare::RenderScene;
use crate::render::settings::VolumeSampling;
use crate::sampling::discrete::ONE_MINUS_EPSILON;
use crate::sampling::warp::Frame;
use crate::volume::phase::PhaseSample;
use crate::volume::phases::Phase;

/// Glows a render keeps at most (the first lights in `Lights::positional` order).
pub const MAX_GLOWS: usize = 4;
/// `R`: how far from a glow's film point its pixels reach, pixels.
pub const GLOW_RADIUS: f32 = 0.5;
/// `a`: the share of a reached pixel's samples drawn around its glows.
pub const GLOW_SHARE: f32 = 0.5;

/// The film points, in pixels (`(0, 0)` the image's top-left corner), of the point and spot
/// lights inside media that the camera sees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Glows {
    pub centres: [Vec2; MAX_GLOWS],
    pub count: usize,
}

impl Glows {
    /// No glow: every pixel's jitter is uniform.
    pub const NONE: Glows = Glows {
        centres: [Vec2::ZERO; MAX_GLOWS],
        count: 0,
    };

    /// The glows of `rs` on a `width x height` film. None under distance-only sampling (the
    /// ablation baseline), where each ray's own estimate near the light has no finite variance
    /// either. A light counts as inside media where some VDB medium's bounds hold it or the
    /// scene has a homogeneous medium.
    pub fn of_scene(
        rs: &RenderScene,
        sampling: VolumeSampling,
        time: f32,
        width: u32,
        height: u32,
    ) -> Glows {
        let mut glows = Glows::NONE;
        if sampling == VolumeSampling::Distance {
            return glows;
        }
        let aspect = width as f32 / height as f32;
        let pinhole = rs.pinhole_at(time);
        for p in lamps_in_media(rs, time) {
            let Some(f) = pinhole.film_point(p, aspect) else {
                continue;
            };
            let c = Vec2::new(f.x * width as f32, f.y * height as f32);
            let reach = GLOW_RADIUS + 1.0;
            let on_film = c.x > -reach
                && c.y > -reach
                && c.x < width as f32 + reach
                && c.y < height as f32 + reach;
            if on_film && glows.count < MAX_GLOWS {
                glows.centres[glows.count] = c;
                glows.count += 1;
            }
        }
        glows
    }

    /// Pixel `(x, y)`'s jitter (in `[0, 1)^2`) for the uniform numbers `u`, and the sample's
    /// weight `1 / p(q)` (module doc; 0 where rounding left a glow sample outside the
    /// pixel): `(u, 1)` where no glow reaches the pixel.
    pub fn jitter(&self, x: u32, y: u32, u: Vec2) -> (Vec2, f32) {
        let corner = Vec2::new(x as f32, y as f32);
        let mut near = [0usize; MAX_GLOWS];
        let mut n = 0;
        for (k, c) in self.centres[..self.count].iter().enumerate() {
            if reaches(*c, corner) {
                near[n] = k;
                n += 1;
            }
        }
        if n == 0 {
            return (u, 1.0);
        }
        let q = if u.x < GLOW_SHARE {
            let s = u.x / GLOW_SHARE * n as f32;
            let pick = (s as usize).min(n - 1);
            let c = self.centres[near[pick]];
            let (phi_0, fan) = fan(c, corner);
            let phi = phi_0 + fan * (s - pick as f32);
            let e = Vec2::new(phi.cos(), phi.sin());
            let (t_in, t_out) = chord(c, e, corner);
            c + (t_in + u.y * (t_out - t_in)) * e - corner
        } else {
            Vec2::new((u.x - GLOW_SHARE) / (1.0 - GLOW_SHARE), u.y)
        };
        if !(q.x >= 0.0 && q.x < 1.0 && q.y >= 0.0 && q.y < 1.0) {
            return (q, 0.0);
        }
        let mut glow = 0.0;
        for &k in &near[..n] {
            glow += density(self.centres[k], corner, q);
        }
        (q, 1.0 / ((1.0 - GLOW_SHARE) + GLOW_SHARE / n as f32 * glow))
    }
}

/// Whether the glow centred at `c` reaches the pixel whose top-left corner is `corner`: the
/// distance from `c` to the pixel's square is below [`GLOW_RADIUS`].
fn reaches(c: Vec2, corner: Vec2) -> bool {
    let d = (corner - c).max(c - (corner + Vec2::ONE)).max(Vec2::ZERO);
    d.length_squared() < GLOW_RADIUS * GLOW_RADIUS
}

/// The directions from `c` that meet the pixel whose top-left corner is `corner`: the angle
/// of the first and the fan's angle `Phi` (`2 pi` where `c` is inside the pixel, at most `pi`
/// elsewhere, the pixel being convex), measured from its centre's direction.
fn fan(c: Vec2, corner: Vec2) -> (f32, f32) {
    let inside = c.cmpgt(corner).all() && c.cmplt(corner + Vec2::ONE).all();
    if inside {
        return (0.0, TAU);
    }
    let mid = corner + Vec2::splat(0.5) - c;
    let base = mid.y.atan2(mid.x);
    let (mut lo, mut hi) = (0.0f32, 0.0f32);
    for k in 0..4 {
        let v = corner + Vec2::new((k & 1) as f32, (k >> 1) as f32) - c;
        if v != Vec2::ZERO {
            let mut rel = v.y.atan2(v.x) - base;
            if rel > PI {
                rel -= TAU;
            } else if rel < -PI {
                rel += TAU;
            }
            lo = lo.min(rel);
            hi = hi.max(rel);
        }
    }
    (base + lo, hi - lo)
}

/// The part `[t_in, t_out]` (`t_in >= 0`) of the ray from `c` along unit `e` inside the
/// pixel whose top-left corner is `corner`; empty (`t_out <= t_in`) where it misses it.
fn chord(c: Vec2, e: Vec2, corner: Vec2) -> (f32, f32) {
    let (mut t_in, mut t_out) = (0.0f32, f32::INFINITY);
    for i in 0..2 {
        let (lo, hi) = (corner[i] - c[i], corner[i] + 1.0 - c[i]);
        if e[i] == 0.0 {
            if !(lo <= 0.0 && hi >= 0.0) {
                return (0.0, 0.0);
            }
        } else {
            let (t1, t2) = (lo / e[i], hi / e[i]);
            t_in = t_in.max(t1.min(t2));
            t_out = t_out.min(t1.max(t2));
        }
    }
    (t_in, t_out)
}

/// `g(q)`: the density of the glow centred at `c` at the point `q` of the pixel whose
/// top-left corner is `corner` (module doc).
fn density(c: Vec2, corner: Vec2, q: Vec2) -> f32 {
    let v = corner + q - c;
    let r = v.length();
    if !(r > 0.0) {
        return 0.0;
    }
    let (t_in, t_out) = chord(c, v / r, corner);
    let (_, fan) = fan(c, corner);
    let length = t_out - t_in;
    if length > 0.0 && fan > 0.0 {
        1.0 / (fan * r * length)
    } else {
        0.0
    }
}

/// The positions at `time` of the point and spot lights inside media: where some VDB
/// medium's bounds hold them, or anywhere in a scene with a homogeneous medium.
fn lamps_in_media<'a>(rs: &'a RenderScene, time: f32) -> impl Iterator<Item = Vec3> + 'a {
    rs.lights.positional.iter().filter_map(move |&k| {
        let p = Vec3::from(rs.lights.posed(k as usize, time).position);
        let inside = |b: &crate::math::Aabb| p.cmpge(b.min).all() && p.cmple(b.max).all();
        let in_media = !rs.homogeneous.is_empty() || rs.vdb.iter().any(|m| inside(&m.world_bounds));
        in_media.then_some(p)
    })
}

/// `b`: the share of a medium scattering event's directions drawn towards lamps in media.
pub const CONE_SHARE: f32 = 0.1;
/// `theta_max`: the half-angle of the cone around a lamp's direction, radians.
pub const CONE_ANGLE: f32 = 0.25;
/// `cos(theta_max)`: a direction is in a cone where its cosine to the axis is above it.
pub const COS_CONE_ANGLE: f32 = 0.968_912_4;

/// Directions drawn towards lamps inside media at scattering events, in media and on
/// surfaces: the light a scattered path then meets near a lamp, at a distance `D` from it, is
/// about `1 / D`, and under the phase function or BSDF alone `D ~ R theta` has a density
/// `~ theta`, so the estimate's second moment diverges (as log): a wall beside a bulb in
/// smoke shows fireflies. A share `b` of the directions is drawn with `theta` uniform in
/// `[0, theta_max]` about one lamp's direction (a density `1 / (2 pi theta_max sin theta)`),
/// the rest from the phase function or BSDF, weighed by the mixture:
///
/// ```text
/// p(wi) = (1 - b) p_phase(wi) + (b / n) sum_k p_cone,k(wi),    beta *= p_phase(wi) / p(wi)
/// p(wi) = (1 - b) p_bsdf(wi)  + (b / n) sum_k p_cone,k(wi),    beta *= f(wi) cos / p(wi)
/// ```
///
/// Surface events also draw a share towards the media that emitting media light
/// ([`LitMedia`]); medium events find those by their phase function.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lamps {
    pub positions: [Vec3; MAX_GLOWS],
    pub count: usize,
    /// The boxes of the media that emitting media light (none without media lights).
    pub lit: LitMedia,
}

impl Lamps {
    /// The lamps of `rs` at `time` (none under distance-only sampling) and the media its
    /// emitting media light.
    pub fn of_scene(rs: &RenderScene, sampling: VolumeSampling, time: f32) -> Lamps {
        let mut lamps = Lamps {
            lit: rs
                .media_lights
                .as_ref()
                .map_or(LitMedia::NONE, |m| LitMedia::new(&m.lit)),
            ..Lamps::default()
        };
        if sampling == VolumeSampling::Distance {
            return lamps;
        }
        for p in lamps_in_media(rs, time).take(MAX_GLOWS) {
            lamps.positions[lamps.count] = p;
            lamps.count += 1;
        }
        lamps
    }

    /// The density of a scattering direction `wi` at `x` whose phase function or BSDF has the
    /// density `pdf` there: the mixture's with the cones (`pdf` itself without lamps). What
    /// next-event estimation weighs a light's sample against, so that its MIS weight and
    /// that of the scattered direction that meets the same light sum to one.
    pub fn mixture_pdf(&self, x: Vec3, wi: Vec3, pdf: f32) -> f32 {
        if self.count == 0 {
            pdf
        } else {
            (1.0 - CONE_SHARE) * pdf + CONE_SHARE * self.pdf(x, wi)
        }
    }

    /// Whether surface events draw some of their directions from the lamps or the lit media.
    pub fn guides_surfaces(&self) -> bool {
        self.count > 0 || self.lit.count > 0
    }

    /// The shares of a surface event's directions drawn from the lamps' cones and from the
    /// lit media's boxes.
    fn surface_shares(&self) -> (f32, f32) {
        let cones = if self.count > 0 { CONE_SHARE } else { 0.0 };
        let boxes = if self.lit.count > 0 { LIT_SHARE } else { 0.0 };
        (cones, boxes)
    }

    /// [`mixture_pdf`](Self::mixture_pdf) at a surface: the BSDF's density `pdf` mixed with
    /// the lamps' cones and the lit media's boxes.
    pub fn surface_mixture_pdf(&self, x: Vec3, wi: Vec3, pdf: f32) -> f32 {
        if self.lit.count == 0 {
            return self.mixture_pdf(x, wi, pdf);
        }
        let (cones, boxes) = self.surface_shares();
        let mut p = (1.0 - cones - boxes) * pdf + boxes * self.lit.pdf(x, wi);
        if self.count > 0 {
            p += cones * self.pdf(x, wi);
        }
        p
    }

    /// The cones' mixture density `(1 / n) sum_k p_cone,k(wi)` at `x`.
    pub fn pdf(&self, x: Vec3, wi: Vec3) -> f32 {
        let mut sum = 0.0;
        for c in &self.positions[..self.count] {
            let axis = (*c - x).normalize_or_zero();
            let cos = axis.dot(wi).clamp(-1.0, 1.0);
            if cos > COS_CONE_ANGLE {
                // From the cross product: near the axis 1 - cos^2 loses every digit.
                let sin = axis.cross(wi).length();
                sum += 1.0 / (std::f32::consts::TAU * CONE_ANGLE * sin.max(1e-7));
            }
        }
        sum / self.count as f32
    }

    /// A medium event's next direction at `x` (`u` the event's point, `u_c` picks the
    /// strategy and the lamp, `more` feeds the phase function's rejections): a share
    /// [`CONE_SHARE`] from the lamps' cones, the rest from `phase`, weighed by the mixture.
    pub fn sample_phase(
        &self,
        phase: &Phase,
        x: Vec3,
        wo: Vec3,
        u: Vec2,
        u_c: f32,
        more: &mut dyn FnMut() -> Vec2,
    ) -> PhaseSample {
        let wi = if u_c < CONE_SHARE {
            let pick = ((u_c / CONE_SHARE * self.count as f32) as usize).min(self.count - 1);
            self.sample(x, pick, u)
        } else {
            phase.sample(wo, u, more).wi
        };
        let f = phase.p(wo, wi);
        let pdf = self.mixture_pdf(x, wi, f);
        let weight = if pdf > 0.0 { f / pdf } else { 0.0 };
        PhaseSample { wi, pdf, weight }
    }

    /// A surface's next direction at `x`, in the shading frame `frame` (`(u_lobe, u)` the
    /// BSDF's numbers, `u_c` picks the strategy and the lamp or box): a share [`CONE_SHARE`]
    /// from the lamps' cones, a share [`LIT_SHARE`] from the lit media's boxes, the rest from
    /// `bsdf`, weighed by the mixture. `None` where the direction is below the surface or the
    /// BSDF's sampling fails.
    pub fn sample_bsdf(
        &self,
        bsdf: &Principled,
        frame: &Frame,
        wo_l: Vec3,
        x: Vec3,
        (u_lobe, u): (f32, Vec2),
        u_c: f32,
    ) -> Option<BsdfSample> {
        let (cones, boxes) = self.surface_shares();
        let wi_l = if u_c < cones {
            let pick = ((u_c / cones * self.count as f32) as usize).min(self.count - 1);
            frame.to_local(self.sample(x, pick, u))
        } else if u_c < cones + boxes {
            // The box and the point's third coordinate from what is left of `u_c`.
            let s = (u_c - cones) / boxes * self.lit.count as f32;
            let pick = (s as usize).min(self.lit.count - 1);
            let w = (s - pick as f32).clamp(0.0, ONE_MINUS_EPSILON);
            frame.to_local(self.lit.sample(x, pick, u.extend(w)))
        } else {
            bsdf.sample(wo_l, u_lobe, u)?.wi
        };
        let pdf_bsdf = bsdf.pdf(wo_l, wi_l);
        if !(wi_l.z > 0.0 && pdf_bsdf > 0.0) {
            return None;
        }
        let wi = frame.from_local(wi_l);
        let pdf = self.surface_mixture_pdf(x, wi, pdf_bsdf);
        Some(BsdfSample {
            wi: wi_l,
            weight: bsdf.eval(wo_l, wi_l) * wi_l.z / pdf,
            pdf,
        })
    }

    /// A direction at `x` in lamp `pick`'s cone for uniform `u`.
    pub fn sample(&self, x: Vec3, pick: usize, u: Vec2) -> Vec3 {
        let axis = (self.positions[pick] - x).normalize_or_zero();
        let theta = CONE_ANGLE * u.x;
        let phi = std::f32::consts::TAU * u.y;
        let local = Vec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        );
        Frame::from_z(axis).from_local(local).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::warp::direction_grid;

    /// The weighted jitter integrates any function over the pixel without bias: the mean of
    /// `w f(q)` over a fine grid of `u` is `f`'s integral, for a pixel holding a glow's centre
    /// and one on its edge; pixels no glow reaches keep `u` with weight 1.
    #[test]
    fn weighted_jitter_integrates_the_pixel() {
        let glows = Glows {
            centres: [
                Vec2::new(10.3, 5.6),
                Vec2::new(12.0, 5.5),
                Vec2::new(14.0, 5.0),
                Vec2::ZERO,
            ],
            count: 3,
        };
        let f = |q: Vec2| 1.0 + q.x * q.x + 0.5 * q.y;
        let exact = 1.0 + 1.0 / 3.0 + 0.25;
        for (x, y) in [(10, 5), (11, 5), (12, 5), (9, 5), (13, 4), (14, 5), (13, 5)] {
            let m = 1500;
            let mut sum = 0.0f64;
            for i in 0..m {
                for j in 0..m {
                    let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                    let (q, w) = glows.jitter(x, y, u);
                    if w > 0.0 {
                        assert!(q.cmpge(Vec2::ZERO).all() && q.cmplt(Vec2::ONE).all());
                        sum += (w * f(q)) as f64;
                    }
                }
            }
            let mean = sum / (m * m) as f64;
            assert!(
                (mean - exact).abs() < 2e-3,
                "pixel ({x}, {y}): {mean} against {exact}"
            );
        }
        let u = Vec2::new(0.3, 0.7);
        assert_eq!(glows.jitter(20, 5, u), (u, 1.0));
        assert_eq!(Glows::NONE.jitter(10, 5, u), (u, 1.0));
    }

    /// The lamps' cones integrate to 1 over the sphere, and the mixture's weighted directions
    /// integrate the phase function without bias: the mean weight is 1 and the mean weight in
    /// a lamp's cone is the phase function's mass there (forward HG, a lamp to the side).
    #[test]
    fn lamp_cones_keep_the_phase_integral() {
        let lamps = Lamps {
            positions: [
                Vec3::new(2.0, 0.5, 0.0),
                Vec3::new(-1.0, 0.0, 3.0),
                Vec3::ZERO,
                Vec3::ZERO,
            ],
            count: 2,
            lit: LitMedia::NONE,
        };
        let x = Vec3::new(0.1, 0.0, 0.2);
        // The cones' density over the sphere, by a fine grid in (cos, phi).
        let mut total = 0.0f64;
        let cell = direction_grid(2000, false, |wi| total += lamps.pdf(x, wi) as f64);
        total *= cell;
        assert!((total - 1.0).abs() < 2e-3, "cones integrate to {total}");
        let phase = Phase::hg(0.6);
        let wo = Vec3::new(1.0, 0.0, 0.0);
        let axis = (lamps.positions[0] - x).normalize();
        let mut rng = crate::sampling::Rng::new(3, 4, 5);
        let n = 2_000_000;
        let (mut sum, mut in_cone) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (u, u_c) = (rng.uniform_vec2(), rng.uniform_f32());
            let s = lamps.sample_phase(&phase, x, wo, u, u_c, &mut || rng.uniform_vec2());
            sum += s.weight as f64;
            if axis.dot(s.wi).clamp(-1.0, 1.0).acos() < CONE_ANGLE {
                in_cone += s.weight as f64;
            }
        }
        // The phase function's mass in lamp 0's cone, by quadrature about its axis.
        let frame = crate::sampling::warp::Frame::from_z(axis);
        let q = 400;
        let mut mass = 0.0f64;
        for i in 0..q {
            let theta = CONE_ANGLE as f64 * (i as f64 + 0.5) / q as f64;
            for j in 0..q {
                let phi = std::f64::consts::TAU * (j as f64 + 0.5) / q as f64;
                let local = glam::DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let wi = frame.from_local(local.as_vec3());
                mass += phase.p(wo, wi) as f64 * theta.sin();
            }
        }
        mass *= CONE_ANGLE as f64 * std::f64::consts::TAU / (q * q) as f64;
        let (mean, cone) = (sum / n as f64, in_cone / n as f64);
        assert!((mean - 1.0).abs() < 3e-3, "mean weight {mean}");
        assert!(
            (cone - mass).abs() < 0.02 * mass + 1e-4,
            "cone {cone} against {mass}"
        );
    }

    /// At a surface, the mixture's weighted directions integrate `f cos` without bias: the
    /// mean weight is the BSDF's albedo by quadrature, in total and in a lamp's cone (one
    /// lamp above the surface, one below it, whose cone directions end the path).
    #[test]
    fn lamp_cones_keep_the_bsdf_integral() {
        let lamps = Lamps {
            positions: [
                Vec3::new(0.8, 0.3, 1.0),
                Vec3::new(-0.5, 0.2, -2.0),
                Vec3::ZERO,
                Vec3::ZERO,
            ],
            count: 2,
            lit: LitMedia::NONE,
        };
        let x = Vec3::new(0.1, -0.2, 0.0);
        let frame = Frame::from_z(Vec3::Z);
        let bsdf = Principled::new(Vec3::new(0.7, 0.5, 0.3), 0.2, 0.4);
        let wo_l = Vec3::new(-0.5, 0.1, 0.8).normalize();
        let axis = (lamps.positions[0] - x).normalize();
        let in_cone = |wi: Vec3| axis.dot(wi) > COS_CONE_ANGLE;
        // `f cos` over the hemisphere and over lamp 0's cone, by a grid in (cos, phi).
        let (mut albedo, mut mass) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        let cell = direction_grid(1500, true, |wi| {
            let v = (bsdf.eval(wo_l, wi) * wi.z).as_dvec3();
            albedo += v;
            if in_cone(frame.from_local(wi)) {
                mass += v;
            }
        });
        (albedo, mass) = (albedo * cell, mass * cell);
        let mut rng = crate::sampling::Rng::new(7, 8, 9);
        let n = 2_000_000;
        let (mut sum, mut cone) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for _ in 0..n {
            let (u_lobe, u, u_c) = (rng.uniform_f32(), rng.uniform_vec2(), rng.uniform_f32());
            if let Some(s) = lamps.sample_bsdf(&bsdf, &frame, wo_l, x, (u_lobe, u), u_c) {
                sum += s.weight.as_dvec3();
                if in_cone(frame.from_local(s.wi)) {
                    cone += s.weight.as_dvec3();
                }
            }
        }
        let (sum, cone) = (sum / n as f64, cone / n as f64);
        for c in 0..3 {
            assert!(
                (sum[c] - albedo[c]).abs() < 5e-3 * albedo[c],
                "channel {c}: mean weight {} against {}",
                sum[c],
                albedo[c]
            );
            assert!(
                (cone[c] - mass[c]).abs() < 0.02 * mass[c],
                "channel {c}: cone {} against {}",
                cone[c],
                mass[c]
            );
        }
    }

    /// With the lit media's boxes beside the lamps' cones (and alone), a surface's weighted
    /// directions still integrate `f cos` without bias: the mean weight is the BSDF's albedo
    /// by quadrature (a box above the surface, one across it).
    #[test]
    fn lit_boxes_keep_the_bsdf_integral() {
        let lit = LitMedia::new(&[
            crate::math::Aabb::new(Vec3::new(1.0, -0.5, 0.5), Vec3::new(2.5, 1.0, 1.5)),
            crate::math::Aabb::new(Vec3::new(-2.0, -1.0, -0.5), Vec3::new(-1.0, 0.0, 0.8)),
        ]);
        let x = Vec3::new(0.1, -0.2, 0.0);
        let frame = Frame::from_z(Vec3::Z);
        let bsdf = Principled::new(Vec3::new(0.7, 0.5, 0.3), 0.2, 0.4);
        let wo_l = Vec3::new(-0.5, 0.1, 0.8).normalize();
        let mut albedo = glam::DVec3::ZERO;
        let cell = direction_grid(1000, true, |wi| {
            albedo += (bsdf.eval(wo_l, wi) * wi.z).as_dvec3();
        });
        albedo *= cell;
        for count in [0, 1] {
            let lamps = Lamps {
                positions: [Vec3::new(0.8, 0.3, 1.0), Vec3::ZERO, Vec3::ZERO, Vec3::ZERO],
                count,
                lit,
            };
            let mut rng = crate::sampling::Rng::new(11, 12, 13);
            let n = 2_000_000;
            let mut sum = glam::DVec3::ZERO;
            for _ in 0..n {
                let (u_lobe, u, u_c) = (rng.uniform_f32(), rng.uniform_vec2(), rng.uniform_f32());
                if let Some(s) = lamps.sample_bsdf(&bsdf, &frame, wo_l, x, (u_lobe, u), u_c) {
                    let pdf =
                        lamps.surface_mixture_pdf(x, frame.from_local(s.wi), bsdf.pdf(wo_l, s.wi));
                    assert_eq!(pdf, s.pdf);
                    sum += s.weight.as_dvec3();
                }
            }
            let sum = sum / n as f64;
            for c in 0..3 {
                assert!(
                    (sum[c] - albedo[c]).abs() < 5e-3 * albedo[c],
                    "{count} lamps, channel {c}: mean weight {} against {}",
                    sum[c],
                    albedo[c]
                );
            }
        }
    }

    /// The cone test by cosine is the test by angle.
    #[test]
    fn cone_cosine_is_the_cone_angle_cosine() {
        assert!((COS_CONE_ANGLE - CONE_ANGLE.cos()).abs() <= f32::EPSILON);
    }

    /// A glow's `1 / d` falloff, the quantity that has no finite variance under uniform
    /// jitter, keeps a bounded weighted value under glow sampling, and no glow sample leaves
    /// its pixel: one glow inside the pixel, one on its edge, one on its corner, one a
    /// little outside it.
    #[test]
    fn weighted_glow_is_bounded() {
        for c in [
            Vec2::new(3.5, 7.25),
            Vec2::new(4.0, 7.6),
            Vec2::new(3.0, 7.0),
            Vec2::new(3.7, 8.3),
        ] {
            let glows = Glows {
                centres: [c, Vec2::ZERO, Vec2::ZERO, Vec2::ZERO],
                count: 1,
            };
            let mut largest = 0.0f32;
            let m = 600;
            for i in 0..m {
                for j in 0..m {
                    let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                    let (q, w) = glows.jitter(3, 7, u);
                    assert!(w > 0.0, "{c}: a sample at {q} left the pixel");
                    let d = (Vec2::new(3.0, 7.0) + q - c).length();
                    largest = largest.max(w / d);
                }
            }
            let bound = TAU * std::f32::consts::SQRT_2 / GLOW_SHARE;
            assert!(largest <= bound * 1.0001, "{c}: {largest} above {bound}");
        }
    }
}
