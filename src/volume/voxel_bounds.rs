//! Per-voxel bounds for culling: the finest bound a walk can thin its tentative collisions by
//! without taking a single step more (see `volume::cull`).
//!
//! For each voxel `v` of each brick, the maximum over its trilinear support `v + {0,1}^3`: the
//! eight voxels every lookup at a point `p` with `floor(p) = v` reads (trilinear blends them;
//! nearest reads `round(p)`, one of them). A blend of values is at most their maximum, so the
//! density at any such point is at most this bound. It is stored relative to the bound of the
//! voxel's leaf cell `cm` (`LeafBounds::cells[..].max`, which covers the support through its
//! apron) as one byte `q`, rounded up: the smallest `q` with `(q * (1/255)) * cm >= max` in
//! `f32` arithmetic, the expression the culling evaluates (CPU and WGSL alike). One byte a
//! voxel is a quarter of the brick's own memory; `q = 255` means "no tighter than the cell".
//! Constant cells need no table: their support may reach a neighbour, and they cull by the
//! cell bound alone.
use rayon::prelude::*;

use std::borrow::Cow;

use super::bounds::{CellBounds, LeafBounds};
use super::grid::{SparseGrid, BRICK_VOXELS, CONSTANT_BIT};

/// The `q` of a voxel whose support maximum is `max` in a cell bounded by `cm`: the smallest
/// byte with `(q * (1/255)) * cm >= max` (255 where none is smaller, or where `cm` is not
/// positive and finite: nothing to thin by there).
pub fn quantize_up(max: f32, cm: f32) -> u8 {
    if !(cm > 0.0 && cm.is_finite() && max < cm) {
        return 255;
    }
    let covers = |q: u32| (q as f32 * (1.0 / 255.0)) * cm >= max;
    // A first guess from the ratio, then the exact f32 test decides (rounding either way).
    let mut q = ((max / cm) * 255.0).ceil().clamp(0.0, 255.0) as u32;
    while q > 0 && covers(q - 1) {
        q -= 1;
    }
    while q < 255 && !covers(q) {
        q += 1;
    }
    q as u8
}

// The max filter reads index `i + 1` beside `i`: plainer as indices than as iterators.
#[allow(clippy::needless_range_loop)]
/// The per-voxel `q` bytes of every brick of `grid` (indexed as the bricks' voxels), relative
/// to the cell bounds `cells` (on the grid's dense cell index), in parallel over cells.
pub fn build_voxel_q(grid: &SparseGrid, cells: &[CellBounds]) -> Vec<u8> {
    let mut q = vec![255u8; grid.bricks.len()];
    let [nx, ny, _] = grid.dims.map(|d| d as usize);
    // The bricks in cell order; each brick's bytes are written by the one cell holding it.
    let mut by_brick: Vec<(usize, usize)> = grid
        .cells
        .iter()
        .enumerate()
        .filter(|(_, &e)| e & CONSTANT_BIT == 0)
        .map(|(index, &e)| (e as usize, index))
        .collect();
    by_brick.sort_unstable();
    let chunks: Vec<(usize, &mut [u8])> = q.chunks_mut(BRICK_VOXELS).enumerate().collect();
    chunks.into_par_iter().for_each(|(brick, out)| {
        let Ok(k) = by_brick.binary_search_by_key(&brick, |&(b, _)| b) else {
            return;
        };
        let index = by_brick[k].1;
        let c = [index % nx, index / nx % ny, index / (nx * ny)];
        let v0 = [0, 1, 2].map(|a| (grid.cell_origin[a] + c[a] as i32) * 8);
        // The brick's voxels and the first voxel past it on each axis (9^3), then the maximum
        // over each voxel's 2x2x2 support, one axis at a time.
        // The brick's own 512 straight from it; only the 217 on the far faces by lookup.
        let own = &grid.bricks[brick * BRICK_VOXELS..][..BRICK_VOXELS];
        let mut m = [[[0f32; 9]; 9]; 9];
        for (z, plane) in m.iter_mut().enumerate() {
            for (y, row) in plane.iter_mut().enumerate() {
                for (x, v) in row.iter_mut().enumerate() {
                    *v = if x < 8 && y < 8 && z < 8 {
                        own[x + 8 * y + 64 * z]
                    } else {
                        grid.voxel(v0[0] + x as i32, v0[1] + y as i32, v0[2] + z as i32)
                    };
                }
            }
        }
        for plane in m.iter_mut() {
            for row in plane.iter_mut() {
                for x in 0..8 {
                    row[x] = row[x].max(row[x + 1]);
                }
            }
        }
        for plane in m.iter_mut() {
            for y in 0..8 {
                for x in 0..8 {
                    plane[y][x] = plane[y][x].max(plane[y + 1][x]);
                }
            }
        }
        for z in 0..8 {
            for y in 0..8 {
                for x in 0..8 {
                    m[z][y][x] = m[z][y][x].max(m[z + 1][y][x]);
                }
            }
        }
        let cm = cells[index].max;
        for z in 0..8 {
            for y in 0..8 {
                for x in 0..8 {
                    out[x + 8 * y + 64 * z] = quantize_up(m[z][y][x], cm);
                }
            }
        }
    });
    q
}

