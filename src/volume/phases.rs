//! The phase functions a medium can have: Henyey-Greenstein, a blend of two, Draine, the
//! Jendersie-d'Eon fit of Mie scattering by water droplets, and Rayleigh. Each is evaluated
//! exactly and sampled exactly (the sample's pdf is its value), with `wo` and `wi` pointing
//! away from the scattering point as in [`super::phase`]: the scattering cosine is
//! `mu = -dot(wo, wi)`.
use glam::{Vec2, Vec3};

use super::phase::{HenyeyGreenstein, PhaseSample};
use crate::sampling::warp::{Frame, INV_4PI};

/// Draine (2003, "Scattering by interstellar dust grains", ApJ 598), Henyey-Greenstein
/// reshaped by a `1 + alpha mu^2` factor:
///
/// ```text
/// p(mu) = HG_g(mu) * (1 + alpha mu^2) / (1 + alpha (1 + 2 g^2) / 3)
/// ```
///
/// with `alpha >= -1` (0 is Henyey-Greenstein, 1 with `g = 0` is Rayleigh). Sampled exactly by
/// rejection from `HG_g`: accept with `(1 + alpha mu^2) / max(1, 1 + alpha)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Draine {
    pub hg: HenyeyGreenstein,
    pub alpha: f32,
}

impl Draine {
    pub fn new(g: f32, alpha: f32) -> Self {
        Draine {
            hg: HenyeyGreenstein::new(g),
            alpha,
        }
    }

    /// The mean scattering cosine, `g (1 + alpha (3 + 2 g^2) / 5) / (1 + alpha (1 + 2 g^2) / 3)`
    /// (Draine's equation 4).
    pub fn mean_cosine(&self) -> f32 {
        let (g, alpha) = (self.hg.g, self.alpha);
        g * (1.0 + alpha * (3.0 + 2.0 * g * g) / 5.0) / (1.0 + alpha * (1.0 + 2.0 * g * g) / 3.0)
    }

    fn shape(&self, mu: f32) -> f32 {
        let g = self.hg.g;
        (1.0 + self.alpha * mu * mu) / (1.0 + self.alpha * (1.0 + 2.0 * g * g) / 3.0)
    }

    pub fn p(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.hg.p(wo, wi) * self.shape(-wo.dot(wi))
    }

    /// The first candidate from `u`, any further ones from `more`.
    pub fn sample(&self, wo: Vec3, u: Vec2, more: &mut dyn FnMut() -> Vec2) -> PhaseSample {
        let bound = (1.0 + self.alpha).max(1.0);
        let mut u = u;
        // Accepted with probability at least 1/3 (alpha >= -1): 256 tries fail with
        // probability below 1e-45.
        for _ in 0..256 {
            let s = self.hg.sample(wo, u);
            let mu = -wo.dot(s.wi);
            if more().x * bound < 1.0 + self.alpha * mu * mu {
                return exact(s.wi, self.p(wo, s.wi));
            }
            u = more();
        }
        let s = self.hg.sample(wo, u);
        exact(s.wi, self.p(wo, s.wi))
    }
}

/// The phase functions a medium can have.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    HenyeyGreenstein(HenyeyGreenstein),
    /// `w a + (1 - w) b`, two Henyey-Greenstein lobes (a forward peak and a back lobe).
    TwoLobe {
        a: HenyeyGreenstein,
        b: HenyeyGreenstein,
        w: f32,
    },
    Draine(Draine),
    /// Jendersie and d'Eon (2023, "An approximate Mie scattering function for fog and cloud
    /// rendering", SIGGRAPH Talks): `(1 - w_d) HG_{g_hg} + w_d Draine_{g_d, alpha}`, the four
    /// parameters fitted to Mie theory as functions of the droplet diameter ([`Phase::mie`]).
    Mie {
        hg: HenyeyGreenstein,
        draine: Draine,
        w_d: f32,
    },
    /// Rayleigh: `p(mu) = 3 (1 + mu^2) / (16 pi)`, sampled by inverting its cubic CDF.
    Rayleigh,
}

/// A sample whose pdf is the phase function's value.
fn exact(wi: Vec3, pdf: f32) -> PhaseSample {
    PhaseSample {
        wi,
        pdf,
        weight: 1.0,
    }
}

