//! Surface scattering for glTF's metallic-roughness materials, as far as Brume approximates
//! them: a Lambertian base (`base * (1 - metallic)`) plus a GGX (Trowbridge-Reitz) microfacet
//! reflection with Schlick's Fresnel (`F0 = mix(0.04, base, metallic)`) and Smith's
//! height-correlated masking; the two lobes add without energy compensation. Transmissive
//! materials (`KHR_materials_transmission`) are smooth dielectrics (roughness ignored).
//! Textures are not decoded: factors only.
//!
//! Everything works in a local frame whose z is the shading normal flipped to `wo`'s side.
use crate::math::luminance;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use crate::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf};

/// Lobes of one opaque surface point.
#[derive(Clone, Copy, Debug)]
pub struct Principled {
    pub diffuse: Vec3,
    pub f0: Vec3,
    /// GGX alpha (roughness^2, kept away from 0 so the lobe stays finite).
    pub alpha: f32,
    /// Probability of sampling the specular lobe.
    pub p_spec: f32,
}

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// `f * |cos| / pdf`.
    pub weight: Vec3,
    pub pdf: f32,
}

impl Principled {
    pub fn new(base: Vec3, metallic: f32, roughness: f32) -> Self {
        let diffuse = base * (1.0 - metallic);
        let f0 = Vec3::splat(0.04).lerp(base, metallic);
        let (ls, ld) = (luminance(f0), luminance(diffuse));
        let p_spec = if ld <= 0.0 {
            1.0
        } else if ls <= 0.0 {
            0.0
        } else {
            (ls / (ls + ld)).clamp(0.1, 0.9)
        };
        Principled {
            diffuse,
            f0,
            alpha: (roughness * roughness).max(2e-3),
            p_spec,
        }
    }

    fn d(&self, cos_h: f32) -> f32 {
        let a2 = self.alpha * self.alpha;
        let c2 = cos_h * cos_h;
        let t = c2 * (a2 - 1.0) + 1.0;
        a2 / (PI * t * t)
    }

    fn lambda(&self, cos: f32) -> f32 {
        let c2 = (cos * cos).max(1e-12);
        let tan2 = (1.0 - c2) / c2;
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    fn fresnel(&self, cos: f32) -> Vec3 {
        let m = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
        self.f0 + (Vec3::ONE - self.f0) * m
    }

    /// `f(wo, wi)` in the local frame (both above the surface, else 0).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let mut f = self.diffuse / PI;
        if self.p_spec > 0.0 {
            let h = (wo + wi).normalize();
            let g = 1.0 / (1.0 + self.lambda(wo.z) + self.lambda(wi.z));
            f += self.fresnel(wo.dot(h)) * (self.d(h.z) * g / (4.0 * wo.z * wi.z));
        }
        f
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let pdf_spec = self.d(h.z) * h.z / (4.0 * wo.dot(h).max(1e-8));
        self.p_spec * pdf_spec + (1.0 - self.p_spec) * cosine_hemisphere_pdf(wi.z)
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.p_spec {
            // Distribution of normals D(h) cos(h): cos^2 = (1 - u) / (1 + (a^2 - 1) u).
            let a2 = self.alpha * self.alpha;
            let cos2 = (1.0 - u.x) / (1.0 + (a2 - 1.0) * u.x);
            let cos_h = cos2.sqrt();
            let sin_h = (1.0 - cos2).max(0.0).sqrt();
            let phi = 2.0 * PI * u.y;
            let h = Vec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
            2.0 * wo.dot(h) * h - wo
        } else {
            cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval(wo, wi) * wi.z / pdf,
            pdf,
        })
    }
}

/// Fresnel reflectance of a smooth dielectric for `cos_i` (from the incident side) and
/// relative index `eta = n_t / n_i`; 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

/// Refracts `wo` (pointing away, on the side of `n`) through a surface with relative index
/// `eta = n_t / n_i`; `None` under total internal reflection.
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = n.dot(wo);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / eta + (cos_i / eta - cos_t) * n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Monte Carlo estimate of the albedo agrees between sampling and eval/pdf, and stays <= 1.
    #[test]
    fn sampling_matches_eval_over_pdf() {
        let mut rng = Rng::new(1, 2, 3);
        for (base, metallic, rough) in [
            (Vec3::splat(0.8), 0.0, 1.0),
            (Vec3::splat(0.9), 1.0, 0.3),
            (Vec3::new(0.5, 0.2, 0.1), 0.5, 0.6),
        ] {
            let b = Principled::new(base, metallic, rough);
            let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
            let n = 200_000;
            let mut sum = Vec3::ZERO;
            for _ in 0..n {
                if let Some(s) = b.sample(wo, rng.uniform_f32(), rng.uniform_vec2()) {
                    sum += s.weight;
                }
            }
            let albedo = sum / n as f32;
            assert!(albedo.max_element() <= 1.02, "{albedo}");
            // Uniform-hemisphere estimate of the same integral.
            let mut sum_u = Vec3::ZERO;
            for _ in 0..n {
                let w = crate::sampling::warp::uniform_hemisphere(rng.uniform_vec2());
                sum_u += b.eval(wo, w) * w.z * 2.0 * PI;
            }
            let ref_albedo = sum_u / n as f32;
            assert!(
                (albedo - ref_albedo).abs().max_element() < 0.03,
                "{albedo} vs {ref_albedo}"
            );
        }
    }
}
