//! Warps from the unit square to directions, and the orthonormal frames they are expressed in.
//! Each warp has its pdf (per steradian) next to it; `tests/physics/sampling_warp.rs` chi-square tests
//! every pair.
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

pub const INV_4PI: f32 = 0.25 * FRAC_1_PI;

/// `(sin_theta cos phi, sin_theta sin phi, cos_theta)`.
#[inline]
pub fn spherical_direction(sin_theta: f32, cos_theta: f32, phi: f32) -> Vec3 {
    let (s, c) = phi.sin_cos();
    Vec3::new(sin_theta * c, sin_theta * s, cos_theta)
}

/// Uniform on the unit sphere (Archimedes: z uniform in [-1, 1]).
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    spherical_direction(r, z, 2.0 * PI * u.y)
}

#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    INV_4PI
}

/// Uniform on the +z hemisphere.
#[inline]
pub fn uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    spherical_direction(r, z, 2.0 * PI * u.y)
}

#[inline]
pub fn uniform_hemisphere_pdf() -> f32 {
    0.5 * FRAC_1_PI
}

/// Shirley-Chiu concentric map of the square onto the unit disk (area preserving up to a
/// constant, low distortion, so stratification survives).
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, 0.25 * PI * (o.y / o.x))
    } else {
        (o.y, 0.5 * PI - 0.25 * PI * (o.x / o.y))
    };
    let (s, c) = theta.sin_cos();
    r * Vec2::new(c, s)
}

/// Cosine-weighted +z hemisphere (Malley's method: lift the concentric disk).
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// An orthonormal frame `(x, y, z)`, right-handed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub x: Vec3,
    pub y: Vec3,
    pub z: Vec3,
}

impl Frame {
    /// A frame whose `z` is the unit vector `n`: the branchless construction of Duff et al.
    /// (2017, "Building an Orthonormal Basis, Revisited", JCGT 6(1)), continuous except on the
    /// `n.z = 0` sign flip and free of the division by `1 + n.z` near `n.z = -1`.
    pub fn from_z(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { x, y, z: n }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    #[inline]
    pub fn from_local(&self, v: Vec3) -> Vec3 {
        v.x * self.x + v.y * self.y + v.z * self.z
    }
}

/// Test quadrature over directions: calls `f(wi)` at the centres of an `m x m` grid in
/// `(cos theta, phi)` over the sphere (over `z > 0` with `upper`); returns a cell's solid angle.
#[cfg(test)]
pub(crate) fn direction_grid(m: usize, upper: bool, mut f: impl FnMut(Vec3)) -> f64 {
    let lo = if upper { 0.0 } else { -1.0 };
    for i in 0..m {
        let cos = lo + (1.0 - lo) * (i as f64 + 0.5) / m as f64;
        let sin = (1.0 - cos * cos).sqrt();
        for j in 0..m {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / m as f64;
            f(glam::DVec3::new(sin * phi.cos(), sin * phi.sin(), cos).as_vec3());
        }
    }
    (1.0 - lo) * std::f64::consts::TAU / (m * m) as f64
}
