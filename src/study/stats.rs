//! Small statistics shared by image comparison and the study: normal tail probabilities and
//! the Sidak correction for families of z-tests.

/// Complementary error function (Numerical Recipes' `erfcc`, relative error < 1.2e-7), enough
/// for test thresholds.
pub fn erfc(x: f64) -> f64 {
    // Polynomial in t, highest degree first, by Horner's rule (a flat table: the deeply
    // nested textbook form makes rustfmt hang).
    const C: [f64; 10] = [
        0.17087277,
        -0.82215223,
        1.48851587,
        -1.13520398,
        0.27886807,
        -0.18628806,
        0.09678418,
        0.37409196,
        1.00002368,
        -1.26551223,
    ];
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = C.iter().fold(0.0, |acc, &c| acc * t + c);
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// `z` such that `P(|Z| > z) = a` for a standard normal `Z` (bisection on [`erfc`]).
pub fn two_sided_z(a: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if erfc(mid / std::f64::consts::SQRT_2) > a {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Per-test level that keeps the probability of any false rejection among `n` independent
/// tests at `alpha` (Sidak 1967): `1 - (1 - alpha)^(1/n)`.
pub fn sidak_level(alpha: f64, n: usize) -> f64 {
    // -expm1(ln1p(-alpha) / n) keeps precision for large n where (1 - alpha)^(1/n) ~ 1.
    -((-alpha).ln_1p() / n.max(1) as f64).exp_m1()
}

/// Least-squares slope and intercept of `y` on `x`; `None` with fewer than two distinct `x`.
pub fn fit_line(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    let n = x.len().min(y.len());
    if n < 2 {
        return None;
    }
    let mx = x[..n].iter().sum::<f64>() / n as f64;
    let my = y[..n].iter().sum::<f64>() / n as f64;
    let sxx: f64 = x[..n].iter().map(|v| (v - mx) * (v - mx)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = x[..n]
        .iter()
        .zip(&y[..n])
        .map(|(a, b)| (a - mx) * (b - my))
        .sum();
    let slope = sxy / sxx;
    Some((slope, my - slope * mx))
}

/// Mean and sample standard deviation (0 for a single value; NaN for none).
pub fn mean_std(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (m, 0.0);
    }
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, var.sqrt())
}

/// Per-pixel variance of one render, pooled over pixels and RGB channels, from renders of the
/// same image with different seeds: the mean over values of their sample variance across the
/// renders (`k - 1` in the denominator). With two renders A and B this is
/// `mean((A - B)^2) / 2`.
pub fn seed_variance(renders: &[&[[f32; 3]]]) -> Result<f64, String> {
    Ok(seed_variance_profile(renders, 0.0)?.pooled)
}

/// [`seed_variance`], and the share of it that the worst values carry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeedVariance {
    /// [`seed_variance`].
    pub pooled: f64,
    /// The fraction of the pooled sum contributed by the `ceil(top_fraction * 3n)` largest
    /// per-value variances (0 when the pooled variance is 0). Near `top_fraction` for noise
    /// spread over the image; near 1 where a few pixels carry it (a point light inside a
    /// medium: distance sampling gives the pixel that sees the light an infinite-variance
    /// single-scattering estimate), and then `pooled` is set by a few outliers and moves by
    /// multiples between sets of seeds: an efficiency taken from it ranks nothing.
    pub top_share: f64,
}

/// The share of the pixel values whose variance the benches' `top 0.1%` columns sum
/// ([`SeedVariance::top_share`]).
pub const TOP_FRACTION: f64 = 1e-3;

/// [`seed_variance`] and [`SeedVariance::top_share`] of the `top_fraction` worst values.
pub fn seed_variance_profile(
    renders: &[&[[f32; 3]]],
    top_fraction: f64,
) -> Result<SeedVariance, String> {
    check_renders(renders)?;
    let k = renders.len() as f64;
    let n = renders[0].len();
    let mut per_value = Vec::with_capacity(3 * n);
    for p in 0..n {
        for c in 0..3 {
            let m = renders.iter().map(|r| r[p][c] as f64).sum::<f64>() / k;
            per_value.push(
                renders
                    .iter()
                    .map(|r| (r[p][c] as f64 - m).powi(2))
                    .sum::<f64>()
                    / (k - 1.0),
            );
        }
    }
    let sum: f64 = per_value.iter().sum();
    let top = ((top_fraction.clamp(0.0, 1.0) * per_value.len() as f64).ceil() as usize)
        .min(per_value.len());
    let top_share = if sum > 0.0 && top > 0 {
        // Only the `top` largest need ordering.
        let split = per_value.len() - top;
        per_value.select_nth_unstable_by(split, f64::total_cmp);
        per_value[split..].iter().sum::<f64>() / sum
    } else {
        0.0
    };
    Ok(SeedVariance {
        pooled: sum / (3 * n) as f64,
        top_share,
    })
}

/// Mean over pixels and RGB of renders averaged over seeds, with the variance of that mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageMean {
    pub mean: f64,
    /// Variance of `mean`: the sample variance across seeds of each pixel's R + G + B (so the
    /// correlation of a pixel's channels counts), summed over pixels (pixels are rendered with
    /// independent random streams), divided by `(3 n)^2` and by the number of seeds. It uses
    /// every pixel's spread, so it is much steadier than the spread of the seeds' image means
    /// (one degree of freedom per extra seed).
    pub variance: f64,
}

