//! Choosing one of a few events with one uniform.
//!
//! Every tracking estimator picks among mutually exclusive events (absorb, scatter, null, ...)
//! by inverting one CDF with one uniform. Remapping the uniform afterwards lets a second,
//! nested choice reuse it (e.g. decomposition tracking: control vs residual, then which
//! residual event) without changing the number of draws the WGSL mirror must make.

/// The outcome of [`sample_discrete`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscreteSample {
    /// The chosen index.
    pub index: usize,
    /// Its probability `w[index] / sum(w)`.
    pub pmf: f32,
    /// `u` rescaled to `[0, 1)` within the chosen interval: uniform and independent of the
    /// choice, so it may be reused.
    pub u_remapped: f32,
}

/// The largest f32 below one.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Chooses index `i` with probability `w[i] / sum(w)` by inverting the CDF at `u` in `[0, 1)`.
/// Weights must be non-negative (callers pass `|sigma_x|`). Returns `None` when every weight is
/// zero. Zero-weight entries are never chosen, even when rounding puts `u * sum` past the last
/// partial sum.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn sample_discrete(weights: &[f32], u: f32) -> Option<DiscreteSample> {
    let sum: f32 = weights.iter().sum();
    // Written negated so that a NaN sum also returns None.
    if !(sum > 0.0) {
        return None;
    }
    let up = u * sum;
    let mut acc = 0.0f32;
    let mut last_nonzero = None;
    for (i, &w) in weights.iter().enumerate() {
        if w <= 0.0 {
            continue;
        }
        last_nonzero = Some(i);
        if up < acc + w {
            let u_remapped = ((up - acc) / w).clamp(0.0, ONE_MINUS_EPSILON);
            return Some(DiscreteSample {
                index: i,
                pmf: w / sum,
                u_remapped,
            });
        }
        acc += w;
    }
    // Rounding: `u * sum` reached the rounded total. Give the mass to the last real entry.
    let i = last_nonzero?;
    Some(DiscreteSample {
        index: i,
        pmf: weights[i] / sum,
        u_remapped: ONE_MINUS_EPSILON,
    })
}

/// Probability mass of `index` under [`sample_discrete`]; 0 when all weights are zero.
pub fn discrete_pmf(weights: &[f32], index: usize) -> f32 {
    let sum: f32 = weights.iter().sum();
    if sum > 0.0 {
        weights[index] / sum
    } else {
        0.0
    }
}
