//! Per-cell extinction bounds: the coarse majorant (and minorant) grid the DDA walks.
//!
//! Cell `c` covers index space `[8c, 8c + 8)` per axis. Its bounds are the minimum and maximum
//! over the voxel block `[8c - 1, 8c + 9]` per axis: the cell's own 8 voxels plus an apron of
//! one voxel below and two above. Trilinear reconstruction at any point `p` in
//! `[8c - 1, 8c + 9)` reads voxels `floor(p)` and `floor(p) + 1`, both inside that block, and
//! nearest lookup reads `round(p)`, also inside it. So every reconstructed value within
//! one voxel of the cell lies in `[min, max]`, which keeps the bound valid when floating-point
//! rounding of `o + t d` pushes a sample point slightly past the cell the DDA thinks it is in.
use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;

use super::grid::{SparseGrid, BRICK_DIM, BRICK_VOXELS, CONSTANT_BIT};

/// Edge of one bounds cell (a brick, a leaf node) in index units: every walk over the cells
/// (the DDA, the adaptive hierarchy, culling, emission bounds) and `dda.wgsl` use it.
pub const CELL_WIDTH: f32 = BRICK_DIM as f32;

/// Bounds of one cell, laid out for a GPU storage buffer (two `f32`, 8 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct CellBounds {
    /// Lower bound of every reconstructed value in or near the cell.
    pub min: f32,
    /// Upper bound of every reconstructed value in or near the cell.
    pub max: f32,
}
const _: () = assert!(std::mem::size_of::<CellBounds>() == 8);

impl CellBounds {
    /// The empty interval, identity of [`union`](Self::union).
    pub const EMPTY: CellBounds = CellBounds {
        min: f32::INFINITY,
        max: f32::NEG_INFINITY,
    };

    pub fn point(v: f32) -> Self {
        Self { min: v, max: v }
    }

    #[inline]
    pub fn union(self, o: CellBounds) -> CellBounds {
        CellBounds {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    pub fn contains(self, o: CellBounds) -> bool {
        o.min >= self.min && o.max <= self.max
    }
}

/// Bounds for every cell of a [`SparseGrid`], on the same dense index (`dims`,
/// `cell_origin`, x fastest).
#[derive(Clone, Debug)]
pub struct LeafBounds {
    pub cells: Vec<CellBounds>,
    pub dims: [u32; 3],
    pub cell_origin: [i32; 3],
    /// Bounds over the whole cell box (the background for a grid with no cells).
    pub global: CellBounds,
    /// Per-voxel bounds of every brick voxel relative to its cell's maximum, one byte each
    /// (`volume::voxel_bounds`): what culling thins by inside a cell. Empty where not built
    /// (bounds made by hand). Shared: bounds derived from a grid's (an emitting medium's walk
    /// bounds) keep its table and raise it through [`Self::voxel_floor`] instead of copying
    /// a quarter of the grid's brick memory.
    pub voxel_q: std::sync::Arc<[u8]>,
    /// Per cell, the least `q` any of its voxels reads (`max(q, floor)`): where derived bounds
    /// raise a cell's voxels (`render::emission_bounds::walk_bounds`). Empty: none.
    pub voxel_floor: Vec<u8>,
    /// The walk box: the smallest box of cells, `[lo, hi)` relative to `cell_origin`, holding
    /// every cell whose bounds are not exactly `[0, 0]` (empty, `lo == hi`, when there is
    /// none). Outside it every reconstructed value is 0, so the walks clip rays to it
    /// ([`Self::walk_box`]): a grid's box carries a ring of zero cells (the conversion pads
    /// one cell on every side for the trilinear apron, and files keep zero-valued leaves),
    /// which every walk crossed for nothing (the example grids' walk boxes are 43-70 % of
    /// their cell boxes). Kept by [`Self::build`] and [`Self::from_cells`]; code that changes
    /// `cells` afterwards calls [`Self::update_active`], and [`Self::validate`] checks it.
    pub active: [[u32; 3]; 2],
}

/// Entries of [`LeafBounds::gpu_walk_box`] in the GPU's bounds buffer.
pub const GPU_WALK_BOX_ENTRIES: usize = 3;

/// The walk box of `cells` over `dims` ([`LeafBounds::active`]).
pub fn active_cells(cells: &[CellBounds], dims: [u32; 3]) -> [[u32; 3]; 2] {
    let (mut lo, mut hi) = (dims, [0u32; 3]);
    let [nx, ny, _] = dims.map(|d| d as usize);
    for (index, c) in cells.iter().enumerate() {
        // NaN bounds count as non-zero: only exact zeros are clipped.
        if c.min == 0.0 && c.max == 0.0 {
            continue;
        }
        let at = [index % nx, index / nx % ny, index / (nx * ny)].map(|x| x as u32);
        for a in 0..3 {
            lo[a] = lo[a].min(at[a]);
            hi[a] = hi[a].max(at[a] + 1);
        }
    }
    if (0..3).any(|a| lo[a] >= hi[a]) {
        return [[0; 3]; 2];
    }
    [lo, hi]
}

/// How tight the per-cell bounds are compared with one global bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundsStats {
    pub global_min: f32,
    pub global_max: f32,
    /// Mean cell majorant over the global majorant: the expected fraction of null collisions
    /// the per-cell grid leaves compared with a single global bound (1 = no gain).
    pub mean_max_over_global: f64,
    /// Fraction of cells whose majorant is 0, which tracking crosses without sampling.
    pub empty_fraction: f64,
}

/// Local voxel range of neighbour offset `d` (-1, 0, +1) that the apron reads: the last voxel
/// below, the whole cell, or the first two voxels above.
fn apron_range(d: i64) -> std::ops::RangeInclusive<usize> {
    match d {
        -1 => 7..=7,
        0 => 0..=7,
        _ => 0..=1,
    }
}

impl LeafBounds {
    /// Bounds made by hand from their `cells` (x fastest over `dims`, from `cell_origin`):
    /// the global bounds are their union, and there is no per-voxel table.
    pub fn from_cells(cells: Vec<CellBounds>, dims: [u32; 3], cell_origin: [i32; 3]) -> Self {
        let global = cells
            .iter()
            .copied()
            .fold(CellBounds::EMPTY, CellBounds::union);
        LeafBounds {
            voxel_q: Default::default(),
            voxel_floor: Vec::new(),
            active: active_cells(&cells, dims),
            cells,
            dims,
            cell_origin,
            global,
        }
    }