impl Phase {
    /// Henyey-Greenstein with mean cosine `g`.
    pub fn hg(g: f32) -> Self {
        Phase::HenyeyGreenstein(HenyeyGreenstein::new(g))
    }

    /// The Jendersie-d'Eon fit for water droplets of `diameter` micrometres (their equations
    /// for `d <= 0.1`, `0.1 < d < 1.5`, `1.5 <= d < 5` and `5 <= d <= 50`); `None` outside
    /// `(0, 50]`.
    pub fn mie(diameter: f32) -> Option<Self> {
        let d = diameter as f64;
        if !(d > 0.0 && d <= 50.0) {
            return None;
        }
        let ln = d.ln();
        let (g_hg, g_d, alpha, w_d) = if d <= 0.1 {
            (
                13.8 * d * d,
                1.1456 * d * (9.29044 * d).sin(),
                250.0,
                0.252977 - 312.983 * d.powf(4.3),
            )
        } else if d < 1.5 {
            let c = 1.19692 * ((ln - 0.238604) * (ln + 1.00667) / (0.507522 - 0.15677 * ln)).cos()
                + 1.37932 * ln
                + 0.0625835;
            (
                0.862 - 0.143 * ln * ln,
                0.379685 * c.cos() + 0.344213,
                250.0,
                0.146209 * (3.38707 * ln + 2.11193).cos() + 0.316072 + 0.0778917 * ln,
            )
        } else if d < 5.0 {
            let lnln = ln.ln();
            (
                0.0604931 * lnln + 0.940256,
                0.500411 - 0.081287 / (-2.0 * ln + ln.tan() + 1.27551),
                7.30354 * ln + 6.31675,
                0.026914 * (ln - (5.68947 * (lnln - 0.0292149)).cos()) + 0.376475,
            )
        } else {
            (
                (-0.0990567 / (d - 1.67154)).exp(),
                (-2.20679 / (d + 3.91029) - 0.428934).exp(),
                (3.62489 - 8.29288 / (d + 5.52825)).exp(),
                (-0.599085 / (d - 0.641583) - 0.665888).exp(),
            )
        };
        Some(Phase::Mie {
            hg: HenyeyGreenstein::new(g_hg as f32),
            draine: Draine::new(g_d as f32, alpha as f32),
            w_d: w_d.clamp(0.0, 1.0) as f32,
        })
    }

    /// The mean scattering cosine `<mu>` (forward positive), which equiangular sampling
    /// shapes its density by (`integrator::equiangular`).
    pub fn mean_cosine(&self) -> f32 {
        match self {
            Phase::HenyeyGreenstein(hg) => hg.g,
            Phase::TwoLobe { a, b, w } => w * a.g + (1.0 - w) * b.g,
            Phase::Draine(d) => d.mean_cosine(),
            Phase::Mie { hg, draine, w_d } => (1.0 - w_d) * hg.g + w_d * draine.mean_cosine(),
            Phase::Rayleigh => 0.0,
        }
    }

