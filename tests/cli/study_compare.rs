//! `brume compare` and `study::compare`: exact norms on synthetic images, z-tests on synthetic
//! noise of known variance, and clear errors on bad inputs.
use crate::common::scratch;

use std::process::Command;

use brume::film::{write_image, Image, Metadata};
use brume::study::compare::{compare, difference_image, CompareError, CompareOptions};

fn image(w: usize, h: usize, f: impl Fn(usize, usize) -> [f32; 3]) -> Image {
    Image {
        width: w,
        height: h,
        rgb: (0..w * h).map(|i| f(i % w, i / w)).collect(),
        alpha: Some(vec![1.0; w * h]),
        variance: None,
        samples: None,
        attributes: Metadata::new(),
    }
}

/// Standard normal deviates from a fixed-seed xorshift and Box-Muller.
struct Normal(u64);
impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn next(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// A noisy estimate of the constant `mu` with per-pixel standard error `se` and its variance
/// layer, plus `bias`.
fn noisy(w: usize, h: usize, mu: f32, se: f32, bias: f32, seed: u64) -> Image {
    let mut n = Normal(seed);
    let mut img = image(w, h, |_, _| [0.0; 3]);
    for p in &mut img.rgb {
        *p = std::array::from_fn(|_| mu + bias + se * n.next() as f32);
    }
    img.variance = Some(vec![[se * se; 3]; w * h]);
    img.samples = Some(vec![64.0; w * h]);
    img
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs().max(1e-6)
}

#[test]
fn norms_are_exact_on_known_differences() {
    // B = (1, 2, 0.5); A differs by +-0.1 in R (checkerboard), +0.2 in G, 0 in B.
    let b = image(16, 8, |_, _| [1.0, 2.0, 0.5]);
    let a = image(16, 8, |x, y| {
        let s = if (x + y) % 2 == 0 { 0.1 } else { -0.1 };
        [1.0 + s, 2.2, 0.5]
    });
    let c = compare(&a, &b, &CompareOptions::default()).unwrap();
    let f = |v: f32| v as f64;
    // The f32 pixels carry the rounding of 1.1, 0.9, 2.2: compare with their exact values.
    let dr = [f(1.1f32) - 1.0, 1.0 - f(0.9f32)];
    let dg = f(2.2f32) - 2.0;
    let mse_r = (dr[0] * dr[0] + dr[1] * dr[1]) / 2.0;
    assert!(close(c.rmse[0], mse_r.sqrt()), "{:?}", c.rmse);
    assert!(close(c.rmse[1], dg));
    assert_eq!(c.rmse[2], 0.0);
    assert!(close(c.rmse_all, ((mse_r + dg * dg) / 3.0).sqrt()));
    assert!(close(c.relmse[0], mse_r / (1.0 + 1e-2)));
    assert!(close(c.relmse[1], dg * dg / (4.0 + 1e-2)));
    assert!(close(c.mean_abs_diff[0], (dr[0] + dr[1]) / 2.0));
    assert!(close(c.mean_signed_diff[0], (dr[0] - dr[1]) / 2.0));
    assert!(close(c.mean_signed_diff[1], dg));
    assert!(close(c.mean_rel_diff[1], dg / 2.0));
    assert_eq!(c.mean_rel_diff[2], 0.0);
    // No variance anywhere: no z-tests.
    assert!(c.pixel_test.is_none() && c.block_test.is_none());
    assert_eq!(c.variance_from, "none");
    // The difference image is A - B.
    let d = difference_image(&a, &b).unwrap();
    assert!(close(d.rgb[0][1] as f64, f(2.2f32 - 2.0)));
}

#[test]
fn z_tests_pass_unbiased_and_fail_biased_images() {
    let (w, h) = (64, 48);
    let reference = noisy(w, h, 0.5, 0.01, 0.0, 1);
    let opts = CompareOptions::default();

    // An independent unbiased estimate passes both tests (fixed seeds: deterministic).
    let same = noisy(w, h, 0.5, 0.01, 0.0, 2);
    let c = compare(&same, &reference, &opts).unwrap();
    let (p, b) = (c.pixel_test.unwrap(), c.block_test.unwrap());
    assert_eq!(c.variance_from, "both");
    assert_eq!(p.tests, w * h * 3);
    assert!(p.passed && b.passed, "{p:?} {b:?}");
    // About alpha of the uncorrected per-test decisions fail.
    assert!(p.fraction_failing_per_test < 0.005, "{p:?}");

    // The image equal to the reference passes with z = 0 everywhere.
    let c = compare(&reference, &reference, &opts).unwrap();
    assert_eq!(c.pixel_test.as_ref().unwrap().worst_z, 0.0);

    // A bias of 10 standard errors of the difference fails almost every pixel.
    let se_diff = (2.0f32).sqrt() * 0.01;
    let biased = noisy(w, h, 0.5, 0.01, 10.0 * se_diff, 3);
    let c = compare(&biased, &reference, &opts).unwrap();
    let p = c.pixel_test.unwrap();
    assert!(!p.passed && p.fraction_failing_sidak > 0.9, "{p:?}");
    assert!(c.mean_z.unwrap()[0] > 100.0);

    // A bias of 0.5 standard errors hides in per-pixel noise but not in 8x8 block means,
    // whose standard error is 8 times smaller (z about 4 per block).
    let slight = noisy(w, h, 0.5, 0.01, 0.5 * se_diff, 4);
    let c = compare(&slight, &reference, &opts).unwrap();
    let (p, b) = (c.pixel_test.unwrap(), c.block_test.unwrap());
    assert!(p.fraction_failing_sidak < 0.01, "{p:?}");
    assert!(!b.passed && b.fraction_failing_per_test > 0.3, "{b:?}");

    // Variance in B only (a reference with variance against, e.g., a Cycles render without).
    let mut no_var = noisy(w, h, 0.5, 0.005, 0.0, 5);
    no_var.variance = None;
    no_var.samples = None;
    let reference_wide = noisy(w, h, 0.5, 0.02, 0.0, 6);
    let c = compare(&no_var, &reference_wide, &opts).unwrap();
    assert_eq!(c.variance_from, "B");
    assert!(c.pixel_test.unwrap().passed);
}

#[test]
fn unknown_variance_is_skipped_and_zero_variance_needs_agreement() {
    let mut a = noisy(8, 8, 1.0, 0.01, 0.0, 7);
    a.samples.as_mut().unwrap()[0] = 1.0; // one sample: variance unknown
    let b = noisy(8, 8, 1.0, 0.01, 0.0, 8);
    let c = compare(&a, &b, &CompareOptions::default()).unwrap();
    assert_eq!(c.pixel_test.unwrap().skipped, 3);
    // Zero variance on both sides: equal values pass, different ones fail.
    let mut x = image(4, 4, |_, _| [1.0; 3]);
    x.variance = Some(vec![[0.0; 3]; 16]);
    let mut y = x.clone();
    assert!(
        compare(&x, &y, &CompareOptions::default())
            .unwrap()
            .pixel_test
            .unwrap()
            .passed
    );
    y.rgb[5][1] = 1.01;
    let t = compare(&x, &y, &CompareOptions::default())
        .unwrap()
        .pixel_test
        .unwrap();
    assert_eq!(t.failing_sidak, 1);
}

/// A constant background whose variance is only rounding noise (standard error 1e-8 of the
/// value): two devices that round it one or three ulps apart agree (z in the tens without the
/// rounding floor), a real difference still fails, and
/// a faint pixel with real noise below `ZERO_VARIANCE_TOLERANCE` is z-tested as noise.
#[test]
fn rounding_level_variance_is_floored_not_trusted() {
    let sky = 0.4f32;
    let mut x = image(4, 4, |_, _| [sky; 3]);
    let rounding_var = (1e-8 * sky) * (1e-8 * sky);
    x.variance = Some(vec![[rounding_var; 3]; 16]);
    x.samples = Some(vec![256.0; 16]);
    let mut y = x.clone();
    let ulp = f32::EPSILON * 0.5;
    y.rgb[3] = [sky + ulp, sky + 3.0 * ulp, sky - ulp];
    let t = compare(&x, &y, &CompareOptions::default())
        .unwrap()
        .pixel_test
        .unwrap();
    assert!(t.passed, "{t:?}");
    assert!(t.worst_z < 1.0, "{t:?}");
    // Real noise of standard error 2.5e-6 (below the zero-variance tolerance 5e-6 at 0.4) and
    // a difference of 1.6 standard errors: an ordinary z, no failure (faint smoke edges like
    // this must not be failed by a tolerance rule).
    let mut n = x.clone();
    n.variance = Some(vec![[3.0e-12; 3]; 16]);
    let mut m = n.clone();
    m.rgb[7][2] = sky + 4.0e-6;
    let t = compare(&m, &n, &CompareOptions::default())
        .unwrap()
        .pixel_test
        .unwrap();
    assert!(t.passed && t.worst_z > 1.5 && t.worst_z < 1.7, "{t:?}");
    y.rgb[3][0] = sky + 1e-3;
    let t = compare(&x, &y, &CompareOptions::default())
        .unwrap()
        .pixel_test
        .unwrap();
    assert_eq!(t.failing_sidak, 1, "{t:?}");
}

#[test]
fn different_sizes_and_bad_options_are_errors() {
    let a = image(4, 4, |_, _| [0.0; 3]);
    let b = image(4, 5, |_, _| [0.0; 3]);
    let e = compare(&a, &b, &CompareOptions::default()).unwrap_err();
    assert!(matches!(e, CompareError::SizeMismatch { .. }));
    assert!(
        e.to_string().contains("4x4") && e.to_string().contains("4x5"),
        "{e}"
    );
    let bad = CompareOptions {
        block: 0,
        ..Default::default()
    };
    assert!(compare(&a, &a, &bad).is_err());
}

fn brume(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_brume"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn cli_compares_files_and_names_bad_ones() {
    let a = scratch::file("a.exr");
    let b = scratch::file("b.exr");
    let small = scratch::file("small.exr");
    let garbage = scratch::file("garbage.exr");
    write_image(&a, &noisy(24, 16, 0.5, 0.01, 0.0, 9)).unwrap();
    write_image(&b, &noisy(24, 16, 0.5, 0.01, 0.0, 10)).unwrap();
    write_image(&small, &noisy(12, 16, 0.5, 0.01, 0.0, 11)).unwrap();
    std::fs::write(&garbage, b"this is not an EXR file at all").unwrap();
    let (a_s, b_s, small_s) = (
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        small.to_str().unwrap(),
    );
    let diff = scratch::file("diff.exr");
    let png = scratch::file("diff.png");
    let (ok, out, err) = brume(&[
        "compare",
        a_s,
        b_s,
        "--json",
        "--diff",
        diff.to_str().unwrap(),
        "--diff-png",
        png.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(v["rmse_all"].as_f64().unwrap() > 0.0);
    assert_eq!(v["pixel_test"]["passed"], true);
    assert!(diff.is_file() && png.is_file());
    let d = brume::film::read_exr(&diff).unwrap();
    assert!(d.variance.is_some());

    let (ok, out, _) = brume(&["compare", a_s, b_s]);
    assert!(
        ok && out.contains("RMSE") && out.contains("block z-test"),
        "{out}"
    );

    let (ok, _, err) = brume(&["compare", a_s, small_s]);
    assert!(
        !ok && err.contains("different sizes") && err.contains("24x16"),
        "{err}"
    );
    let missing = scratch::file("missing.exr");
    let (ok, _, err) = brume(&["compare", missing.to_str().unwrap(), b_s]);
    assert!(!ok && err.contains("missing.exr"), "{err}");
    let (ok, _, err) = brume(&["compare", b_s, garbage.to_str().unwrap()]);
    assert!(
        !ok && err.contains("garbage.exr") && err.contains("not a readable OpenEXR"),
        "{err}"
    );
}