    /// The walk box as the GPU's bounds buffer holds it, right after the global bound
    /// ([`GPU_WALK_BOX_ENTRIES`] entries, `shaders/common/dda.wgsl`'s `dda_new_in`): per axis
    /// the index-space minimum and maximum, exact `f32` integers.
    pub fn gpu_walk_box(&self) -> [CellBounds; GPU_WALK_BOX_ENTRIES] {
        let (lo, hi) = self.walk_box();
        [0, 1, 2].map(|a| CellBounds {
            min: lo[a],
            max: hi[a],
        })
    }

    /// Recomputes [`Self::active`] after `cells` changed.
    pub fn update_active(&mut self) {
        self.active = active_cells(&self.cells, self.dims);
    }

    /// The index-space minimum corner of the cell box (exact: a multiple of 8 well below 2^24).
    #[inline]
    pub fn cell_lo(&self) -> crate::math::Vec3 {
        crate::math::Vec3::from_array(self.cell_origin.map(|c| c as f32 * 8.0))
    }

    /// [`Self::active`] in index space: the box every walk clips its rays to (minimum and
    /// maximum corner; exact, multiples of 8 well below 2^24).
    #[inline]
    pub fn walk_box(&self) -> (crate::math::Vec3, crate::math::Vec3) {
        let [lo, hi] = self.active;
        let at = |c: [u32; 3]| {
            crate::math::Vec3::from_array(
                [0, 1, 2].map(|a| (self.cell_origin[a] as i64 + c[a] as i64) as f32 * 8.0),
            )
        };
        (at(lo), at(hi))
    }

    /// Computes the bounds of every cell, in parallel over cells.
    pub fn build(grid: &SparseGrid) -> LeafBounds {
        // Each cell's own range first; the apron pass then only scans a neighbour's voxels
        // when its whole range is not already inside the running bound.
        let own: Vec<CellBounds> = grid
            .cells
            .par_iter()
            .map(|&entry| {
                if entry & CONSTANT_BIT != 0 {
                    CellBounds::point(grid.constants[(entry & !CONSTANT_BIT) as usize])
                } else {
                    let base = entry as usize * BRICK_VOXELS;
                    grid.bricks[base..base + BRICK_VOXELS]
                        .iter()
                        .fold(CellBounds::EMPTY, |b, &v| b.union(CellBounds::point(v)))
                }
            })
            .collect();

        let [nx, ny, _] = grid.dims.map(|d| d as usize);
        let cells: Vec<CellBounds> = (0..grid.cells.len())
            .into_par_iter()
            .map(|index| {
                let c = [index % nx, index / nx % ny, index / (nx * ny)].map(|x| x as i64);
                apron_bounds(grid, &own, c)
            })
            .collect();

        let global = if cells.is_empty() {
            CellBounds::point(grid.background)
        } else {
            cells
                .par_iter()
                .copied()
                .reduce(|| CellBounds::EMPTY, CellBounds::union)
        };
        let voxel_q = build_voxel_q(grid, &cells).into();
        LeafBounds {
            voxel_q,
            voxel_floor: Vec::new(),
            active: active_cells(&cells, grid.dims),
            cells,
            dims: grid.dims,
            cell_origin: grid.cell_origin,
            global,
        }
    }

