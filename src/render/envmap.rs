//! The environment map as a light: Blender's equirectangular convention, the radiance lookup,
//! and importance sampling of directions (pbrt-v3 `InfiniteAreaLight`, pbrt-v4
//! `ImageInfiniteLight`; PBR 3rd ed. sec. 14.2.4). Mirrored in `shaders/common/envmap.wgsl`.
//!
//! # Axes and the equirectangular convention (Cycles')
//! glTF is Y-up; Blender is Z-up: glTF `(x, y, z)` is Blender `(x, -z, y)`. A world direction
//! `w` (towards where the light comes from) is first put in Blender's axes, then rotated by the
//! Mapping node's Euler XYZ rotation `R = Rz(rz) Ry(ry) Rx(rx)` (Cycles `euler_to_transform`;
//! a Mapping node of type Point with unit scale and no location turns the vector `d` into
//! `R d`), and the rotated direction `d` is looked up as Cycles' `direction_to_equirectangular`
//! does:
//!
//! ```text
//! u = 0.5 - atan2(d.y, d.x) / (2 pi)     in [0, 1), left to right
//! v = acos(d.z) / pi                     in [0, 1], top row (zenith) to bottom row (nadir)
//! ```
//!
//! (Cycles writes `v` from the bottom, as Blender stores images; Brume's images run from the
//! top row, so Cycles' `1 - v` is Brume's `v`.) So the image centre looks along Blender +X
//! (glTF +X), the point a quarter of the way in looks along Blender +Y (glTF -Z), and the top
//! row is Blender +Z (glTF +Y). `tests/physics/envmap.rs` checks known directions against pixels.
//!
//! The lookup is bilinear between pixel centres, as Cycles' default Linear interpolation:
//! wrapping across the `u = 0 / 1` seam, clamped at the poles (Cycles repeats vertically too,
//! blending the top and bottom rows within half a pixel of the poles; Brume does not).
//!
//! # Sampling
//! Directions are drawn from a piecewise-constant distribution over the pixels, each pixel
//! weighted by the luminance of the map averaged over the pixel (the bilinear lookup's
//! integral: a `(1, 6, 1) / 8` tent over the 3 x 3 neighbours, so every pixel the lookup can
//! make bright has a non-zero weight and the estimator stays unbiased) times `sin(theta)` of
//! the pixel centre (the solid angle a pixel row subtends). A point `(u, v)` with density
//! `p(u, v)` is the direction above with solid-angle density
//! `p(u, v) / (2 pi^2 sin(theta))`, since `dOmega = sin(theta) dtheta dphi` and
//! `(theta, phi) = (pi v, 2 pi (0.5 - u))`.
// Comparisons are written negated (`!(pdf > 0.0)`) so that a NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

use crate::sampling::piecewise::PiecewiseConstant2D;
use crate::sampling::warp::{uniform_sphere, uniform_sphere_pdf};
use crate::scene::envmap::EnvironmentImage;

/// How next-event estimation draws environment directions (`--env-sampling`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum EnvSampling {
    /// In proportion to the map's luminance (the default).
    #[default]
    Importance,
    /// Uniformly over the sphere: the ablation baseline.
    Uniform,
}

impl std::fmt::Display for EnvSampling {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EnvSampling::Importance => "importance",
            EnvSampling::Uniform => "uniform",
        })
    }
}

/// glTF (Y-up) to Blender (Z-up) axes: `(x, y, z) -> (x, -z, y)`.
pub const BLENDER_FROM_GLTF: Mat3 = Mat3::from_cols(
    Vec3::new(1.0, 0.0, 0.0),
    Vec3::new(0.0, 0.0, 1.0),
    Vec3::new(0.0, -1.0, 0.0),
);

/// Blender's Mapping node rotation (Euler XYZ, radians): `Rz Ry Rx`, as Cycles'
/// `euler_to_transform` builds it.
pub fn mapping_rotation(euler: [f32; 3]) -> Mat3 {
    Mat3::from_rotation_z(euler[2])
        * Mat3::from_rotation_y(euler[1])
        * Mat3::from_rotation_x(euler[0])
}

