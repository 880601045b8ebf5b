//! Comparing two images: error norms, per-pixel and per-block z-tests, difference images.
//!
//! `A` is the image under test, `B` the reference; differences are `A - B` and relative errors
//! divide by the reference. Every function here is pure (images in, numbers out) except the
//! writers at the end.
//!
//! - Norms ([`Comparison::rmse`], [`Comparison::relmse`], mean absolute and signed difference)
//!   are per channel over all pixels, plus the pooled value over the three channels.
//!   The relative MSE is `mean((a - b)^2 / (b^2 + 1e-2))` (Rousselle et al. 2011's form: the
//!   `1e-2` keeps dark pixels from dominating).
//! - The per-pixel z-test follows Mitsuba 3's image regression tests: for every pixel and
//!   channel `z = (a - b) / sqrt(var_a + var_b)` with the variances of the pixel means that the
//!   images carry (either, or both), and a two-sided test whose level is Sidak-corrected so the
//!   whole image fails with probability `alpha` (0.1 %) when `A` and `B` estimate the same
//!   image. Pixels whose variance is unknown (fewer than two samples) are skipped. The variance
//!   of the difference gets a floor of [`ROUNDING_ULPS`] f32 ulps of the reference value, the
//!   spread that two devices' rounding puts between renders of the same deterministic value: a
//!   z against a rounding-level standard error would fail a GPU against the CPU on a constant
//!   background. Pixels with no variance at all (a black background) must agree to
//!   [`ZERO_VARIANCE_TOLERANCE`].
//! - The block test averages `block x block` pixels first (partial blocks at the right and
//!   bottom edges included) so that per-pixel noise that is far from normal (a few fireflies)
//!   averages towards normality; the variance of a block mean is the sum of its pixels'
//!   variances over the pixel count squared (pixels are independent). Both the Sidak-corrected
//!   verdict and the fraction failing an uncorrected 0.1 % test per block are reported: for two
//!   unbiased images the latter is about 0.001, and a bias shows as many failing blocks.
use serde::Serialize;

use super::stats::{erfc, sidak_level, two_sided_z};
use crate::film::Image;

/// The constant in the relative MSE denominator `b^2 + 1e-2`.
pub const RELMSE_EPSILON: f64 = 1e-2;

/// Where both variances are zero and the rounding floor is too (a black reference), a
/// difference up to `1e-6 + 1e-5 |b|` still passes: two renders of a constant background agree
/// to rounding, not bit for bit.
pub const ZERO_VARIANCE_TOLERANCE: (f64, f64) = (1e-6, 1e-5);

/// The standard error floor of a difference, in f32 ulps (`f32::EPSILON`) of the reference
/// value. Pixels that are constant up to rounding (sky seen through an empty box) have standard
/// errors of about 1e-8 of their value (the f32 rounding of equal samples), and two devices
/// that round divisions and transcendentals differently put them 1-3 ulps apart: without the
/// floor such a pixel's z reaches tens. A pixel with real noise (standard errors of 1e-6 and
/// more) is not moved by it.
pub const ROUNDING_ULPS: f64 = 4.0;

/// How to compare.
#[derive(Clone, Copy, Debug)]
pub struct CompareOptions {
    /// Side of the square pixel blocks of the block test.
    pub block: usize,
    /// Family-wise significance level of the z-tests (0.001: 99.9 % confidence).
    pub alpha: f64,
}

impl Default for CompareOptions {
    fn default() -> Self {
        Self {
            block: 8,
            alpha: 1e-3,
        }
    }
}

/// A family of two-sided z-tests.
#[derive(Clone, Debug, Serialize)]
pub struct ZTest {
    /// Tests run (pixels or blocks times channels, less those with unknown variance).
    pub tests: usize,
    /// Tests skipped because the variance was unknown.
    pub skipped: usize,
    /// `|z|` threshold of the Sidak-corrected per-test level.
    pub z_sidak: f64,
    /// Tests over `z_sidak`.
    pub failing_sidak: usize,
    /// `failing_sidak / tests`.
    pub fraction_failing_sidak: f64,
    /// `|z|` threshold of an uncorrected test at level `alpha`.
    pub z_per_test: f64,
    /// Tests over `z_per_test` (expected `alpha * tests` for unbiased images).
    pub failing_per_test: usize,
    /// `failing_per_test / tests`.
    pub fraction_failing_per_test: f64,
    /// Largest `|z|`.
    pub worst_z: f64,
    /// Whether no test exceeded the Sidak threshold: the images agree at `1 - alpha`.
    pub passed: bool,
}

