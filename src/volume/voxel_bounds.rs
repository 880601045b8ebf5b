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
//! cell bound alone. The table is built with the cell bounds (`volume::bounds::build_voxel_q`);
//! this module holds what reads it.
use std::borrow::Cow;

use super::bounds::LeafBounds;
use super::grid::{SparseGrid, BRICK_VOXELS, CONSTANT_BIT};

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
    use crate::volume::bounds::quantize_up;

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