impl ImageMean {
    /// `self.mean - other.mean` and its z-score with both variances.
    pub fn difference(&self, other: &ImageMean) -> (f64, f64) {
        let d = self.mean - other.mean;
        let v = self.variance + other.variance;
        let z = if v > 0.0 {
            d / v.sqrt()
        } else if d == 0.0 {
            0.0
        } else {
            f64::INFINITY.copysign(d)
        };
        (d, z)
    }
}

/// [`ImageMean`] of renders of one image with different seeds (at least two).
pub fn image_mean(renders: &[&[[f32; 3]]]) -> Result<ImageMean, String> {
    check_renders(renders)?;
    let k = renders.len() as f64;
    let n = renders[0].len();
    let (mut total, mut var_sum) = (0f64, 0f64);
    for p in 0..n {
        let sums: Vec<f64> = renders
            .iter()
            .map(|r| r[p].iter().map(|&v| v as f64).sum())
            .collect();
        let m = sums.iter().sum::<f64>() / k;
        total += m;
        var_sum += sums.iter().map(|s| (s - m).powi(2)).sum::<f64>() / (k - 1.0);
    }
    let values = (3 * n) as f64;
    Ok(ImageMean {
        mean: total / values,
        variance: var_sum / (values * values) / k,
    })
}

fn check_renders(renders: &[&[[f32; 3]]]) -> Result<(), String> {
    if renders.len() < 2 {
        return Err(format!(
            "{} render(s): the variance needs at least 2 seeds",
            renders.len()
        ));
    }
    let n = renders[0].len();
    if n == 0 || renders.iter().any(|r| r.len() != n) {
        return Err("renders are empty or differ in size".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_seed_variance_is_half_the_mean_squared_difference() {
        let a = [[1.0f32, 2.0, 3.0], [0.0, 0.0, 0.0]];
        let b = [[2.0f32, 2.0, 1.0], [1.0, 0.0, 0.0]];
        // Squared differences 1, 0, 4, 1, 0, 0: mean 1, half of it 0.5.
        assert!((seed_variance(&[&a, &b]).unwrap() - 0.5).abs() < 1e-12);
        let m = image_mean(&[&a, &b]).unwrap();
        assert!((m.mean - 12.0 / 12.0).abs() < 1e-12);
        // Pixel sums: (6, 5) and (0, 1): sample variances 0.5 and 0.5, sum 1, / 6^2 / 2.
        assert!((m.variance - 1.0 / 36.0 / 2.0).abs() < 1e-12);
        assert!(seed_variance(&[&a]).is_err());
        assert!(image_mean(&[&a, &b[..1]]).is_err());
    }

    #[test]
    fn top_share_tells_outliers_from_spread_noise() {
        // 1000 pixels; render B differs from A by 1 in every channel (per-value variance 0.5
        // each), except pixel 7, whose red differs by 100 (variance 5000).
        let a = vec![[0.0f32; 3]; 1000];
        let mut b = vec![[1.0f32; 3]; 1000];
        let even = seed_variance_profile(&[&a, &b], 1e-3).unwrap();
        // 3000 values, the top 3 carry 3 / 3000 of an even sum.
        assert!((even.pooled - 0.5).abs() < 1e-12);
        assert!((even.top_share - 1e-3).abs() < 1e-12, "{even:?}");
        b[7][0] = 100.0;
        let spiked = seed_variance_profile(&[&a, &b], 1e-3).unwrap();
        let sum = 2999.0 * 0.5 + 5000.0;
        assert!((spiked.pooled - sum / 3000.0).abs() < 1e-9);
        // The spike and two ordinary values.
        assert!(
            (spiked.top_share - 5001.0 / sum).abs() < 1e-12,
            "{spiked:?}"
        );
        assert_eq!(spiked.pooled, seed_variance(&[&a, &b]).unwrap());
        // No variance at all: no share.
        assert_eq!(
            seed_variance_profile(&[&a, &a], 1e-3).unwrap().top_share,
            0.0
        );
    }

    #[test]
    fn image_mean_variance_matches_the_spread_of_means() {
        // Independent noise per pixel and seed: the estimated variance of the seed-averaged
        // image mean agrees with its actual spread over many trials.
        let mut state = 12345u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (n, trials) = (200, 400);
        let mut means = Vec::new();
        let mut est = 0.0;
        for _ in 0..trials {
            let imgs: Vec<Vec<[f32; 3]>> = (0..2)
                .map(|_| {
                    (0..n)
                        .map(|_| {
                            let shared = uniform() as f32;
                            [shared, shared + uniform() as f32, 0.5]
                        })
                        .collect()
                })
                .collect();
            let refs: Vec<&[[f32; 3]]> = imgs.iter().map(|v| v.as_slice()).collect();
            let m = image_mean(&refs).unwrap();
            means.push(m.mean);
            est += m.variance / trials as f64;
        }
        let (_, sd) = mean_std(&means);
        let ratio = sd * sd / est;
        assert!(
            (0.8..1.25).contains(&ratio),
            "actual / estimated variance {ratio}"
        );
    }

    #[test]
    fn differences_have_signed_z_scores() {
        let a = ImageMean {
            mean: 1.0,
            variance: 0.01,
        };
        let b = ImageMean {
            mean: 0.9,
            variance: 0.03,
        };
        let (d, z) = a.difference(&b);
        assert!((d - 0.1).abs() < 1e-12 && (z - 0.5).abs() < 1e-12);
        let c = ImageMean {
            mean: 1.0,
            variance: 0.0,
        };
        assert_eq!(c.difference(&c), (0.0, 0.0));
    }
}
