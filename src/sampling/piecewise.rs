//! Piecewise-constant distributions over `[0, 1)` and `[0, 1)^2`, sampled by inverting their
//! CDFs (pbrt-v4 `PiecewiseConstant1D` / `PiecewiseConstant2D`, `util/sampling.h`; PBR 4th ed.
//! sec. A.4.2 and A.4.4).
//!
//! The 2D distribution is a marginal over rows (`v`) and one conditional per row (`u`): draw
//! the row from the marginal with `u.y`, then the column from that row's conditional with
//! `u.x`. Everything lives in flat arrays so that the GPU mirror (`shaders/common/envmap.wgsl`)
//! binds them as storage buffers unchanged:
//!
//! | array         | length            | content                                             |
//! |---------------|-------------------|-----------------------------------------------------|
//! | `func`        | `nu * nv`         | the (non-negative) function, row-major              |
//! | `cond_cdf`    | `nv * (nu + 1)`   | per row: `0, ..., 1` (uniform steps for a zero row) |
//! | `marg_func`   | `nv`              | per row: the integral of the row over `u`           |
//! | `marg_cdf`    | `nv + 1`          | `0, ..., 1` over rows                               |
//!
//! and `integral`, the function's integral over the unit square. Sums run in f64 so a 4k-wide
//! row keeps its small entries. A sample never lands in a zero-valued cell: the binary search
//! picks the last entry whose CDF is `<= u`, and a zero cell has an empty CDF interval.
// Comparisons are written negated (`!(pdf > 0.0)`) so that a NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::discrete::ONE_MINUS_EPSILON;

/// A piecewise-constant function on `[0, 1)^2`, `nu` cells across and `nv` down, ready to
/// sample in proportion to its value.
#[derive(Clone, Debug, PartialEq)]
pub struct PiecewiseConstant2D {
    pub nu: usize,
    pub nv: usize,
    pub func: Vec<f32>,
    pub cond_cdf: Vec<f32>,
    pub marg_func: Vec<f32>,
    pub marg_cdf: Vec<f32>,
    /// Integral of `func` over the unit square (each cell has area `1 / (nu nv)`).
    pub integral: f32,
}

/// A point drawn from [`PiecewiseConstant2D::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample2D {
    /// The point in `[0, 1)^2`.
    pub uv: [f32; 2],
    /// Its density with respect to area on the unit square.
    pub pdf: f32,
    /// The cell `(column, row)` it fell in.
    pub cell: [usize; 2],
}

/// Index of the interval of `cdf` (non-decreasing, `cdf[0] = 0`) holding `u`: the last `i` in
/// `0..cdf.len() - 1` with `cdf[i] <= u`. Zero-width intervals are never returned for `u` in
/// `[0, 1)`, since a later entry with the same CDF value is preferred.
#[inline]
pub fn find_interval(cdf: &[f32], u: f32) -> usize {
    // partition_point gives the first index with cdf > u; the interval starts one before.
    let n = cdf.len() - 1;
    cdf.partition_point(|&c| c <= u).clamp(1, n) - 1
}

/// CDF over `f` (length `n + 1`, from 0 to 1) and the integral `sum(f) / n`; a zero (or
/// non-finite) function gets the uniform CDF and integral 0.
fn cdf_of(f: &[f32], cdf: &mut Vec<f32>) -> f64 {
    let n = f.len();
    let total: f64 = f.iter().map(|&x| x as f64).sum();
    cdf.push(0.0);
    let mut acc = 0.0f64;
    for (i, &x) in f.iter().enumerate() {
        acc += x as f64;
        cdf.push(if total > 0.0 && total.is_finite() {
            (acc / total) as f32
        } else {
            (i + 1) as f32 / n as f32
        });
    }
    // Exactly 1 at the end whatever the rounding.
    *cdf.last_mut().unwrap() = 1.0;
    if total.is_finite() {
        total / n as f64
    } else {
        0.0
    }
}

