//! A reusable chi-square goodness-of-fit harness for sampling routines, after Mitsuba 3's
//! `chi2.py` and pbrt-v4's `sampling_test.cpp`: histogram the samples, integrate the pdf over
//! the same bins, pool bins whose expected count is below 5 (the chi-square approximation needs
//! it), and turn the statistic into a p-value with the regularised incomplete gamma function.
//! A test accepts when `p >= sidak(0.01, number_of_tests)`.
//!
//! Everything is f64: the statistic sums many terms and the pdf integrals must be much more
//! accurate than the sampling noise.
use glam::Vec3;

/// Outcome of [`chi2_test`].
#[derive(Clone, Debug, PartialEq)]
pub struct Chi2Outcome {
    pub statistic: f64,
    /// Degrees of freedom: pooled bin count minus one.
    pub dof: usize,
    pub p_value: f64,
    /// Human-readable reason when the test failed outright (a sample where the pdf is zero).
    pub note: Option<String>,
}

/// Sidak-corrected per-test significance so that `n_tests` independent tests together reject a
/// correct sampler with probability `alpha`.
pub fn sidak(alpha: f64, n_tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / n_tests as f64)
}

/// `ln Gamma(x)` for `x > 0` (Lanczos approximation, g = 7, 9 terms; ~1e-15 relative).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection keeps the series in its accurate range.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma `Q(a, x) = Gamma(a, x) / Gamma(a)`: the series for
/// `P = 1 - Q` below `x < a + 1`, the Lentz continued fraction for `Q` above (each converges
/// fast in its own range; Numerical Recipes sec. 6.2 uses the same split).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    assert!(a > 0.0, "gamma_q needs a > 0");
    if x <= 0.0 {
        return 1.0;
    }
    let ln_prefactor = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^-x x^a / Gamma(a + 1) * sum_n x^n / ((a+1)...(a+n))
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut ap = a;
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * ln_prefactor.exp()).clamp(0.0, 1.0)
    } else {
        // Q(a, x) = e^-x x^a / Gamma(a) * 1 / (x + 1 - a - 1 (1 - a) / (x + 3 - a - ...))
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (h * ln_prefactor.exp()).clamp(0.0, 1.0)
    }
}

/// Survival function of the chi-square distribution: `P(X >= statistic)`.
pub fn chi2_sf(statistic: f64, dof: usize) -> f64 {
    if dof == 0 {
        return 1.0;
    }
    gamma_q(0.5 * dof as f64, 0.5 * statistic)
}