/// The lookup frame of a map rotated by `euler`: Blender axes, then the Mapping rotation.
pub fn lookup_from_world(euler: [f32; 3]) -> Mat3 {
    mapping_rotation(euler) * BLENDER_FROM_GLTF
}

/// Cycles' `direction_to_equirectangular` for a unit direction `d` in the lookup frame, with
/// `v` from the top: `(u, v)` in `[0, 1)^2` (`u` wraps; `v = 1` only straight down).
#[inline]
pub fn direction_to_uv(d: Vec3) -> Vec2 {
    let u = 0.5 - d.y.atan2(d.x) * (0.5 / PI);
    // atan2 = -pi gives u = 1: the same column as u = 0.
    let u = if u >= 1.0 { u - 1.0 } else { u };
    let v = d.z.clamp(-1.0, 1.0).acos() / PI;
    Vec2::new(u, v)
}

/// The inverse of [`direction_to_uv`]: the unit direction of `(u, v)` in the lookup frame.
#[inline]
pub fn uv_to_direction(uv: Vec2) -> Vec3 {
    let phi = PI * (1.0 - 2.0 * uv.x);
    let theta = PI * uv.y;
    let (sin_t, cos_t) = theta.sin_cos();
    let (sin_p, cos_p) = phi.sin_cos();
    Vec3::new(sin_t * cos_p, sin_t * sin_p, cos_t)
}

