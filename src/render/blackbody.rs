//! Blackbody colour as Cycles' Principled Volume uses it: linear Rec.709 RGB of Planck's law,
//! normalised to unit luminance, so that intensity is carried by the Stefan-Boltzmann factor
//! alone (`(5.670373e-8 * 1e-6 / pi) * mix(1, T^4, I) * C(T)`, as Cycles 5 renders it on a
//! homogeneous cube). Like Cycles, temperatures are clamped to [800 K, 12000 K] for the colour.
//!
//! The CIE 1931 2-degree colour matching functions are the CIE's own table at 5 nm (CIE 015:2018,
//! as distributed by the CIE and colour-science's `MSDS_CMFS`), not an analytic multi-lobe
//! Gaussian fit (Wyman, Sloan & Shirley 2013): the fit halves `x_bar` beyond 700 nm, where an
//! 800 K body emits, and would put the red channel 11 % below Cycles' at 800 K. With the table,
//! 800 K gives (5.406, -0.201, -0.082), Cycles' own (5.413, -0.203, -0.082).
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

/// CIE 1931 2-degree `(nm, [x_bar, y_bar, z_bar])` from 360 nm to 830 nm every 5 nm, read
/// once from the table beside this file.
fn cie_1931_2deg() -> &'static [(f64, [f64; 3])] {
    static CIE: OnceLock<Vec<(f64, [f64; 3])>> = OnceLock::new();
    CIE.get_or_init(|| {
        include_str!("cie_1931_2deg.csv")
            .lines()
            .filter(|l| !l.starts_with('#') && !l.starts_with("nm,"))
            .map(|l| {
                let v: Vec<f64> = l
                    .split(',')
                    .map(|x| x.parse().expect("the CIE table holds numbers"))
                    .collect();
                (v[0], [v[1], v[2], v[3]])
            })
            .collect()
    })
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
    // The colour is normalised, so the step's width cancels; at 5 nm the sum agrees with a
    // 1 nm one to 2e-5 (Planck's curve is smooth on that scale).
    let mut xyz = [0.0f64; 3];
    for (nm, c) in cie_1931_2deg() {
        let p = planck(*nm, t);
        for k in 0..3 {
            xyz[k] += p * c[k];
        }
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
    fn matches_the_cie_1931_table_at_1_nm() {
        // Reference: the same integral over colour-science's 1 nm CIE 1931 2-degree table
        // (computed outside Brume). Cycles' own fit gives (5.413, -0.203, -0.082) at 800 K.
        for (t, rgb) in [
            (800.0, [5.4061, -0.2011, -0.0823]),
            (1500.0, [3.2640, 0.4341, -0.0642]),
            (3000.0, [1.7706, 0.8443, 0.2721]),
            (6500.0, [1.0432, 0.9836, 1.0352]),
        ] {
            let c = blackbody_rgb_exact(t);
            for k in 0..3 {
                assert!((c[k] - rgb[k]).abs() < 1e-3, "{t} K: {c} vs {rgb:?}");
            }
        }
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