    /// Bounds of the cell at `(x, y, z)` relative to `cell_origin`.
    #[inline]
    pub fn get(&self, x: u32, y: u32, z: u32) -> CellBounds {
        self.cells
            [x as usize + self.dims[0] as usize * (y as usize + self.dims[1] as usize * z as usize)]
    }

    /// The bounds as a flat `f32` array of `(min, max)` pairs, ready for upload.
    pub fn as_f32_slice(&self) -> &[f32] {
        bytemuck::cast_slice(&self.cells)
    }

    pub fn stats(&self) -> BoundsStats {
        let n = self.cells.len().max(1) as f64;
        let sum_max: f64 = self.cells.iter().map(|b| b.max as f64).sum();
        let empty = self.cells.iter().filter(|b| b.max == 0.0).count();
        BoundsStats {
            global_min: self.global.min,
            global_max: self.global.max,
            mean_max_over_global: if self.global.max > 0.0 {
                sum_max / n / self.global.max as f64
            } else {
                0.0
            },
            empty_fraction: empty as f64 / n,
        }
    }

    /// Recomputes every cell's bounds the slow obvious way (a voxel lookup for each of the
    /// 11^3 voxels of its block) and checks they match exactly, as well as the global bound.
    /// Grids with more than `max_cells` cells are checked on an evenly strided sample.
    pub fn validate(&self, grid: &SparseGrid, max_cells: usize) -> Result<(), String> {
        if self.dims != grid.dims
            || self.cell_origin != grid.cell_origin
            || self.cells.len() != grid.cells.len()
        {
            return Err(format!(
                "bounds index {:?} at {:?} does not match the grid's {:?} at {:?}",
                self.dims, self.cell_origin, grid.dims, grid.cell_origin
            ));
        }
        let expected_global = if self.cells.is_empty() {
            CellBounds::point(grid.background)
        } else {
            self.cells
                .iter()
                .copied()
                .fold(CellBounds::EMPTY, CellBounds::union)
        };
        if expected_global != self.global {
            return Err(format!(
                "global bound {:?} differs from the union of cells {:?}",
                self.global, expected_global
            ));
        }
        if self.active != active_cells(&self.cells, self.dims) {
            return Err(format!(
                "walk box {:?} is not the box of the non-zero cells {:?}",
                self.active,
                active_cells(&self.cells, self.dims)
            ));
        }
        let stride = self.cells.len().div_ceil(max_cells.max(1)).max(1);
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        (0..self.cells.len())
            .into_par_iter()
            .step_by(stride)
            .try_for_each(|index| {
                let c = [index % nx, index / nx % ny, index / (nx * ny)];
                let v0 = [0, 1, 2].map(|a| (self.cell_origin[a] as i64 + c[a] as i64) * 8);
                let mut slow = CellBounds::EMPTY;
                for k in v0[2] - 1..=v0[2] + 9 {
                    for j in v0[1] - 1..=v0[1] + 9 {
                        for i in v0[0] - 1..=v0[0] + 9 {
                            slow = slow
                                .union(CellBounds::point(grid.voxel(i as i32, j as i32, k as i32)));
                        }
                    }
                }
                if slow == self.cells[index] {
                    Ok(())
                } else {
                    Err(format!(
                    "cell {c:?} (voxels {v0:?} + [-1, 9]): stored bounds {:?}, recomputed {slow:?}",
                    self.cells[index]
                ))
                }
            })
    }
}

/// Bounds of cell `c` (relative to the cell origin) over its block with apron.
fn apron_bounds(grid: &SparseGrid, own: &[CellBounds], c: [i64; 3]) -> CellBounds {
    let dims = grid.dims.map(|d| d as i64);
    let mut b = own[grid.cell_index(c[0] as u32, c[1] as u32, c[2] as u32)];
    for dz in -1..=1i64 {
        for dy in -1..=1i64 {
            for dx in -1..=1i64 {
                let n = [c[0] + dx, c[1] + dy, c[2] + dz];
                if (0..3).any(|a| n[a] < 0 || n[a] >= dims[a]) {
                    // Outside the cell box every lookup is the background.
                    b = b.union(CellBounds::point(grid.background));
                    continue;
                }
                let index = grid.cell_index(n[0] as u32, n[1] as u32, n[2] as u32);
                let whole = own[index];
                if b.contains(whole) {
                    continue;
                }
                let entry = grid.cells[index];
                if entry & CONSTANT_BIT != 0 {
                    b = b.union(whole);
                    continue;
                }
                let brick = &grid.bricks[entry as usize * BRICK_VOXELS..][..BRICK_VOXELS];
                for z in apron_range(dz) {
                    for y in apron_range(dy) {
                        for x in apron_range(dx) {
                            b = b.union(CellBounds::point(brick[x + 8 * y + 64 * z]));
                        }
                    }
                }
            }
        }
    }
    b
}

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