/// Everything [`compare`] measures. Per-channel arrays are `[R, G, B]`.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub width: usize,
    pub height: usize,
    /// Pixels with a non-finite value in either image; they are left out of every figure.
    pub nonfinite_pixels: usize,
    /// Root mean squared difference per channel.
    pub rmse: [f64; 3],
    /// Root mean squared difference pooled over the channels.
    pub rmse_all: f64,
    /// `mean((a - b)^2 / (b^2 + 1e-2))` per channel.
    pub relmse: [f64; 3],
    /// The same pooled over the channels.
    pub relmse_all: f64,
    /// `mean(|a - b|)`.
    pub mean_abs_diff: [f64; 3],
    /// `mean(a - b)`.
    pub mean_signed_diff: [f64; 3],
    /// Image means of A and B.
    pub mean_a: [f64; 3],
    pub mean_b: [f64; 3],
    /// `(mean_a - mean_b) / |mean_b|` (NaN where `mean_b` is 0).
    pub mean_rel_diff: [f64; 3],
    /// z of the image-mean difference per channel, where a variance is known.
    pub mean_z: Option<[f64; 3]>,
    /// Which images carried a variance layer: "A", "B", "both" or "none".
    pub variance_from: &'static str,
    /// Per-pixel z-test; `None` when neither image has variance.
    pub pixel_test: Option<ZTest>,
    /// Block z-test; `None` when neither image has variance.
    pub block_test: Option<ZTest>,
    /// Block side used.
    pub block: usize,
    /// Family-wise level used.
    pub alpha: f64,
}

/// Why two images cannot be compared.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("the images have different sizes: A is {}x{}, B is {}x{}", a.0, a.1, b.0, b.1)]
    SizeMismatch {
        a: (usize, usize),
        b: (usize, usize),
    },
    #[error("the images are empty (0 pixels)")]
    Empty,
    #[error("block size must be at least 1")]
    BadBlock,
    #[error("alpha {0} must be in (0, 1)")]
    BadAlpha(f64),
}

/// Squared error and relative squared error of `a` against reference `b`, pooled over pixels
/// and channels, for the study's per-pass checkpoints: `(mse, relmse)`. Non-finite values count
/// (a NaN makes the result NaN, so a broken estimator cannot look good).
pub fn mse_relmse(a: &[[f32; 3]], b: &[[f32; 3]]) -> (f64, f64) {
    let mut se = 0.0;
    let mut rel = 0.0;
    for (pa, pb) in a.iter().zip(b) {
        for c in 0..3 {
            let (x, y) = (pa[c] as f64, pb[c] as f64);
            let d2 = (x - y) * (x - y);
            se += d2;
            rel += d2 / (y * y + RELMSE_EPSILON);
        }
    }
    let n = (a.len().min(b.len()) * 3).max(1) as f64;
    (se / n, rel / n)
}

/// Variances of A and B for pixel `i`, channel `c`, and whether the variance is known.
fn pixel_variance(a: &Image, b: &Image, i: usize, c: usize) -> (f64, bool) {
    let mut v = 0.0;
    let mut known = false;
    for img in [a, b] {
        if let Some(var) = &img.variance {
            // A pixel with fewer than two samples has an unknown, not a zero, variance.
            let enough = img.samples.as_ref().map_or(true, |s| s[i] >= 2.0);
            if enough {
                v += var[i][c] as f64;
                known = true;
            } else {
                return (0.0, false);
            }
        }
    }
    (v, known)
}

fn z_of(d: f64, v: f64, reference: f64) -> f64 {
    let floor = ROUNDING_ULPS * f32::EPSILON as f64 * reference.abs();
    let v = v + floor * floor;
    if v > 0.0 {
        d / v.sqrt()
    } else if d.abs() <= ZERO_VARIANCE_TOLERANCE.0 + ZERO_VARIANCE_TOLERANCE.1 * reference.abs() {
        0.0
    } else {
        f64::INFINITY.copysign(d)
    }
}

fn z_test(zs: &[f64], skipped: usize, alpha: f64) -> ZTest {
    let tests = zs.len();
    let z_sidak = two_sided_z(sidak_level(alpha, tests));
    let z_per_test = two_sided_z(alpha);
    let failing_sidak = zs.iter().filter(|z| z.abs() > z_sidak).count();
    let failing_per_test = zs.iter().filter(|z| z.abs() > z_per_test).count();
    let frac = |k: usize| {
        if tests > 0 {
            k as f64 / tests as f64
        } else {
            0.0
        }
    };
    ZTest {
        tests,
        skipped,
        z_sidak,
        failing_sidak,
        fraction_failing_sidak: frac(failing_sidak),
        z_per_test,
        failing_per_test,
        fraction_failing_per_test: frac(failing_per_test),
        worst_z: zs.iter().fold(0.0f64, |w, z| w.max(z.abs())),
        passed: failing_sidak == 0,
    }
}

