//! Bounds for lookups at advected points, the majorants and minorants of velocity motion blur.
//!
//! Blurred by a velocity field, a lookup at index point `p` and time offset `dt` reads the
//! density at `p - s`, where the displacement `s = v(p) dt` is at most `r` long: the speed
//! bound of `p`'s cell (`SpeedBounds`) times the largest `|dt|` of the shutter, in index units.
//! Every point within `r` of bounds cell `c` lies in a cell whose box comes within `r` of `c`'s
//! box (at most `ceil(r / 8)` cells away along each axis), and every value reconstructed in a
//! cell lies within that cell's [`CellBounds`] (`volume::bounds`). So the union of the bounds
//! of those cells bounds every advected lookup made from `c` at any time of the shutter: a
//! true majorant and minorant, with no statistical guess of the velocity.
use rayon::prelude::*;

use super::advection::Advection;
use super::bounds::{CellBounds, LeafBounds, CELL_WIDTH};
use crate::math::DVec3;

/// `bounds` dilated for lookups advected along `adv` at factors `|k| <= k_max`
/// ([`Advection::source`]): each cell's radius is [`Advection::radius`] over the cell, so
/// the result bounds every value a blurred lookup made from the cell reads. `outside` stands
/// for the cells beyond `bounds`' box. `None` where the velocity is unbounded (an infinite
/// speed or factor) or the dilated box would exceed `max_cells` cells.
pub fn advected_bounds(
    bounds: &LeafBounds,
    outside: CellBounds,
    adv: &Advection,
    k_max: f64,
    max_cells: u64,
) -> Option<LeafBounds> {
    let reach = k_max * adv.max_speed();
    if !reach.is_finite() {
        return None;
    }
    // Covers the largest radius of any cell, the background's included.
    let grow = (reach / CELL_WIDTH as f64).ceil() as u64 + 1;
    let cells: u64 = bounds.dims.iter().map(|&d| d as u64 + 2 * grow).product();
    if grow > u32::MAX as u64 / 4 || cells > max_cells {
        return None;
    }
    let w = CELL_WIDTH as f64;
    Some(dilated_bounds(bounds, outside, grow as u32, |c| {
        let lo = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * w;
        adv.radius(lo, lo + DVec3::splat(w), k_max)
    }))
}

