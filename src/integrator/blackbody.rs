//! Blackbody colour as Cycles' Principled Volume uses it: linear Rec.709 RGB of Planck's law,
//! normalised to unit luminance, so that intensity is carried by the Stefan-Boltzmann factor
//! alone (`(5.670373e-8 * 1e-6 / pi) * mix(1, T^4, I) * C(T)`, measured on Cycles 5; see
//! BUILD-NOTES.md). Like Cycles, temperatures are clamped to [800 K, 12000 K] for the colour.
//!
//! The CIE 1931 matching functions come from the multi-lobe Gaussian fit of Wyman, Sloan &
//! Shirley (2013), "Simple Analytic Approximations to the CIE XYZ Color Matching Functions",
//! JCGT 2(2), accurate to well under a percent of the tabulated functions.
use std::sync::OnceLock;

use glam::Vec3;

/// Coldest temperature of the colour table, kelvin (colder clamps to it).
pub const T_MIN: f32 = 800.0;
/// Hottest temperature of the colour table, kelvin.
pub const T_MAX: f32 = 12000.0;
/// Kelvin between table entries.
pub const TABLE_STEP: f32 = 10.0;
/// Entries of the colour table (`T_MIN`, `T_MIN + TABLE_STEP`, ..., `T_MAX`).
pub const TABLE_LEN: usize = ((T_MAX - T_MIN) / TABLE_STEP) as usize + 1;

/// Cycles' scale: Stefan-Boltzmann constant, 1e-6, over pi.
pub const STEFAN_BOLTZMANN_SCALE: f32 = 5.670373e-8 * 1e-6 / std::f32::consts::PI;

fn lobe(x: f64, mu: f64, s1: f64, s2: f64) -> f64 {
    let s = if x < mu { s1 } else { s2 };
    (-0.5 * ((x - mu) / s).powi(2)).exp()
}

fn cie_xyz(lambda_nm: f64) -> [f64; 3] {
    let l = lambda_nm;
    let x = 1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7)
        - 0.065 * lobe(l, 501.1, 20.4, 26.2);
    let y = 0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1);
    let z = 1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8);
    [x, y, z]
}

/// Planck's spectral radiance up to a constant factor (the colour is normalised anyway).
fn planck(lambda_nm: f64, t: f64) -> f64 {
    const C2: f64 = 1.4387769e-2; // h c / k, m K
    let l = lambda_nm * 1e-9;
    1.0 / (l.powi(5) * ((C2 / (l * t)).exp() - 1.0))
}

/// Unit-luminance linear Rec.709 colour of a blackbody at `t` kelvin (computed, not cached).
pub fn blackbody_rgb_exact(t: f32) -> Vec3 {
    let t = (t as f64).clamp(T_MIN as f64, T_MAX as f64);
    let mut xyz = [0.0f64; 3];
    let mut lambda = 360.0;
    while lambda <= 830.0 {
        let p = planck(lambda, t);
        let c = cie_xyz(lambda);
        for k in 0..3 {
            xyz[k] += p * c[k];
        }
        lambda += 1.0;
    }
    let [x, y, z] = xyz.map(|v| v / xyz[1]);
    Vec3::new(
        (3.2404542 * x - 1.5371385 * y - 0.4985314 * z) as f32,
        (-0.9692660 * x + 1.8760108 * y + 0.0415560 * z) as f32,
        (0.0556434 * x - 0.2040259 * y + 1.0572252 * z) as f32,
    )
}

/// The unit-luminance colour table [`blackbody_rgb`] interpolates (uploaded as is by the GPU
/// backend).
pub fn table() -> &'static [Vec3] {
    static TABLE: OnceLock<Vec<Vec3>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..TABLE_LEN)
            .map(|i| blackbody_rgb_exact(T_MIN + i as f32 * TABLE_STEP))
            .collect()
    })
}

/// Unit-luminance blackbody colour, linearly interpolated from a 10 K table.
pub fn blackbody_rgb(t: f32) -> Vec3 {
    let table = table();
    let x = ((t.clamp(T_MIN, T_MAX) - T_MIN) / TABLE_STEP).max(0.0);
    let i = (x as usize).min(table.len() - 2);
    let f = x - i as f32;
    table[i].lerp(table[i + 1], f)
}

/// Emitted radiance per metre of Cycles' Principled Volume blackbody term at `t` kelvin with
/// blackbody intensity `intensity`.
///
/// `T^4` is formed in f64: in f32 it overflows above 4.3e9 K although the radiance itself stays
/// representable up to ~1e13 K (the scene loader refuses temperatures above
/// `scene::MAX_TEMPERATURE_K`, so a loaded scene never reaches that).
pub fn blackbody_emission(t: f32, intensity: f32) -> Vec3 {
    let t = t.max(0.0);
    let t2 = t as f64 * t as f64;
    let scale =
        STEFAN_BOLTZMANN_SCALE as f64 * ((1.0 - intensity as f64) + intensity as f64 * t2 * t2);
    blackbody_rgb(t) * scale as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_luminance_and_warm_to_cool() {
        for t in [1000.0, 1500.0, 3000.0, 6500.0, 10000.0] {
            let c = blackbody_rgb(t);
            let lum = 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
            assert!((lum - 1.0).abs() < 2e-3, "{t} K: luminance {lum}");
        }
        let (warm, cool) = (blackbody_rgb(1500.0), blackbody_rgb(10000.0));
        assert!(warm.x > warm.z && cool.z > cool.x);
        // D65 is close to 6504 K: near white.
        let d65 = blackbody_rgb(6504.0);
        assert!((d65 - Vec3::ONE).abs().max_element() < 0.08, "{d65}");
    }

    #[test]
    fn emission_is_finite_up_to_the_loader_limit() {
        // Regression (fuzz_inputs): T^4 in f32 overflowed at 4.3e9 K, giving inf radiance.
        for t in [5e9f32, 1e11, crate::scene::MAX_TEMPERATURE_K] {
            let e = blackbody_emission(t, 1.0);
            assert!(e.is_finite() && e.max_element() > 0.0, "{t} K: {e}");
        }
        let r = blackbody_emission(2000.0, 1.0).x as f64;
        let expected =
            STEFAN_BOLTZMANN_SCALE as f64 * 2000f64.powi(4) * blackbody_rgb(2000.0).x as f64;
        assert!((r / expected - 1.0).abs() < 1e-6);
    }
}