/// Bilinear lookup of `image` at `(u, v)`: pixel `(i, j)` is centred at
/// `((i + 0.5) / w, (j + 0.5) / h)`; columns wrap, rows clamp.
pub fn bilinear(image: &EnvironmentImage, uv: Vec2) -> Vec3 {
    let (w, h) = (image.width as i64, image.height as i64);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let col = |i: i64| i.rem_euclid(w) as u32;
    let row = |j: i64| j.clamp(0, h - 1) as u32;
    let p = |i: i64, j: i64| Vec3::from(image.at(col(i), row(j)));
    let top = p(x0, y0) * (1.0 - fx) + p(x0 + 1, y0) * fx;
    let bottom = p(x0, y0 + 1) * (1.0 - fx) + p(x0 + 1, y0 + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

/// Rec. 709 luminance.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The sampling weight of every pixel: the luminance of the bilinear lookup averaged over the
/// pixel (`(1, 6, 1) / 8` in each axis, columns wrapping, rows clamped) times `sin(theta)` at
/// the pixel centre.
pub fn sampling_weights(image: &EnvironmentImage) -> Vec<f32> {
    let (w, h) = (image.width as i64, image.height as i64);
    let lum: Vec<f32> = image
        .rgb
        .iter()
        .map(|&c| luminance(Vec3::from(c)))
        .collect();
    let at = |i: i64, j: i64| lum[(j.clamp(0, h - 1) * w + i.rem_euclid(w)) as usize];
    let tent = [1.0 / 8.0, 6.0 / 8.0, 1.0 / 8.0];
    let mut out = Vec::with_capacity(lum.len());
    for j in 0..h {
        let sin_theta = (PI * (j as f32 + 0.5) / h as f32).sin();
        for i in 0..w {
            let mut s = 0.0f32;
            for (dj, wj) in tent.iter().enumerate() {
                for (di, wi) in tent.iter().enumerate() {
                    s += wi * wj * at(i + di as i64 - 1, j + dj as i64 - 1);
                }
            }
            out.push(s * sin_theta);
        }
    }
    out
}

/// A direction drawn towards the environment.
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    /// Unit world direction towards the environment.
    pub wi: Vec3,
    /// Radiance arriving along `-wi`.
    pub le: Vec3,
    /// Solid-angle density of `wi`.
    pub pdf: f32,
}

/// An environment map ready to look up and sample.
pub struct EnvironmentMap {
    pub image: Arc<EnvironmentImage>,
    /// `color * strength`.
    pub scale: Vec3,
    /// World (glTF) directions to the lookup frame (a rotation: its inverse is its transpose).
    pub lookup_from_world: Mat3,
    /// Over the pixels, weights from [`sampling_weights`].
    pub distribution: PiecewiseConstant2D,
    pub sampling: EnvSampling,
}

impl EnvironmentMap {
    /// `None` when the map is black everywhere (it then emits nothing).
    pub fn new(image: Arc<EnvironmentImage>, scale: Vec3, rotation: [f32; 3]) -> Option<Self> {
        let distribution = PiecewiseConstant2D::new(
            sampling_weights(&image),
            image.width as usize,
            image.height as usize,
        );
        (distribution.integral > 0.0).then(|| EnvironmentMap {
            image,
            scale,
            lookup_from_world: lookup_from_world(rotation),
            distribution,
            sampling: EnvSampling::Importance,
        })
    }

    /// Radiance arriving from world direction `w` (unit; the direction towards the sky).
    #[inline]
    pub fn le(&self, w: Vec3) -> Vec3 {
        self.scale * bilinear(&self.image, direction_to_uv(self.lookup_from_world * w))
    }

    /// Draws a direction with `u` in `[0, 1)^2`.
    pub fn sample(&self, u: Vec2) -> Option<EnvSample> {
        match self.sampling {
            EnvSampling::Uniform => {
                let wi = uniform_sphere(u);
                Some(EnvSample {
                    wi,
                    le: self.le(wi),
                    pdf: uniform_sphere_pdf(),
                })
            }
            EnvSampling::Importance => {
                let s = self.distribution.sample(u.to_array())?;
                let uv = Vec2::from(s.uv);
                let wi = self.lookup_from_world.transpose() * uv_to_direction(uv);
                // The density of the direction as `pdf` computes it, not of the cell drawn:
                // the two differ only where rounding moved the direction across a cell edge,
                // and MIS needs the same value whichever strategy produced the direction.
                // (PBR 3rd ed. computes it the same way.)
                let pdf = self.pdf(wi);
                if !(pdf > 0.0) {
                    return None;
                }
                Some(EnvSample {
                    wi,
                    le: self.scale * bilinear(&self.image, uv),
                    pdf,
                })
            }
        }
    }

    /// Solid-angle density of [`Self::sample`] drawing world direction `w`.
    pub fn pdf(&self, w: Vec3) -> f32 {
        match self.sampling {
            EnvSampling::Uniform => uniform_sphere_pdf(),
            EnvSampling::Importance => {
                let d = self.lookup_from_world * w;
                let sin_theta = (1.0 - d.z * d.z).max(0.0).sqrt();
                if !(sin_theta > 0.0) {
                    return 0.0;
                }
                self.distribution.pdf(direction_to_uv(d).to_array()) / (2.0 * PI * PI * sin_theta)
            }
        }
    }
}

/// The environment light: constant radiance, or a map times it.
pub struct EnvLight {
    /// `color * strength` (the constant radiance without a map).
    pub radiance: Vec3,
    pub map: Option<EnvironmentMap>,
}

impl EnvLight {
    /// From the scene's environment; `None` when it emits nothing. A map whose pixels are all
    /// equal is the constant environment and is rendered as one (same estimator, same noise).
    pub fn new(env: &crate::scene::Environment) -> Option<EnvLight> {
        let mut radiance = Vec3::from(env.radiance);
        let mut map = None;
        if let Some(image) = &env.image {
            match image.constant() {
                Some(c) => radiance *= Vec3::from(c),
                None => {
                    map = Some(EnvironmentMap::new(image.clone(), radiance, env.rotation)?);
                }
            }
        }
        (radiance.max_element() > 0.0).then_some(EnvLight { radiance, map })
    }

    /// Radiance arriving from world direction `w`.
    #[inline]
    pub fn le(&self, w: Vec3) -> Vec3 {
        match &self.map {
            None => self.radiance,
            Some(m) => m.le(w),
        }
    }

    /// Draws a direction towards the environment.
    pub fn sample(&self, u: Vec2) -> Option<EnvSample> {
        match &self.map {
            None => Some(EnvSample {
                wi: uniform_sphere(u),
                le: self.radiance,
                pdf: uniform_sphere_pdf(),
            }),
            Some(m) => m.sample(u),
        }
    }

    /// Solid-angle density of [`Self::sample`] drawing `w`.
    pub fn pdf(&self, w: Vec3) -> f32 {
        match &self.map {
            None => uniform_sphere_pdf(),
            Some(m) => m.pdf(w),
        }
    }
}