/// `bounds` dilated for advection, over its cell box grown by `grow` cells on every side. Cell
/// `c` of the result (absolute cell coordinates) holds the union of the bounds of the cells
/// whose boxes come within `radius(c)` of its box, `outside` standing for the cells
/// beyond `bounds`' box (the grid's background). `radius(c)` is the longest displacement, in
/// index units, of a lookup made in cell `c`; `grow` must cover the largest radius where it is
/// not 0 outside the box. The result has no per-voxel table (no voxel culling).
pub fn dilated_bounds(
    bounds: &LeafBounds,
    outside: CellBounds,
    grow: u32,
    radius: impl Fn([i32; 3]) -> f64 + Sync,
) -> LeafBounds {
    let origin = bounds.cell_origin.map(|o| o - grow as i32);
    let dims = bounds.dims.map(|d| d + 2 * grow);
    let at = |c: [i32; 3]| -> CellBounds {
        let rel = [0, 1, 2].map(|a| c[a] as i64 - bounds.cell_origin[a] as i64);
        if (0..3).any(|a| rel[a] < 0 || rel[a] >= bounds.dims[a] as i64) {
            return outside;
        }
        bounds.get(rel[0] as u32, rel[1] as u32, rel[2] as u32)
    };
    let [nx, ny, nz] = dims.map(|d| d as usize);
    let cells: Vec<CellBounds> = (0..nx * ny * nz)
        .into_par_iter()
        .map(|index| {
            let rel = [index % nx, index / nx % ny, index / (nx * ny)];
            let c = [0, 1, 2].map(|a| origin[a] + rel[a] as i32);
            let r = radius(c);
            // Also the whole box for a NaN or infinite radius: never an unsound bound.
            let k = if r <= 0.0 {
                0
            } else if r.is_finite() {
                (r / CELL_WIDTH as f64).ceil().min(i32::MAX as f64 / 4.0) as i32
            } else {
                i32::MAX / 4
            };
            let lo = [0, 1, 2].map(|a| (c[a] - k).max(origin[a] - 1));
            let hi = [0, 1, 2].map(|a| (c[a] + k).min(origin[a] + dims[a] as i32));
            // Only the cells whose box comes within `r` of cell `c`'s box: the corners of the
            // cube of cells `k` away lie farther than `r` once `k >= 2`.
            let gap = |a: usize, x: i32| ((x - c[a]).abs() - 1).max(0) as f64 * CELL_WIDTH as f64;
            let r2 = r * r;
            let mut b = CellBounds::EMPTY;
            for z in lo[2]..=hi[2] {
                let gz = gap(2, z).powi(2);
                for y in lo[1]..=hi[1] {
                    let gyz = gz + gap(1, y).powi(2);
                    for x in lo[0]..=hi[0] {
                        if gyz + gap(0, x).powi(2) <= r2 {
                            b = b.union(at([x, y, z]));
                        }
                    }
                }
            }
            b
        })
        .collect();
    LeafBounds::from_cells(cells, dims, origin)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::convert::{dense_to_vdb, ConversionPolicy};
    use crate::volume::{check::SplitMix64, SparseGrid};
    use glam::DVec3;

    /// Random lookups displaced by up to each cell's radius stay inside the dilated bounds of
    /// the cell they are made from, and a zero radius keeps a cell's own bounds.
    #[test]
    fn every_displaced_lookup_stays_within_the_dilated_bounds() {
        let mut rng = SplitMix64(0x6d0);
        let n = [40usize, 24, 32];
        let values: Vec<f32> = (0..n[0] * n[1] * n[2])
            .map(|_| {
                let u = rng.range(0.0, 1.0);
                if u < 0.6 {
                    0.0
                } else {
                    (u * 3.0) as f32
                }
            })
            .collect();
        let data = dense_to_vdb(n, [-5, 3, -17], &values, 0.0).unwrap();
        let (grid, _) = SparseGrid::from_vdb(&data, ConversionPolicy::default()).unwrap();
        let bounds = LeafBounds::build(&grid);
        // Radii of 0 to 20 voxels, varying from cell to cell.
        let radius = |c: [i32; 3]| ((c[0] * 7 + c[1] * 3 + c[2]).rem_euclid(6) as f64) * 4.0;
        let grown = dilated_bounds(&bounds, CellBounds::point(0.0), 3, radius);
        let mut checked = 0;
        for _ in 0..200_000 {
            let lo = grid.cell_origin.map(|o| o as f64 * 8.0 - 16.0);
            let p = DVec3::new(
                rng.range(lo[0], lo[0] + 8.0 * grid.dims[0] as f64 + 32.0),
                rng.range(lo[1], lo[1] + 8.0 * grid.dims[1] as f64 + 32.0),
                rng.range(lo[2], lo[2] + 8.0 * grid.dims[2] as f64 + 32.0),
            );
            let c = p.to_array().map(|x| (x / 8.0).floor() as i32);
            let rel = [0, 1, 2].map(|a| c[a] - grown.cell_origin[a]);
            if (0..3).any(|a| rel[a] < 0 || rel[a] >= grown.dims[a] as i32) {
                continue;
            }
            let r = radius(c);
            let dir = DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let s = dir.normalize_or_zero() * r * rng.range(0.0, 1.0);
            let v = grid.sample_trilinear(p - s);
            let b = grown.get(rel[0] as u32, rel[1] as u32, rel[2] as u32);
            assert!(
                v >= b.min && v <= b.max,
                "lookup at {p} displaced by {s} reads {v}, outside [{}, {}]",
                b.min,
                b.max
            );
            if r == 0.0 && (0..3).all(|a| c[a] >= grid.cell_origin[a]) {
                let own = [0, 1, 2].map(|a| c[a] - grid.cell_origin[a]);
                if (0..3).all(|a| own[a] < grid.dims[a] as i32) {
                    let ob = bounds.get(own[0] as u32, own[1] as u32, own[2] as u32);
                    assert_eq!(b, ob, "a still cell keeps its own bounds");
                }
            }
            checked += 1;
        }
        assert!(checked > 100_000, "{checked}");
    }
}
