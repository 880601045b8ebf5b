//! [`SpeedBounds`]: per-leaf-cell upper bounds on the speed `|v|` that a vector grid's
//! trilinear lookups return, the distance per unit time that motion-blur majorants must dilate
//! a cell by.
//!
//! For leaf cell `c` (the index points `p` with `floor(p / 8) = c`, i.e. `[8c, 8c + 8)` per
//! axis) a trilinear lookup of component `a` reads voxels `8c ..= 8c + 8` on every axis, and
//! on axis `a` up to `8c + 9` for a staggered grid (it reads at `p + 0.5 e_a`). The bound of
//! component `a` is the largest `|value|` over exactly those voxels; since trilinear weights are
//! convex, `|v_a(p)| <= M_a` and `|v(p)| <= sqrt(M_x^2 + M_y^2 + M_z^2)`.
use rayon::prelude::*;

use super::grid::{BRICK_VOXELS, CONSTANT_BIT};
use super::SparseGrid;
use crate::math::{DAffine3, DVec3};

/// Relative slack on every bound: OpenVDB's blends round three times per level, three levels
/// deep, each time by at most `2^-24` relative to the largest input, so a computed sample can
/// exceed the largest voxel magnitude by about `15 * 2^-24`; `2^-18` covers that fourfold.
const ROUNDING_SLACK: f64 = 1.0 + 1.0 / (1 << 18) as f64;

/// Per-leaf-cell speed bounds over a vector grid's cell box (the box of its components).
#[derive(Clone, Debug, Default)]
pub struct SpeedBounds {
    /// Cell counts of the box, as the components' `dims`.
    pub dims: [u32; 3],
    /// Cell coordinate of entry 0, as the components' `cell_origin`.
    pub cell_origin: [i32; 3],
    /// Per cell (x fastest): for each component, a bound on its magnitude at every index
    /// point of the cell, in the grid's value units.
    pub component_max: Vec<[f32; 3]>,
    /// Per cell: a bound on `|v|` at every index point of the cell, in the grid's value units.
    pub speed: Vec<f32>,
    /// The component bounds outside the cell box, where every lookup is the background.
    pub outside_component_max: [f32; 3],
    /// The speed bound outside the cell box.
    pub outside_speed: f32,
}

/// `x` rounded up to an `f32` (for non-negative `x`).
fn round_up_f32(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f32::from_bits(f.to_bits() + 1)
    } else {
        f
    }
}

/// The bound on `|v|` from component bounds, with the rounding slack.
fn speed_of(m: [f32; 3]) -> f32 {
    let s = m
        .iter()
        .map(|&c| (c as f64) * (c as f64))
        .sum::<f64>()
        .sqrt();
    round_up_f32(s * ROUNDING_SLACK)
}

/// Largest `|value|` of each cell's own 8^3 voxels.
fn own_maxima(grid: &SparseGrid) -> Vec<f32> {
    grid.cells
        .par_iter()
        .map(|&entry| {
            if entry & CONSTANT_BIT != 0 {
                grid.constants[(entry & !CONSTANT_BIT) as usize].abs()
            } else {
                let base = entry as usize * BRICK_VOXELS;
                grid.bricks[base..base + BRICK_VOXELS]
                    .iter()
                    .fold(0.0f32, |m, v| m.max(v.abs()))
            }
        })
        .collect()
}

impl SpeedBounds {
    /// Bounds for three components that share one cell box (see [`super::VectorGrid`]).
    pub fn build(components: &[SparseGrid; 3], staggered: bool) -> Self {
        let g = &components[0];
        let outside_component_max = components.each_ref().map(|c| c.background.abs());
        let mut bounds = Self {
            dims: g.dims,
            cell_origin: g.cell_origin,
            component_max: Vec::new(),
            speed: Vec::new(),
            outside_component_max: outside_component_max
                .map(|m| round_up_f32(m as f64 * ROUNDING_SLACK)),
            outside_speed: speed_of(outside_component_max),
        };
        let own = components.each_ref().map(own_maxima);
        let [nx, ny, _] = g.dims.map(|d| d as usize);
        let maxima: Vec<[f32; 3]> = (0..g.cells.len())
            .into_par_iter()
            .map(|index| {
                let cell = [index % nx, index / nx % ny, index / (nx * ny)];
                std::array::from_fn(|a| {
                    let mut extent = [1i64; 3];
                    if staggered {
                        extent[a] = 2;
                    }
                    component_max(&components[a], &own[a], cell, extent)
                })
            })
            .collect();
        bounds.component_max = maxima
            .iter()
            .map(|m| m.map(|c| round_up_f32(c as f64 * ROUNDING_SLACK)))
            .collect();
        bounds.speed = maxima.iter().map(|&m| speed_of(m)).collect();
        bounds
    }

