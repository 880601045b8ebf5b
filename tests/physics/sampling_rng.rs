//! The u32 PCG streams: pinned outputs (the WGSL mirror must reproduce them), uniformity, and
//! independence between neighbouring streams.
use crate::common;

use brume::sampling::chi2::{chi2_test, histogram_1d, sidak};
use brume::sampling::rng::pcg_hash;
use brume::sampling::Rng;
use common::{assert_z, Moments};

/// Values pinned from this implementation. `shaders/common/rng.wgsl` must give the same: a
/// change here is a change of every image and of the GPU mirror.
#[test]
fn outputs_are_pinned() {
    assert_eq!(
        [pcg_hash(0), pcg_hash(1), pcg_hash(0xdead_beef)],
        [129_708_002, 2_831_084_092, 1_730_779_506]
    );
    let mut r = Rng::new(0, 0, 0);
    assert_eq!(r.raw(), (1_104_539_492, 1_072_320_463));
    assert_eq!(
        [r.next_u32(), r.next_u32(), r.next_u32(), r.next_u32()],
        [3_742_828_207, 3_266_566_982, 1_496_874_601, 401_767_782]
    );
    let mut r = Rng::new(1920 * 1080 - 1, 4095, 42);
    assert_eq!(r.raw(), (1_660_539_785, 3_412_545_709));
    assert_eq!(
        [r.next_u32(), r.next_u32(), r.next_u32(), r.next_u32()],
        [3_177_539_456, 4_044_696_642, 1_678_072_070, 3_602_497_513]
    );
    let mut r = Rng::new(7, 3, 1);
    assert_eq!(
        [r.uniform_f32().to_bits(), r.uniform_f32().to_bits()],
        [1_054_482_396, 1_061_286_628]
    );
}

#[test]
fn uniform_f32_bounds_and_resolution() {
    // The extreme outputs map to 0 and 1 - 2^-24 exactly.
    assert_eq!((0u32 >> 8) as f32 * (1.0 / 16_777_216.0), 0.0);
    assert_eq!(
        (u32::MAX >> 8) as f32 * (1.0 / 16_777_216.0),
        1.0 - 1.0 / 16_777_216.0
    );
    let mut r = Rng::new(3, 0, 9);
    for _ in 0..1_000_000 {
        let u = r.uniform_f32();
        assert!((0.0..1.0).contains(&u));
    }
}

/// Chi-square uniformity of one stream, of the first draw across many streams (pixels), and
/// of pairs of neighbouring pixels (2-D histogram: catches correlation between streams).
#[test]
fn streams_are_uniform_and_independent() {
    let alpha = sidak(0.01, 4);
    let n = 1_000_000u32;
    let bins = 100;
    let expected = vec![n as f64 / bins as f64; bins];
    let mut r = Rng::new(12, 34, 56);
    let within = histogram_1d((0..n).map(|_| r.uniform_f32() as f64), 0.0, 1.0, bins);
    let across_pixels = histogram_1d(
        (0..n).map(|p| Rng::new(p, 0, 5).uniform_f32() as f64),
        0.0,
        1.0,
        bins,
    );
    let across_samples = histogram_1d(
        (0..n).map(|s| Rng::new(77, s, 5).uniform_f32() as f64),
        0.0,
        1.0,
        bins,
    );
    for (name, h) in [
        ("one stream", within),
        ("across pixels", across_pixels),
        ("across samples", across_samples),
    ] {
        let t = chi2_test(&h, &expected, 5.0);
        println!(
            "{name}: chi2 {:.1} dof {} p {:.4}",
            t.statistic, t.dof, t.p_value
        );
        assert!(t.p_value >= alpha, "{name}: {t:?}");
    }
    // Neighbouring pixels, same sample: 16 x 16 joint histogram of their first draws.
    let k = 16usize;
    let mut joint = vec![0.0; k * k];
    for p in 0..n {
        let a = Rng::new(p, 0, 5).uniform_f32();
        let b = Rng::new(p + 1, 0, 5).uniform_f32();
        joint[(a * k as f32) as usize * k + (b * k as f32) as usize] += 1.0;
    }
    let t = chi2_test(&joint, &vec![n as f64 / (k * k) as f64; k * k], 5.0);
    println!(
        "neighbour pairs: chi2 {:.1} dof {} p {:.4}",
        t.statistic, t.dof, t.p_value
    );
    assert!(t.p_value >= alpha, "{t:?}");
}

/// Mean 1/2 and lag-1 correlation 0 within a stream.
#[test]
fn moments_within_a_stream() {
    let mut r = Rng::new(1, 2, 3);
    let (mut mean, mut lag) = (Moments::default(), Moments::default());
    let mut prev = r.uniform_f32() as f64;
    for _ in 0..1_000_000 {
        let u = r.uniform_f32() as f64;
        mean.push(u);
        lag.push((u - 0.5) * (prev - 0.5));
        prev = u;
    }
    assert_z("uniform mean", &mean, 0.5);
    assert_z("lag-1 covariance", &lag, 0.0);
}
