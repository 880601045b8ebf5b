//! The agreement of two renders of one scene that `--against` prints: the image mean's relative
//! difference and z-score, and a z-test per 8x8 block, of the colours and of the alphas.
use anyhow::{bail, Result};

use crate::film::Image;
use crate::study::stats::erfc;

/// Agreement of two renders of the same scene.
#[derive(Debug, Clone)]
pub struct Agreement {
    /// (mean(b) - mean(a)) / mean(a) over all pixels, per channel and for R+G+B.
    pub mean_rel_diff: [f64; 4],
    /// z-score of the R+G+B image-mean difference.
    pub mean_z: f64,
    pub blocks: usize,
    pub failed_blocks: usize,
    /// Largest |z| of any block and channel.
    pub max_block_z: f64,
    /// The alphas' agreement, where either image has an alpha below 1 (a transparent film).
    pub alpha: Option<AlphaAgreement>,
}

/// Agreement of two renders' alpha (coverage).
#[derive(Debug, Clone)]
pub struct AlphaAgreement {
    /// (mean(b) - mean(a)) / mean(a) of the alpha over all pixels.
    pub mean_rel_diff: f64,
    pub failed_blocks: usize,
    /// Largest |z| of any block.
    pub max_block_z: f64,
}

impl std::fmt::Display for Agreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = self.mean_rel_diff;
        write!(
            f,
            "mean_rel_diff {:+.4} (R {:+.4} G {:+.4} B {:+.4}) mean_z {:+.2} \
             blocks_failed {}/{} ({:.2} %) max_block_z {:.2}",
            m[3],
            m[0],
            m[1],
            m[2],
            self.mean_z,
            self.failed_blocks,
            self.blocks,
            100.0 * self.failed_blocks as f64 / self.blocks.max(1) as f64,
            self.max_block_z
        )?;
        if let Some(a) = &self.alpha {
            write!(
                f,
                " alpha_mean_rel_diff {:+.4} alpha_blocks_failed {}/{} alpha_max_block_z {:.2}",
                a.mean_rel_diff, a.failed_blocks, self.blocks, a.max_block_z
            )?;
        }
        Ok(())
    }
}

/// The alphas of `a` and `b` compared as [`compare`] compares colours, per `block`x`block`
/// block at level `level`; `None` where both are opaque. Neither renderer writes the alpha's
/// variance, so each pixel's is bounded by `A (1 - A) / n` (alpha samples lie in [0, 1], `n`
/// the pixel's samples): a conservative test.
fn compare_alpha(a: &Image, b: &Image, block: usize, level: f64) -> Option<AlphaAgreement> {
    let (aa, ab) = (a.alpha.as_ref()?, b.alpha.as_ref()?);
    if aa.iter().chain(ab).all(|&x| x == 1.0) {
        return None;
    }
    let var = |img: &Image, al: &[f32], p: usize| {
        let n = img.samples.as_ref().map_or(1.0, |s| s[p].max(1.0) as f64);
        let x = (al[p] as f64).clamp(0.0, 1.0);
        x * (1.0 - x) / n
    };
    let (sa, sb): (f64, f64) = (
        aa.iter().map(|&x| x as f64).sum(),
        ab.iter().map(|&x| x as f64).sum(),
    );
    let z_crit = normal_quantile(1.0 - level / 2.0);
    let (bw, bh) = (a.width / block, a.height / block);
    let (mut failed, mut max_z) = (0, 0f64);
    for by in 0..bh {
        for bx in 0..bw {
            let (mut d, mut v, mut s) = (0f64, 0f64, 0f64);
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let p = y * a.width + x;
                    d += ab[p] as f64 - aa[p] as f64;
                    v += var(a, aa, p) + var(b, ab, p);
                    s += aa[p] as f64;
                }
            }
            // As for colours: float rounding of a deterministic value must not count.
            let v = v + (1e-6 * (2.0 * s.abs() + d.abs())).powi(2);
            let z = if v > 0.0 {
                d.abs() / v.sqrt()
            } else if d == 0.0 {
                0.0
            } else {
                f64::INFINITY
            };
            max_z = max_z.max(z);
            failed += (z > z_crit) as usize;
        }
    }
    Some(AlphaAgreement {
        mean_rel_diff: (sb - sa) / sa,
        failed_blocks: failed,
        max_block_z: max_z,
    })
}