    /// Linear index of the cell containing index point `p`, or `None` outside the box (and at
    /// NaN coordinates).
    pub fn cell_at(&self, p: DVec3) -> Option<usize> {
        let mut index = 0usize;
        let mut stride = 1usize;
        for (a, c) in p.to_array().into_iter().enumerate() {
            let cell = (c / 8.0).floor() - self.cell_origin[a] as f64;
            // Also false for NaN.
            if !(cell >= 0.0 && cell < self.dims[a] as f64) {
                return None;
            }
            index += cell as usize * stride;
            stride *= self.dims[a] as usize;
        }
        Some(index)
    }

    /// The speed bound for lookups at index point `p` (its cell's, or the background's).
    pub fn speed_at(&self, p: DVec3) -> f32 {
        self.cell_at(p)
            .map_or(self.outside_speed, |index| self.speed[index])
    }

    /// The largest speed any lookup can return, in the grid's value units.
    pub fn max_speed(&self) -> f32 {
        self.speed.iter().fold(self.outside_speed, |m, &s| m.max(s))
    }

    /// A bound on the index-space speed `|L v|` for component bounds `m`, where `L` is the
    /// linear part of `index_from_world` (the values read as world-space vectors): voxels per
    /// unit time when the values are world units per unit time. Exact for axis-aligned voxels.
    pub fn index_speed(m: [f32; 3], index_from_world: &DAffine3) -> f64 {
        let l = index_from_world.matrix3;
        let s = (0..3)
            .map(|i| {
                let row: f64 = (0..3).map(|j| l.col(j)[i].abs() * m[j] as f64).sum();
                row * row
            })
            .sum::<f64>()
            .sqrt();
        s * (1.0 + 1e-12)
    }

    /// The largest index-space speed any lookup can return (see [`Self::index_speed`]).
    pub fn max_index_speed(&self, index_from_world: &DAffine3) -> f64 {
        self.component_max
            .iter()
            .map(|&m| Self::index_speed(m, index_from_world))
            .fold(
                Self::index_speed(self.outside_component_max, index_from_world),
                f64::max,
            )
    }

    /// Bytes of the per-cell tables.
    pub fn memory_bytes(&self) -> u64 {
        (self.component_max.len() * 12 + self.speed.len() * 4) as u64
    }
}

/// Largest `|value|` of `grid` over the voxels `8 cell ..= 8 cell + 7 + extent` (relative to the
/// grid's cell origin): the cell's own maximum, widened by its upper neighbours' voxels only
/// where a neighbour's own maximum says they could exceed it.
fn component_max(grid: &SparseGrid, own: &[f32], cell: [usize; 3], extent: [i64; 3]) -> f32 {
    let at = |c: [usize; 3]| -> f32 {
        if (0..3).all(|a| c[a] < grid.dims[a] as usize) {
            own[grid.cell_index(c[0] as u32, c[1] as u32, c[2] as u32)]
        } else {
            grid.background.abs()
        }
    };
    let mine = at(cell);
    let neighbours = (1..8)
        .map(|d: usize| {
            at([
                cell[0] + (d & 1),
                cell[1] + (d >> 1 & 1),
                cell[2] + (d >> 2),
            ])
        })
        .fold(0.0f32, f32::max);
    if neighbours <= mine {
        return mine;
    }
    // The halo: stencil voxels past the cell's upper faces, read one by one.
    let lo = [0, 1, 2].map(|a| 8 * (grid.cell_origin[a] as i64 + cell[a] as i64));
    let mut m = mine;
    for k in lo[2]..=lo[2] + 7 + extent[2] {
        for j in lo[1]..=lo[1] + 7 + extent[1] {
            for i in lo[0]..=lo[0] + 7 + extent[0] {
                if i >= lo[0] + 8 || j >= lo[1] + 8 || k >= lo[2] + 8 {
                    m = m.max(grid.voxel(i as i32, j as i32, k as i32).abs());
                }
            }
        }
    }
    m
}
