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