/// Pearson's chi-square test of `observed` counts against `expected` counts (same binning,
/// expected summing to the sample count). Bins are sorted by expected count and the smallest
/// are pooled together until each pool expects at least `min_expected` (Mitsuba's rule); a
/// sample in a bin with zero expected count fails the test outright.
pub fn chi2_test(observed: &[f64], expected: &[f64], min_expected: f64) -> Chi2Outcome {
    assert_eq!(observed.len(), expected.len());
    let mut order: Vec<usize> = (0..observed.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let mut bins: Vec<(f64, f64)> = Vec::new();
    let (mut pool_obs, mut pool_exp) = (0.0, 0.0);
    for &i in &order {
        let (o, e) = (observed[i], expected[i]);
        if e <= 0.0 {
            if o > 0.0 {
                return Chi2Outcome {
                    statistic: f64::INFINITY,
                    dof: 0,
                    p_value: 0.0,
                    note: Some(format!(
                        "{o} samples in bin {i} where the pdf integrates to 0"
                    )),
                };
            }
            continue;
        }
        if pool_exp > 0.0 || e < min_expected {
            pool_obs += o;
            pool_exp += e;
            if pool_exp >= min_expected {
                bins.push((pool_obs, pool_exp));
                pool_obs = 0.0;
                pool_exp = 0.0;
            }
        } else {
            bins.push((o, e));
        }
    }
    if pool_exp > 0.0 {
        // Leftover pool below the threshold: merge it into the smallest emitted bin.
        match bins.first_mut() {
            Some(b) => {
                b.0 += pool_obs;
                b.1 += pool_exp;
            }
            None => bins.push((pool_obs, pool_exp)),
        }
    }
    let statistic: f64 = bins.iter().map(|&(o, e)| (o - e) * (o - e) / e).sum();
    let dof = bins.len().saturating_sub(1);
    Chi2Outcome {
        statistic,
        dof,
        p_value: chi2_sf(statistic, dof),
        note: None,
    }
}

/// Adaptive Simpson quadrature of `f` over `[a, b]` to absolute tolerance `eps`. Recursion
/// follows peaks (a Henyey-Greenstein lobe at g = 0.99 is ~1e-4 wide in cos theta).
pub fn integrate(f: &dyn Fn(f64) -> f64, a: f64, b: f64, eps: f64) -> f64 {
    #[allow(clippy::too_many_arguments)]
    fn rec(
        f: &dyn Fn(f64) -> f64,
        a: f64,
        b: f64,
        fa: f64,
        fm: f64,
        fb: f64,
        whole: f64,
        eps: f64,
        depth: u32,
    ) -> f64 {
        let m = 0.5 * (a + b);
        let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
        let (flm, frm) = (f(lm), f(rm));
        let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
        let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
        let delta = left + right - whole;
        if depth == 0 || delta.abs() <= 15.0 * eps {
            return left + right + delta / 15.0;
        }
        rec(f, a, m, fa, flm, fm, left, 0.5 * eps, depth - 1)
            + rec(f, m, b, fm, frm, fb, right, 0.5 * eps, depth - 1)
    }
    // Start from a few fixed panels so a narrow peak cannot hide between the first 3 points.
    let panels = 8;
    let h = (b - a) / panels as f64;
    (0..panels)
        .map(|k| {
            let (x0, x1) = (a + k as f64 * h, a + (k + 1) as f64 * h);
            let (f0, f1, fmid) = (f(x0), f(x1), f(0.5 * (x0 + x1)));
            let w = h / 6.0 * (f0 + 4.0 * fmid + f1);
            rec(f, x0, x1, f0, fmid, f1, w, eps / panels as f64, 40)
        })
        .sum::<f64>()
}

/// A histogram over directions in `(cos theta, phi)` with uniform bins, so every bin subtends
/// the same solid angle and `dOmega = dcos dphi` makes the pdf integral separable.
#[derive(Clone, Debug)]
pub struct SphereHistogram {
    pub n_cos: usize,
    pub n_phi: usize,
    pub counts: Vec<f64>,
}

impl SphereHistogram {
    pub fn new(n_cos: usize, n_phi: usize) -> Self {
        SphereHistogram {
            n_cos,
            n_phi,
            counts: vec![0.0; n_cos * n_phi],
        }
    }

    fn bin(&self, d: Vec3) -> usize {
        let c = ((d.z as f64 + 1.0) * 0.5 * self.n_cos as f64)
            .floor()
            .clamp(0.0, self.n_cos as f64 - 1.0) as usize;
        let mut phi = (d.y as f64).atan2(d.x as f64);
        if phi < 0.0 {
            phi += 2.0 * std::f64::consts::PI;
        }
        let p = (phi / (2.0 * std::f64::consts::PI) * self.n_phi as f64)
            .floor()
            .clamp(0.0, self.n_phi as f64 - 1.0) as usize;
        c * self.n_phi + p
    }

    pub fn add(&mut self, d: Vec3) {
        let b = self.bin(d);
        self.counts[b] += 1.0;
    }

    /// Expected counts for `n` samples of the solid-angle pdf `pdf(cos_theta, phi)`.
    pub fn expected(&self, n: f64, pdf: &dyn Fn(f64, f64) -> f64, eps: f64) -> Vec<f64> {
        let two_pi = 2.0 * std::f64::consts::PI;
        let mut out = vec![0.0; self.counts.len()];
        for c in 0..self.n_cos {
            let (c0, c1) = (
                -1.0 + 2.0 * c as f64 / self.n_cos as f64,
                -1.0 + 2.0 * (c + 1) as f64 / self.n_cos as f64,
            );
            for p in 0..self.n_phi {
                let (p0, p1) = (
                    two_pi * p as f64 / self.n_phi as f64,
                    two_pi * (p + 1) as f64 / self.n_phi as f64,
                );
                let inner = |phi: f64| integrate(&|mu| pdf(mu, phi), c0, c1, eps);
                out[c * self.n_phi + p] = n * integrate(&inner, p0, p1, eps);
            }
        }
        out
    }
}

/// Counts of `samples` in `bins` equal-width bins over `[lo, hi)`; samples outside are ignored
/// (callers give them their own bin).
pub fn histogram_1d(
    samples: impl IntoIterator<Item = f64>,
    lo: f64,
    hi: f64,
    bins: usize,
) -> Vec<f64> {
    let mut h = vec![0.0; bins];
    for x in samples {
        if x >= lo && x < hi {
            let i = (((x - lo) / (hi - lo)) * bins as f64).floor() as usize;
            h[i.min(bins - 1)] += 1.0;
        }
    }
    h
}

/// Expected counts of `n` samples of `pdf` over the same equal-width bins.
pub fn expected_1d(
    n: f64,
    pdf: &dyn Fn(f64) -> f64,
    lo: f64,
    hi: f64,
    bins: usize,
    eps: f64,
) -> Vec<f64> {
    let w = (hi - lo) / bins as f64;
    (0..bins)
        .map(|i| n * integrate(pdf, lo + i as f64 * w, lo + (i + 1) as f64 * w, eps))
        .collect()
}