/// Image mean relative difference of `b` against `a`, and a z-test per `block`x`block` block
/// and channel with both variance layers; a block fails when any channel rejects at the
/// Sidak-corrected level for three channels, so the block test is at `alpha`.
pub fn compare(a: &Image, b: &Image, block: usize, alpha: f64) -> Result<Agreement> {
    if a.width != b.width || a.height != b.height {
        bail!(
            "sizes differ: {}x{} vs {}x{}",
            a.width,
            a.height,
            b.width,
            b.height
        );
    }
    let (va, vb) = match (&a.variance, &b.variance) {
        (Some(x), Some(y)) => (x, y),
        _ => bail!("both images need a variance layer (reference renderers: --runs >= 2)"),
    };
    let n = a.width * a.height;
    let mut sum = [[0f64; 4]; 2];
    let mut var_sum = 0f64;
    for p in 0..n {
        for c in 0..3 {
            sum[0][c] += a.rgb[p][c] as f64;
            sum[1][c] += b.rgb[p][c] as f64;
            var_sum += va[p][c] as f64 + vb[p][c] as f64;
        }
    }
    for s in &mut sum {
        s[3] = s[0] + s[1] + s[2];
    }
    let mean_rel_diff = std::array::from_fn(|c| (sum[1][c] - sum[0][c]) / sum[0][c]);
    let mean_z = (sum[1][3] - sum[0][3]) / var_sum.sqrt();

    let alpha_channel = 1.0 - (1.0 - alpha).powf(1.0 / 3.0);
    let z_crit = normal_quantile(1.0 - alpha_channel / 2.0);
    let (bw, bh) = (a.width / block, a.height / block);
    // An average block's magnitude per channel: the rounding floor below never falls under a
    // millionth of it, so blocks whose values are float noise (a blackbody's faint negative
    // tail, 1e-12 against a flame of 0.3) cannot fail.
    let typical: [f64; 3] = std::array::from_fn(|c| {
        let sum: f64 = a.rgb.iter().map(|p| (p[c] as f64).abs()).sum();
        sum / n.max(1) as f64 * (block * block) as f64
    });
    let (mut failed, mut max_z) = (0, 0f64);
    for by in 0..bh {
        for bx in 0..bw {
            let mut d = [0f64; 3];
            let mut v = [0f64; 3];
            let mut sum_a = [0f64; 3];
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let p = y * a.width + x;
                    for c in 0..3 {
                        d[c] += b.rgb[p][c] as f64 - a.rgb[p][c] as f64;
                        sum_a[c] += a.rgb[p][c] as f64;
                        v[c] += va[p][c] as f64 + vb[p][c] as f64;
                    }
                }
            }
            let mut fail = false;
            for c in 0..3 {
                // Float rounding (a constant background, 0.3 vs 0.30000001 across runs)
                // must not count: a variance floor at 1e-6 of the block's value.
                let scale = sum_a[c].abs() + (sum_a[c] + d[c]).abs() + typical[c];
                let v_eff = v[c] + (1e-6 * scale).powi(2);
                let z = if v_eff > 0.0 {
                    d[c] / v_eff.sqrt()
                } else if d[c] == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                };
                max_z = max_z.max(z.abs());
                fail |= z.abs() > z_crit;
            }
            failed += fail as usize;
        }
    }
    Ok(Agreement {
        mean_rel_diff,
        mean_z,
        blocks: bw * bh,
        failed_blocks: failed,
        max_block_z: max_z,
        alpha: compare_alpha(a, b, block, alpha),
    })
}

/// Standard normal quantile by bisection on the CDF (erfc by Numerical Recipes' Chebyshev
/// fit, relative error < 1.2e-7).
fn normal_quantile(p: f64) -> f64 {
    let cdf = |z: f64| 0.5 * erfc(-z / std::f64::consts::SQRT_2);
    let (mut lo, mut hi) = (-40.0, 40.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_quantile_matches_tables() {
        assert!((erfc(0.5) - 0.4795001).abs() < 1e-6);
        assert!((erfc(-1.0) - 1.8427008).abs() < 1e-6);
        assert!((normal_quantile(0.975) - 1.959964).abs() < 1e-4);
        assert!((normal_quantile(0.9995) - 3.290527).abs() < 1e-4);
    }
}
