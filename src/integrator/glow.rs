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
//! density proportional to `1 / d` around one of them (`r = R u`, `phi = 2 pi v`), the rest
//! uniformly, and weighs each sample by the mixture's density (one-sample MIS, balance
//! heuristic), in pixel units:
//!
//! ```text
//! p(q) = (1 - a) + (a / n) sum_k g_k(q),    g_k(q) = 1 / (2 pi R |q - c_k|)  where |q - c_k| < R
//! <I>  = f(q) / p(q)     (0 where a glow sample lands outside the pixel)
//! ```
//!
//! with `n` the glows whose discs reach the pixel. Near `c_k`, `f / p` is bounded by
//! `2 pi R n f(q) |q - c_k| / a`, so the pixel's variance is finite. Every other pixel keeps its
//! uniform jitter bit for bit. The estimate is unbiased for any `c_k`, so the film points are
//! taken once per render, at the render's time: a moving camera or light only makes the
//! density less well aimed.
use glam::{Vec2, Vec3};

use crate::render::prepare::RenderScene;
use crate::render::settings::VolumeSampling;

/// Glows a render keeps at most (the first lights in `Lights::positional` order).
pub const MAX_GLOWS: usize = 4;
/// `R`: the radius of a glow's disc, pixels.
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
        for &k in &rs.lights.positional {
            let p = Vec3::from(rs.lights.posed(k as usize, time).position);
            let in_media = !rs.homogeneous.is_empty()
                || rs.vdb.iter().any(|m| {
                    let b = &m.world_bounds;
                    p.cmpge(b.min).all() && p.cmple(b.max).all()
                });
            let Some(f) = pinhole.film_point(p, aspect).filter(|_| in_media) else {
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

    /// Pixel `(x, y)`'s jitter (in `[0, 1)^2` inside the pixel; outside it for a glow sample
    /// that left it) for the uniform numbers `u`, and the sample's weight `1 / p(q)` (module
    /// doc): `(u, 1)` where no glow reaches the pixel.
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
            let r = GLOW_RADIUS * (s - pick as f32);
            let phi = std::f32::consts::TAU * u.y;
            self.centres[near[pick]] + r * Vec2::new(phi.cos(), phi.sin()) - corner
        } else {
            Vec2::new((u.x - GLOW_SHARE) / (1.0 - GLOW_SHARE), u.y)
        };
        if !(q.x >= 0.0 && q.x < 1.0 && q.y >= 0.0 && q.y < 1.0) {
            return (q, 0.0);
        }
        let mut glow = 0.0;
        for &k in &near[..n] {
            let r = (corner + q - self.centres[k]).length();
            if r < GLOW_RADIUS {
                glow += 1.0 / (std::f32::consts::TAU * GLOW_RADIUS * r.max(1e-12));
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The weighted jitter integrates any function over the pixel without bias: the mean of
    /// `w f(q)` over a fine grid of `u` is `f`'s integral, for a pixel holding a glow's centre
    /// and one on its edge; pixels no glow reaches keep `u` with weight 1.
    #[test]
    fn weighted_jitter_integrates_the_pixel() {
        let glows = Glows {
            centres: [
                Vec2::new(10.3, 5.6),
                Vec2::new(12.0, 5.5),
                Vec2::ZERO,
                Vec2::ZERO,
            ],
            count: 2,
        };
        let f = |q: Vec2| 1.0 + q.x * q.x + 0.5 * q.y;
        let exact = 1.0 + 1.0 / 3.0 + 0.25;
        for (x, y) in [(10, 5), (11, 5), (12, 5), (9, 5)] {
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

    /// A glow's `1 / d` falloff, the quantity that has no finite variance under uniform
    /// jitter, keeps a bounded weighted value under glow sampling.
    #[test]
    fn weighted_glow_is_bounded() {
        let glows = Glows {
            centres: [Vec2::new(3.5, 7.25), Vec2::ZERO, Vec2::ZERO, Vec2::ZERO],
            count: 1,
        };
        let c = glows.centres[0];
        let mut largest = 0.0f32;
        let m = 600;
        for i in 0..m {
            for j in 0..m {
                let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                let (q, w) = glows.jitter(3, 7, u);
                if w > 0.0 {
                    let d = (Vec2::new(3.0, 7.0) + q - c).length();
                    largest = largest.max(w / d);
                }
            }
        }
        let bound = std::f32::consts::TAU * GLOW_RADIUS / GLOW_SHARE;
        assert!(largest <= bound * 1.0001, "{largest} above {bound}");
    }
}