    /// `p(wo, wi)` per steradian.
    #[inline]
    pub fn p(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Phase::HenyeyGreenstein(hg) => hg.p(wo, wi),
            Phase::TwoLobe { a, b, w } => w * a.p(wo, wi) + (1.0 - w) * b.p(wo, wi),
            Phase::Draine(d) => d.p(wo, wi),
            Phase::Mie { hg, draine, w_d } => (1.0 - w_d) * hg.p(wo, wi) + w_d * draine.p(wo, wi),
            Phase::Rayleigh => {
                let mu = -wo.dot(wi);
                3.0 * INV_4PI / 4.0 * (1.0 + mu * mu)
            }
        }
    }

    /// Samples `wi` given `wo`: `u` decides (a blend's lobe by `u.x`, rescaled), `more` gives
    /// further points where a rejection needs them (Draine).
    pub fn sample(&self, wo: Vec3, u: Vec2, more: &mut dyn FnMut() -> Vec2) -> PhaseSample {
        // A blend picks its lobe with u.x and reuses the rest of u.x, so u stays stratified.
        let pick = |w: f32, u: Vec2| -> (bool, Vec2) {
            if u.x < w {
                (true, Vec2::new(u.x / w, u.y))
            } else {
                (
                    false,
                    Vec2::new(((u.x - w) / (1.0 - w)).min(1.0 - f32::EPSILON), u.y),
                )
            }
        };
        let wi = match self {
            Phase::HenyeyGreenstein(hg) => return hg.sample(wo, u),
            Phase::Draine(d) => return d.sample(wo, u, more),
            Phase::TwoLobe { a, b, w } => match pick(*w, u) {
                (true, u) => a.sample(wo, u).wi,
                (false, u) => b.sample(wo, u).wi,
            },
            Phase::Mie { hg, draine, w_d } => match pick(*w_d, u) {
                (true, u) => draine.sample(wo, u, more).wi,
                (false, u) => hg.sample(wo, u).wi,
            },
            Phase::Rayleigh => rayleigh_direction(wo, u),
        };
        exact(wi, self.p(wo, wi))
    }

    /// The Henyey-Greenstein `g` where the phase function is one (the GPU variants without
    /// `FEATURE_PHASES` render only those).
    pub fn henyey_greenstein_g(&self) -> Option<f32> {
        match self {
            Phase::HenyeyGreenstein(hg) => Some(hg.g),
            _ => None,
        }
    }

    /// The name a scene writes for it.
    pub fn name(&self) -> &'static str {
        match self {
            Phase::HenyeyGreenstein(_) => "henyey-greenstein",
            Phase::TwoLobe { .. } => "two-lobe",
            Phase::Draine(_) => "draine",
            Phase::Mie { .. } => "mie",
            Phase::Rayleigh => "rayleigh",
        }
    }
}

/// Rayleigh's exact inversion: `F(mu) = (mu^3 + 3 mu + 4) / 8 = u` is the depressed cubic
/// `mu^3 + 3 mu - 4 (2u - 1) = 0`, whose one real root is `z - 1/z` with
/// `z = cbrt(2 xi + sqrt(4 xi^2 + 1))`, `xi = 2u - 1` (Cardano).
fn rayleigh_direction(wo: Vec3, u: Vec2) -> Vec3 {
    let xi = 2.0 * u.x as f64 - 1.0;
    let z = (2.0 * xi + (4.0 * xi * xi + 1.0).sqrt()).cbrt();
    let mu = ((z - 1.0 / z) as f32).clamp(-1.0, 1.0);
    let sin_theta = (1.0 - mu * mu).max(0.0).sqrt();
    let (sp, cp) = (2.0 * std::f32::consts::PI * u.y).sin_cos();
    Frame::from_z(-wo)
        .from_local(Vec3::new(sin_theta * cp, sin_theta * sp, mu))
        .normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `mean_cosine` is `int mu p(mu)` over the sphere, by quadrature in `mu`, for every kind.
    #[test]
    fn mean_cosine_is_the_integral_of_mu() {
        let kinds = [
            Phase::hg(0.6),
            Phase::hg(-0.3),
            Phase::TwoLobe {
                a: HenyeyGreenstein::new(0.8),
                b: HenyeyGreenstein::new(-0.4),
                w: 0.7,
            },
            Phase::Draine(Draine::new(0.5, 1.5)),
            Phase::mie(8.0).unwrap(),
            Phase::Rayleigh,
        ];
        let wo = Vec3::Z;
        for phase in kinds {
            let m = 200_000;
            let mut sum = 0.0f64;
            for i in 0..m {
                let mu = -1.0 + 2.0 * (i as f64 + 0.5) / m as f64;
                let sin = (1.0 - mu * mu).sqrt() as f32;
                // mu = -dot(wo, wi): wi = -mu along z.
                let wi = Vec3::new(sin, 0.0, -mu as f32);
                sum += mu * phase.p(wo, wi) as f64;
            }
            let mean = sum * 2.0 / m as f64 * std::f64::consts::TAU;
            let expected = phase.mean_cosine() as f64;
            assert!(
                (mean - expected).abs() < 2e-3,
                "{}: {mean} against {expected}",
                phase.name()
            );
        }
    }
}