/// Compares image `a` with reference `b` (see the module docs for every figure).
pub fn compare(a: &Image, b: &Image, opts: &CompareOptions) -> Result<Comparison, CompareError> {
    check_comparable(a, b, opts)?;
    let (w, h) = (a.width, a.height);
    let ok = finite_pixels(a, b);
    let n = ok.iter().filter(|&&f| f).count();
    let nonfinite_pixels = w * h - n;
    let nf = n.max(1) as f64;
    let s = PixelSums::of(a, b, &ok);
    let per = |s: [f64; 3]| s.map(|v| v / nf);
    let mean_a = per(s.sum_a);
    let mean_b = per(s.sum_b);
    let has_var = a.variance.is_some() || b.variance.is_some();
    let variance_from = match (a.variance.is_some(), b.variance.is_some()) {
        (true, true) => "both",
        (true, false) => "A",
        (false, true) => "B",
        (false, false) => "none",
    };
    let block_test = has_var.then(|| block_z_test(a, b, &ok, opts));
    let mean_z = s.any_var.then(|| {
        std::array::from_fn(|c| z_of(mean_a[c] - mean_b[c], s.sum_var[c] / (nf * nf), mean_b[c]))
    });
    Ok(Comparison {
        width: w,
        height: h,
        nonfinite_pixels,
        rmse: per(s.se).map(f64::sqrt),
        rmse_all: (s.se.iter().sum::<f64>() / (3.0 * nf)).sqrt(),
        relmse: per(s.rel),
        relmse_all: s.rel.iter().sum::<f64>() / (3.0 * nf),
        mean_abs_diff: per(s.abs),
        mean_signed_diff: per(s.signed),
        mean_a,
        mean_b,
        mean_rel_diff: std::array::from_fn(|c| {
            if mean_b[c] != 0.0 {
                (mean_a[c] - mean_b[c]) / mean_b[c].abs()
            } else {
                f64::NAN
            }
        }),
        mean_z,
        variance_from,
        pixel_test: has_var.then(|| z_test(&s.pixel_z, s.pixel_skipped, opts.alpha)),
        block_test,
        block: opts.block,
        alpha: opts.alpha,
    })
}

/// Refuses inputs no figure can be computed for: different sizes, no pixels, a zero block
/// size or a level outside (0, 1).
fn check_comparable(a: &Image, b: &Image, opts: &CompareOptions) -> Result<(), CompareError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(CompareError::SizeMismatch {
            a: (a.width, a.height),
            b: (b.width, b.height),
        });
    }
    if a.width * a.height == 0 {
        return Err(CompareError::Empty);
    }
    if opts.block == 0 {
        return Err(CompareError::BadBlock);
    }
    if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
        return Err(CompareError::BadAlpha(opts.alpha));
    }
    Ok(())
}

/// Per pixel, whether both images' colours and known variances are finite there: only those
/// pixels enter any figure (the others are counted as `nonfinite_pixels`).
fn finite_pixels(a: &Image, b: &Image) -> Vec<bool> {
    let finite = |i: usize| {
        a.rgb[i].iter().chain(&b.rgb[i]).all(|v| v.is_finite())
            && [a, b].iter().all(|img| {
                img.variance
                    .as_ref()
                    .map_or(true, |v| v[i].iter().all(|x| x.is_finite()))
            })
    };
    (0..a.width * a.height).map(finite).collect()
}

/// Per-channel sums over the finite pixels that the norms and the mean test divide, and the
/// per-pixel z scores, accumulated in one pass in pixel order.
struct PixelSums {
    se: [f64; 3],
    rel: [f64; 3],
    abs: [f64; 3],
    signed: [f64; 3],
    sum_a: [f64; 3],
    sum_b: [f64; 3],
    sum_var: [f64; 3],
    /// Whether any pixel had a known variance (`sum_var` means something).
    any_var: bool,
    pixel_z: Vec<f64>,
    /// Pixel channels without a known variance, left out of `pixel_z`.
    pixel_skipped: usize,
}

impl PixelSums {
    /// The sums over the pixels of `a` and `b` that `ok` keeps.
    fn of(a: &Image, b: &Image, ok: &[bool]) -> Self {
        let mut s = PixelSums {
            se: [0.0; 3],
            rel: [0.0; 3],
            abs: [0.0; 3],
            signed: [0.0; 3],
            sum_a: [0.0; 3],
            sum_b: [0.0; 3],
            sum_var: [0.0; 3],
            any_var: false,
            pixel_z: Vec::new(),
            pixel_skipped: 0,
        };
        for i in (0..a.width * a.height).filter(|&i| ok[i]) {
            for c in 0..3 {
                let (x, y) = (a.rgb[i][c] as f64, b.rgb[i][c] as f64);
                let d = x - y;
                s.se[c] += d * d;
                s.rel[c] += d * d / (y * y + RELMSE_EPSILON);
                s.abs[c] += d.abs();
                s.signed[c] += d;
                s.sum_a[c] += x;
                s.sum_b[c] += y;
                let (v, known) = pixel_variance(a, b, i, c);
                if a.variance.is_some() || b.variance.is_some() {
                    if known {
                        s.pixel_z.push(z_of(d, v, y));
                        s.sum_var[c] += v;
                        s.any_var = true;
                    } else {
                        s.pixel_skipped += 1;
                    }
                }
            }
        }
        s
    }
}

