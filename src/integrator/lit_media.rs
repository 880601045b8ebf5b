//! Directions drawn from surfaces towards the media that emitting media light.
//!
//! Media-light sampling (`render::media_lights`) gives a surface the flame's own light, but
//! the smoke around a flame, lit by it, is found only by a BSDF direction that happens to
//! enter it. From a floor a few metres from a fire the smoke fills a small solid angle near
//! the horizon, where a cosine-weighted direction rarely goes: one bounce in a hundred meets
//! it, and that light (the floor lit by smoke that the fire lights) carries most of the
//! floor's variance. A share `b` of a surface's directions is drawn towards a point `y`
//! uniform in one of the `n` boxes around those media, the rest from the BSDF, weighed by the
//! mixture. Uniform in box `k` of volume `V_k`, `y` has the solid-angle density along the
//! ray's chord `[t_0, t_1]` through the box (`t_0 = 0` from inside it):
//!
//! ```text
//! p_box,k(wi) = (1 / V_k) int_{t_0}^{t_1} t^2 dt = (t_1^3 - t_0^3) / (3 V_k)
//! p(wi)       = (1 - b) p_bsdf(wi) + (b / n) sum_k p_box,k(wi),    beta *= f(wi) cos / p(wi)
//! ```
//!
//! The boxes are those of `MediaLights::lit`: each emitting medium's cells that hold density,
//! and every other still medium that overlaps one of them.
use glam::Vec3;

use crate::math::Aabb;

/// Boxes a render keeps at most (the first of `MediaLights::lit`).
pub const MAX_LIT: usize = 4;
/// `b`: the share of a surface event's directions drawn towards the lit media.
pub const LIT_SHARE: f32 = 0.25;

/// The boxes around the media that emitting media light ([module doc](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LitMedia {
    pub boxes: [Aabb; MAX_LIT],
    pub count: usize,
}

impl Default for LitMedia {
    fn default() -> Self {
        LitMedia::NONE
    }
}

impl LitMedia {
    /// No box: every surface direction comes from its BSDF.
    pub const NONE: LitMedia = LitMedia {
        boxes: [Aabb::EMPTY; MAX_LIT],
        count: 0,
    };

    /// The boxes `lit` (those with volume, the first [`MAX_LIT`]).
    pub fn new(lit: &[Aabb]) -> LitMedia {
        let mut media = LitMedia::NONE;
        for b in lit.iter().filter(|b| volume(b) > 0.0).take(MAX_LIT) {
            media.boxes[media.count] = *b;
            media.count += 1;
        }
        media
    }

    /// The boxes' mixture density `(1 / n) sum_k p_box,k(wi)` at `x`, per steradian.
    pub fn pdf(&self, x: Vec3, wi: Vec3) -> f32 {
        // `1 / wi` once for every box (`Aabb::intersect` bit for bit).
        let inv_d = [0, 1, 2].map(|a| 1.0 / wi[a]);
        let mut sum = 0.0;
        for b in &self.boxes[..self.count] {
            if let Some((t0, t1)) = b.intersect_inv(x, inv_d, 0.0, f32::INFINITY) {
                sum += (t1 * t1 * t1 - t0 * t0 * t0) / (3.0 * volume(b));
            }
        }
        sum / self.count as f32
    }

    /// A direction from `x` towards a point uniform in box `pick` for uniform `u`.
    pub fn sample(&self, x: Vec3, pick: usize, u: Vec3) -> Vec3 {
        let b = &self.boxes[pick];
        let y = b.min + u * (b.max - b.min);
        (y - x).normalize_or_zero()
    }
}

/// The volume of box `b`, m^3 (0 when empty or flat).
fn volume(b: &Aabb) -> f32 {
    let e = (b.max - b.min).max(Vec3::ZERO);
    e.x * e.y * e.z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The boxes' density integrates to the share of the boxes' points seen from `x` (1 from
    /// outside them, and from inside one), and sampling follows it: the mean of `1 / pdf` over
    /// drawn directions is the solid angle the boxes cover, by a fine grid over the sphere.
    #[test]
    fn box_density_integrates_to_one() {
        let media = LitMedia::new(&[
            Aabb::new(Vec3::new(1.0, -0.5, 2.0), Vec3::new(2.5, 1.0, 3.0)),
            Aabb::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.5, 1.0)),
        ]);
        for x in [Vec3::new(0.2, -2.0, 0.1), Vec3::new(0.0, 0.25, 0.0)] {
            let (mut total, mut covered) = (0.0f64, 0.0f64);
            let cell = crate::sampling::warp::direction_grid(1500, false, |wi| {
                let p = media.pdf(x, wi) as f64;
                total += p;
                covered += (p > 0.0) as u32 as f64;
            });
            (total, covered) = (total * cell, covered * cell);
            assert!(
                (total - 1.0).abs() < 3e-3,
                "{x}: density integrates to {total}"
            );
            let mut rng = crate::sampling::Rng::new(5, 6, 7);
            let n = 400_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let pick = (rng.uniform_f32() * 2.0) as usize;
                let u = Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
                let wi = media.sample(x, pick.min(1), u);
                sum += 1.0 / media.pdf(x, wi) as f64;
            }
            let mean = sum / n as f64;
            assert!(
                (mean - covered).abs() < 0.02 * covered,
                "{x}: solid angle {mean} against {covered}"
            );
        }
    }
}