/// What reading a voxel's bound, and the uniform that thins by it, cost at a tentative
/// collision, in lookups (a collision's density lookup is 1): fitted to `brume bench render`
/// (the cloud, which keeps 52 % of its collisions, rendered 3 % slower with the voxel stage;
/// the sunlit plume, which keeps 35 %, in the same time).
pub const VOXEL_READ_COST: f64 = 0.6;

/// `bounds.voxel_q` with `bounds.voxel_floor` applied (every voxel of cell `c`'s brick at least
/// `floor[c]`; `entries` the grid's dense cell index), as one table for the GPU: borrowed where
/// there is no floor, a copy only for the upload otherwise.
pub fn floored_voxel_q<'a>(bounds: &'a LeafBounds, entries: &[u32]) -> Cow<'a, [u8]> {
    if bounds.voxel_floor.is_empty() || bounds.voxel_q.is_empty() {
        return Cow::Borrowed(&bounds.voxel_q);
    }
    let mut q = bounds.voxel_q.to_vec();
    for (&entry, &f) in entries.iter().zip(&bounds.voxel_floor) {
        if f > 0 && entry & CONSTANT_BIT == 0 {
            let brick = entry as usize * BRICK_VOXELS;
            if let Some(b) = q.get_mut(brick..brick + BRICK_VOXELS) {
                b.iter_mut().for_each(|v| *v = (*v).max(f));
            }
        }
    }
    Cow::Owned(q)
}

/// Whether thinning by the per-voxel bounds saves more than it costs on a medium whose walk
/// keeps `kept` of its collisions ([`kept_fraction`]) and reads `lookups` grids at each kept
/// one (the density and its emission grids): `(1 - kept) * lookups > VOXEL_READ_COST`.
pub fn voxel_culling_pays(kept: f64, lookups: f64) -> bool {
    (1.0 - kept) * lookups > VOXEL_READ_COST
}

/// The fraction of the per-leaf walk's tentative collisions the per-voxel bounds keep, in
/// expectation: collisions land in cell `c` at its bound's rate `max_c` (uniformly within it),
/// and one landing on voxel `v` is kept with probability `q(v) / 255` (`q` at least the cell's
/// `floor`, `LeafBounds::voxel_floor`, where there is one). Constant cells keep all (they have
/// no table). 1 for a grid with no positive bound.
pub fn kept_fraction(grid: &SparseGrid, bounds: &LeafBounds) -> f64 {
    let (cells, q, floor) = (&bounds.cells, &bounds.voxel_q, &bounds.voxel_floor);
    let (mut kept, mut all) = (0f64, 0f64);
    for (c, &entry) in grid.cells.iter().enumerate() {
        let w = cells[c].max.max(0.0) as f64;
        if w == 0.0 || !w.is_finite() {
            continue;
        }
        let t = if entry & CONSTANT_BIT != 0 || q.is_empty() {
            1.0
        } else {
            let b = &q[entry as usize * BRICK_VOXELS..][..BRICK_VOXELS];
            let f = floor.get(c).copied().unwrap_or(0);
            b.iter().map(|&v| v.max(f) as f64).sum::<f64>() / (255.0 * BRICK_VOXELS as f64)
        };
        kept += w * t;
        all += w;
    }
    if all > 0.0 {
        kept / all
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantized_bounds_cover_their_maximum_and_are_the_smallest_that_do() {
        for &cm in &[1.0f32, 0.37, 3.6e-3, 1234.5, 7.0e30] {
            for i in 0..=1000 {
                let max = cm * i as f32 / 1000.0;
                let q = quantize_up(max, cm);
                assert!(
                    (q as f32 * (1.0 / 255.0)) * cm >= max,
                    "{max} in {cm}: q {q}"
                );
                if q > 0 {
                    assert!(
                        !(((q - 1) as f32 * (1.0 / 255.0)) * cm >= max),
                        "{max} in {cm}: q {q} is not the smallest"
                    );
                }
            }
        }
        assert_eq!(quantize_up(0.0, 0.0), 255);
        assert_eq!(quantize_up(1.0, f32::INFINITY), 255);
        assert_eq!(quantize_up(2.0, 1.0), 255);
        assert_eq!(quantize_up(-1.0, 1.0), 0);
    }
}