/// The z-test on `opts.block`-square block means of the pixels `ok` keeps (partial blocks at
/// the right and bottom edges included); a block channel with an unknown variance is skipped.
fn block_z_test(a: &Image, b: &Image, ok: &[bool], opts: &CompareOptions) -> ZTest {
    let (w, h) = (a.width, a.height);
    let bs = opts.block;
    let mut zs = Vec::new();
    let mut skipped = 0;
    for by in (0..h).step_by(bs) {
        for bx in (0..w).step_by(bs) {
            let mut sa = [0.0; 3];
            let mut sb = [0.0; 3];
            let mut sv = [0.0; 3];
            let mut count = 0usize;
            let mut known = [true; 3];
            for y in by..(by + bs).min(h) {
                for x in bx..(bx + bs).min(w) {
                    let i = y * w + x;
                    if !ok[i] {
                        continue;
                    }
                    count += 1;
                    for c in 0..3 {
                        sa[c] += a.rgb[i][c] as f64;
                        sb[c] += b.rgb[i][c] as f64;
                        let (v, k) = pixel_variance(a, b, i, c);
                        sv[c] += v;
                        known[c] &= k;
                    }
                }
            }
            if count == 0 {
                continue;
            }
            let k = count as f64;
            for c in 0..3 {
                if known[c] {
                    zs.push(z_of((sa[c] - sb[c]) / k, sv[c] / (k * k), sb[c] / k));
                } else {
                    skipped += 1;
                }
            }
        }
    }
    z_test(&zs, skipped, opts.alpha)
}

/// Two-sided p-value of a z score.
pub fn p_value(z: f64) -> f64 {
    erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// `A - B` as an image; its variance layer is `var_a + var_b` where either is known, so the
/// difference image can itself be z-tested against zero.
pub fn difference_image(a: &Image, b: &Image) -> Result<Image, CompareError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(CompareError::SizeMismatch {
            a: (a.width, a.height),
            b: (b.width, b.height),
        });
    }
    let n = a.width * a.height;
    let rgb = (0..n)
        .map(|i| std::array::from_fn(|c| a.rgb[i][c] - b.rgb[i][c]))
        .collect();
    let variance = (a.variance.is_some() || b.variance.is_some()).then(|| {
        (0..n)
            .map(|i| {
                std::array::from_fn(|c| {
                    a.variance.as_ref().map_or(0.0, |v| v[i][c])
                        + b.variance.as_ref().map_or(0.0, |v| v[i][c])
                })
            })
            .collect()
    });
    let mut attributes = crate::film::Metadata::new();
    attributes.set(
        "brume:content",
        crate::film::AttrValue::Text("difference A - B; variance = var A + var B".into()),
    );
    Ok(Image {
        width: a.width,
        height: a.height,
        rgb,
        alpha: None,
        variance,
        samples: None,
        attributes,
    })
}

/// False colour for a signed difference image: per pixel the mean of the three channels,
/// divided by `scale` and mapped blue (-1) - white (0) - red (+1), clamped. Returns RGB8 pixels
/// row-major and the scale used: the 99th percentile of `|d|` (so one firefly does not wash
/// the map out), or 1 for an all-zero difference.
pub fn false_colour(diff: &Image) -> (Vec<[u8; 3]>, f64) {
    let d: Vec<f64> = diff
        .rgb
        .iter()
        .map(|p| (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0)
        .collect();
    let mut mags: Vec<f64> = d
        .iter()
        .map(|v| v.abs())
        .filter(|v| v.is_finite())
        .collect();
    mags.sort_by(f64::total_cmp);
    let p99 = mags
        .get(((mags.len() as f64 * 0.99) as usize).min(mags.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    let scale = if p99 > 0.0 { p99 } else { 1.0 };
    let px = d
        .iter()
        .map(|&v| {
            if !v.is_finite() {
                return [0, 255, 0]; // non-finite: green, impossible to miss
            }
            let t = (v / scale).clamp(-1.0, 1.0);
            let fade = ((1.0 - t.abs()) * 255.0).round() as u8;
            if t >= 0.0 {
                [255, fade, fade]
            } else {
                [fade, fade, 255]
            }
        })
        .collect();
    (px, scale)
}