impl PiecewiseConstant2D {
    /// The distribution of `func` (row-major, `nu` across, `nv` down; values `>= 0`).
    pub fn new(func: Vec<f32>, nu: usize, nv: usize) -> Self {
        assert!(nu > 0 && nv > 0 && func.len() == nu * nv);
        debug_assert!(func.iter().all(|&x| x >= 0.0));
        let mut cond_cdf = Vec::with_capacity(nv * (nu + 1));
        let mut marg_func = Vec::with_capacity(nv);
        for row in func.chunks_exact(nu) {
            marg_func.push(cdf_of(row, &mut cond_cdf) as f32);
        }
        let mut marg_cdf = Vec::with_capacity(nv + 1);
        let integral = cdf_of(&marg_func, &mut marg_cdf) as f32;
        PiecewiseConstant2D {
            nu,
            nv,
            func,
            cond_cdf,
            marg_func,
            marg_cdf,
            integral,
        }
    }

    /// The CDF of row `v` over its `nu` columns.
    #[inline]
    fn row_cdf(&self, v: usize) -> &[f32] {
        &self.cond_cdf[v * (self.nu + 1)..(v + 1) * (self.nu + 1)]
    }

    /// Draws a point in proportion to `func` with `u` in `[0, 1)^2`: `u[1]` picks the row,
    /// `u[0]` the column. `None` when the function is zero everywhere.
    pub fn sample(&self, u: [f32; 2]) -> Option<Sample2D> {
        if !(self.integral > 0.0) {
            return None;
        }
        let (v, dv) = sample_1d(&self.marg_cdf, u[1]);
        let (c, du) = sample_1d(self.row_cdf(v), u[0]);
        let uv = [
            ((c as f32 + du) / self.nu as f32).min(ONE_MINUS_EPSILON),
            ((v as f32 + dv) / self.nv as f32).min(ONE_MINUS_EPSILON),
        ];
        Some(Sample2D {
            uv,
            pdf: self.func[v * self.nu + c] / self.integral,
            cell: [c, v],
        })
    }

    /// The density of [`Self::sample`] at `uv` (area measure on the unit square).
    pub fn pdf(&self, uv: [f32; 2]) -> f32 {
        if !(self.integral > 0.0) {
            return 0.0;
        }
        let c = ((uv[0] * self.nu as f32) as usize).min(self.nu - 1);
        let v = ((uv[1] * self.nv as f32) as usize).min(self.nv - 1);
        self.func[v * self.nu + c] / self.integral
    }
}

/// Inverts one CDF at `u`: the interval and the offset within it, in `[0, 1)`.
#[inline]
fn sample_1d(cdf: &[f32], u: f32) -> (usize, f32) {
    let i = find_interval(cdf, u);
    let width = cdf[i + 1] - cdf[i];
    let d = if width > 0.0 {
        ((u - cdf[i]) / width).clamp(0.0, ONE_MINUS_EPSILON)
    } else {
        0.0
    };
    (i, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_cells_are_never_drawn_and_pdf_matches_func() {
        // 4 x 2 with zero cells at the start, middle and end of the rows, and a zero row.
        let f = vec![0.0, 2.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        let d = PiecewiseConstant2D::new(f.clone(), 4, 2);
        assert_eq!(d.integral, 3.0 / 8.0);
        for k in 0..1000 {
            let u = [k as f32 / 1000.0, ((k * 7919) % 1000) as f32 / 1000.0];
            let s = d.sample(u).unwrap();
            let [c, v] = s.cell;
            assert!(f[v * 4 + c] > 0.0, "{u:?} -> {s:?}");
            assert_eq!(s.pdf, d.pdf(s.uv));
            assert_eq!(s.pdf, f[v * 4 + c] / d.integral);
        }
        // u at the last representable value stays inside.
        let s = d.sample([ONE_MINUS_EPSILON, ONE_MINUS_EPSILON]).unwrap();
        assert!(s.uv[0] < 1.0 && s.uv[1] < 1.0 && f[s.cell[1] * 4 + s.cell[0]] > 0.0);
        assert!(PiecewiseConstant2D::new(vec![0.0; 4], 2, 2)
            .sample([0.5, 0.5])
            .is_none());
    }
}
