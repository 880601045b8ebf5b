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

/// CIE 1931 2-degree `x_bar, y_bar, z_bar` from 360 nm to 830 nm every 5 nm.
const CIE_1931_2DEG: [[f64; 3]; 95] = [
    [0.0001299, 3.917e-06, 0.0006061],   // 360
    [0.0002321, 6.965e-06, 0.001086],    // 365
    [0.0004149, 1.239e-05, 0.001946],    // 370
    [0.0007416, 2.202e-05, 0.003486],    // 375
    [0.001368, 3.9e-05, 0.006450001],    // 380
    [0.002236, 6.4e-05, 0.01054999],     // 385
    [0.004243, 0.00012, 0.02005001],     // 390
    [0.00765, 0.000217, 0.03621],        // 395
    [0.01431, 0.000396, 0.06785001],     // 400
    [0.02319, 0.00064, 0.1102],          // 405
    [0.04351, 0.00121, 0.2074],          // 410
    [0.07763, 0.00218, 0.3713],          // 415
    [0.13438, 0.004, 0.6456],            // 420
    [0.21477, 0.0073, 1.03905],          // 425
    [0.2839, 0.0116, 1.3856],            // 430
    [0.3285, 0.01684, 1.62296],          // 435
    [0.34828, 0.023, 1.74706],           // 440
    [0.34806, 0.0298, 1.7826],           // 445
    [0.3362, 0.038, 1.77211],            // 450
    [0.3187, 0.048, 1.7441],             // 455
    [0.2908, 0.06, 1.6692],              // 460
    [0.2511, 0.0739, 1.5281],            // 465
    [0.19536, 0.09098, 1.28764],         // 470
    [0.1421, 0.1126, 1.0419],            // 475
    [0.09564, 0.13902, 0.8129501],       // 480
    [0.05795001, 0.1693, 0.6162],        // 485
    [0.03201, 0.20802, 0.46518],         // 490
    [0.0147, 0.2586, 0.3533],            // 495
    [0.0049, 0.323, 0.272],              // 500
    [0.0024, 0.4073, 0.2123],            // 505
    [0.0093, 0.503, 0.1582],             // 510
    [0.0291, 0.6082, 0.1117],            // 515
    [0.06327, 0.71, 0.07824999],         // 520
    [0.1096, 0.7932, 0.05725001],        // 525
    [0.1655, 0.862, 0.04216],            // 530
    [0.2257499, 0.9148501, 0.02984],     // 535
    [0.2904, 0.954, 0.0203],             // 540
    [0.3597, 0.9803, 0.0134],            // 545
    [0.4334499, 0.9949501, 0.008749999], // 550
    [0.5120501, 1.0, 0.005749999],       // 555
    [0.5945, 0.995, 0.0039],             // 560
    [0.6784, 0.9786, 0.002749999],       // 565
    [0.7621, 0.952, 0.0021],             // 570
    [0.8425, 0.9154, 0.0018],            // 575
    [0.9163, 0.87, 0.001650001],         // 580
    [0.9786, 0.8163, 0.0014],            // 585
    [1.0263, 0.757, 0.0011],             // 590
    [1.0567, 0.6949, 0.001],             // 595
    [1.0622, 0.631, 0.0008],             // 600
    [1.0456, 0.5668, 0.0006],            // 605
    [1.0026, 0.503, 0.00034],            // 610
    [0.9384, 0.4412, 0.00024],           // 615
    [0.8544499, 0.381, 0.00019],         // 620
    [0.7514, 0.321, 0.0001],             // 625
    [0.6424, 0.265, 4.999999e-05],       // 630
    [0.5419, 0.217, 3e-05],              // 635
    [0.4479, 0.175, 2e-05],              // 640
    [0.3608, 0.1382, 1e-05],             // 645
    [0.2835, 0.107, -1.905824e-21],      // 650
    [0.2187, 0.0816, 0.0],               // 655
    [0.1649, 0.061, 0.0],                // 660
    [0.1212, 0.04458, 0.0],              // 665
    [0.0874, 0.032, 0.0],                // 670
    [0.0636, 0.0232, 0.0],               // 675
    [0.04677, 0.017, 0.0],               // 680
    [0.0329, 0.01192, 0.0],              // 685
    [0.0227, 0.00821, 0.0],              // 690
    [0.01584, 0.005723, 0.0],            // 695
    [0.01135916, 0.004102, 0.0],         // 700
    [0.008110916, 0.002929, 0.0],        // 705
    [0.005790346, 0.002091, 0.0],        // 710
    [0.004109457, 0.001484, 0.0],        // 715
    [0.002899327, 0.001047, 0.0],        // 720
    [0.00204919, 0.00074, 0.0],          // 725
    [0.001439971, 0.00052, 0.0],         // 730
    [0.0009999493, 0.0003611, 0.0],      // 735
    [0.0006900786, 0.0002492, 0.0],      // 740
    [0.0004760213, 0.0001719, 0.0],      // 745
    [0.0003323011, 0.00012, 0.0],        // 750
    [0.0002348261, 8.48e-05, 0.0],       // 755
    [0.0001661505, 6e-05, 0.0],          // 760
    [0.000117413, 4.24e-05, 0.0],        // 765
    [8.307527e-05, 3e-05, 0.0],          // 770
    [5.870652e-05, 2.12e-05, 0.0],       // 775
    [4.150994e-05, 1.499e-05, 0.0],      // 780
    [2.935326e-05, 1.06e-05, 0.0],       // 785
    [2.067383e-05, 7.4657e-06, 0.0],     // 790
    [1.455977e-05, 5.2578e-06, 0.0],     // 795
    [1.025398e-05, 3.7029e-06, 0.0],     // 800
    [7.221456e-06, 2.6078e-06, 0.0],     // 805
    [5.085868e-06, 1.8366e-06, 0.0],     // 810
    [3.581652e-06, 1.2934e-06, 0.0],     // 815
    [2.522525e-06, 9.1093e-07, 0.0],     // 820
    [1.776509e-06, 6.4153e-07, 0.0],     // 825
    [1.251141e-06, 4.5181e-07, 0.0],     // 830
];
const CIE_FIRST_NM: f64 = 360.0;
const CIE_STEP_NM: f64 = 5.0;

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
    for (i, c) in CIE_1931_2DEG.iter().enumerate() {
        let p = planck(CIE_FIRST_NM + CIE_STEP_NM * i as f64, t);
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
