//! [`SparseGrid`]: Brume's own flat layout of a float grid, and its lookups in index space.
//!
//! The layout is meant to be uploaded as-is to GPU storage buffers, so it is three flat arrays
//! of plain `u32`/`f32` and no pointers:
//!
//! * `cells`: a dense index at leaf resolution (one entry per 8^3 voxel block, x fastest) over
//!   the grid's cell box. An entry is either the index of a brick, or, with [`CONSTANT_BIT`]
//!   set, the index of a constant.
//! * `bricks`: 512 floats per brick, Brume order `x + 8 y + 64 z` (x fastest, unlike OpenVDB's
//!   leaf order).
//! * `constants`: the distinct values of constant cells (tiles, uniform leaves, empty space);
//!   entry 0 is always the background.
//!
//! Lookups follow OpenVDB's conventions exactly (voxel `(i, j, k)` is centred at index point
//! `(i, j, k)`; `PointSampler` rounds, `BoxSampler` interpolates z, then y, then x), so values
//! agree with OpenVDB's samplers bit for bit.
use crate::math::{floor_i64, Aabb, DAffine3, DVec3, Vec3};

/// Set in a cell entry whose remaining bits index `constants` rather than `bricks`.
pub const CONSTANT_BIT: u32 = 1 << 31;
/// Voxels per brick edge (equal to OpenVDB's leaf edge, so a leaf maps to one brick).
pub const BRICK_DIM: i64 = 8;
/// Floats per brick.
pub const BRICK_VOXELS: usize = 512;
/// Default limit on the dense cell index: 2^26 cells, i.e. 256 MiB of `u32` entries, which
/// covers a 4096^3-voxel box.
pub const DEFAULT_MAX_CELLS: u64 = 1 << 26;

/// A float grid in Brume's sparse brick layout. Build it with
/// [`SparseGrid::from_vdb`](Self::from_vdb) or [`SparseGrid::from_dense`](Self::from_dense).
#[derive(Clone, Debug)]
pub struct SparseGrid {
    /// Dense cell index, `cells[x + nx * (y + ny * z)]`; see the module docs for the encoding.
    pub cells: Vec<u32>,
    /// Cell counts `[nx, ny, nz]` of the cell box (all zero for a grid with no data).
    pub dims: [u32; 3],
    /// Cell coordinate (voxel coordinate divided by 8, floored) of `cells[0]`.
    pub cell_origin: [i32; 3],
    /// 512 values per brick in Brume order `x + 8 y + 64 z`.
    pub bricks: Vec<f32>,
    /// Distinct constant-cell values; `constants[0]` is the background.
    pub constants: Vec<f32>,
    /// Value everywhere outside the cell box.
    pub background: f32,
    /// Maps index space (voxel centres at integer points) to world space.
    pub world_from_index: DAffine3,
    /// Inverse of `world_from_index`.
    pub index_from_world: DAffine3,
    /// Voxel edge lengths along the index axes, in world units.
    pub voxel_size: DVec3,
    /// The grid's name in its file (empty for synthetic grids).
    pub name: String,
}

/// What a grid costs in memory and how much of it is constant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridStats {
    pub cell_count: u64,
    pub brick_count: u64,
    pub constant_count: u64,
    pub cell_bytes: u64,
    pub brick_bytes: u64,
    pub constant_bytes: u64,
    /// Fraction of cells that are constant (tiles, uniform leaves, empty space).
    pub constant_fraction: f64,
    /// Fraction of cells equal to the background constant.
    pub empty_fraction: f64,
}

impl GridStats {
    pub fn total_bytes(&self) -> u64 {
        self.cell_bytes + self.brick_bytes + self.constant_bytes
    }
}

/// One of OpenVDB's linear blends: the difference is scaled in double precision and rounded
/// back to `f32` before the add, exactly as `BoxSampler::trilinearInterpolation` does for a
/// float grid, so Brume and OpenVDB agree bit for bit.
#[inline(always)]
fn lerp_vdb(a: f32, b: f32, w: f64) -> f32 {
    a + (((b - a) as f64) * w) as f32
}

/// Trilinear blend of `v[i][j][k]` (value at `i0 + (i, j, k)`) in OpenVDB's order: z first,
/// then y, then x.
#[inline(always)]
fn trilinear_vdb(v: &[[[f32; 2]; 2]; 2], f: DVec3) -> f32 {
    let a = lerp_vdb(
        lerp_vdb(v[0][0][0], v[0][0][1], f.z),
        lerp_vdb(v[0][1][0], v[0][1][1], f.z),
        f.y,
    );
    let b = lerp_vdb(
        lerp_vdb(v[1][0][0], v[1][0][1], f.z),
        lerp_vdb(v[1][1][0], v[1][1][1], f.z),
        f.y,
    );
    lerp_vdb(a, b, f.x)
}

impl SparseGrid {
    /// Total number of cells in the dense index.
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    pub fn brick_count(&self) -> usize {
        self.bricks.len() / BRICK_VOXELS
    }

    /// Linear index of cell `(x, y, z)` relative to `cell_origin`.
    #[inline]
    pub fn cell_index(&self, x: u32, y: u32, z: u32) -> usize {
        x as usize + self.dims[0] as usize * (y as usize + self.dims[1] as usize * z as usize)
    }

    /// The index-space box of the cell grid, `[8 cell_origin, 8 (cell_origin + dims)]`; empty
    /// for a grid with no data. Values are `background` outside it.
    pub fn index_bounds(&self) -> Aabb {
        if self.cells.is_empty() {
            return Aabb::EMPTY;
        }
        let (lo, hi) = self.index_box_i64();
        Aabb::new(
            Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32),
            Vec3::new(hi[0] as f32, hi[1] as f32, hi[2] as f32),
        )
    }

    /// World-space box enclosing the support: the eight corners of [`index_bounds`]
    /// (already padded by one cell) mapped to world space.
    ///
    /// [`index_bounds`]: Self::index_bounds
    pub fn world_bounds(&self) -> Aabb {
        if self.cells.is_empty() {
            return Aabb::EMPTY;
        }
        let (lo, hi) = self.index_box_i64();
        let mut b = Aabb::EMPTY;
        for corner in 0..8 {
            let pick = |axis: usize| if corner >> axis & 1 == 0 { lo[axis] } else { hi[axis] } as f64;
            let w = self
                .world_from_index
                .transform_point3(DVec3::new(pick(0), pick(1), pick(2)));
            b = b.union_point(w.as_vec3());
        }
        b
    }

    /// Widens the cell box to `dims` cells from `cell_origin`, which must contain the current
    /// box: the new cells hold the background (constant entry 0), so every value, and every
    /// lookup, is unchanged. Used where a walk must reach past the grid's own data (an
    /// emitting medium whose flame reaches past its smoke, `scene::media`).
    pub fn widen_to(&mut self, cell_origin: [i32; 3], dims: [u32; 3]) {
        // A grid with no cells has no box to keep.
        let old_dims = if self.cells.is_empty() {
            [0; 3]
        } else {
            self.dims
        };
        let offset: [i64; 3] = std::array::from_fn(|a| {
            if self.cells.is_empty() {
                0
            } else {
                self.cell_origin[a] as i64 - cell_origin[a] as i64
            }
        });
        assert!(
            (0..3).all(|a| offset[a] >= 0 && offset[a] + old_dims[a] as i64 <= dims[a] as i64),
            "widen_to: the new cell box must contain the old one"
        );
        let [nx, ny, nz] = dims.map(|d| d as usize);
        let mut cells = vec![CONSTANT_BIT; nx * ny * nz];
        for z in 0..old_dims[2] as usize {
            for y in 0..old_dims[1] as usize {
                let src = old_dims[0] as usize * (y + old_dims[1] as usize * z);
                let dst = offset[0] as usize
                    + nx * (y + offset[1] as usize + ny * (z + offset[2] as usize));
                cells[dst..dst + old_dims[0] as usize]
                    .copy_from_slice(&self.cells[src..src + old_dims[0] as usize]);
            }
        }
        if self.constants.is_empty() {
            self.constants.push(self.background);
        }
        self.cells = cells;
        self.dims = dims;
        self.cell_origin = cell_origin;
    }

    /// Voxel-coordinate box `[lo, hi)` of the cell grid.
    fn index_box_i64(&self) -> ([i64; 3], [i64; 3]) {
        let lo = self.cell_origin.map(|c| c as i64 * BRICK_DIM);
        let hi = [0, 1, 2].map(|a| lo[a] + self.dims[a] as i64 * BRICK_DIM);
        (lo, hi)
    }

    /// Cell entry of the cell containing voxel `(i, j, k)`, or `None` outside the cell box.
    #[inline]
    fn entry_at(&self, i: i64, j: i64, k: i64) -> Option<u32> {
        // `>> 3` floors negative coordinates, matching the floored cell_origin.
        let cx = (i >> 3) - self.cell_origin[0] as i64;
        let cy = (j >> 3) - self.cell_origin[1] as i64;
        let cz = (k >> 3) - self.cell_origin[2] as i64;
        // One unsigned compare per axis also rejects negative coordinates.
        if (cx as u64) < self.dims[0] as u64
            && (cy as u64) < self.dims[1] as u64
            && (cz as u64) < self.dims[2] as u64
        {
            Some(self.cells[self.cell_index(cx as u32, cy as u32, cz as u32)])
        } else {
            None
        }
    }

    /// Value of a cell entry at local voxel offset `local` (Brume order) inside its cell.
    #[inline]
    fn entry_value(&self, entry: u32, local: usize) -> f32 {
        if entry & CONSTANT_BIT != 0 {
            self.constants[(entry & !CONSTANT_BIT) as usize]
        } else {
            self.bricks[entry as usize * BRICK_VOXELS + local]
        }
    }

    /// The stored value of voxel `(i, j, k)`: its brick value, its constant, or the background
    /// outside the cell box.
    #[inline]
    pub fn voxel(&self, i: i32, j: i32, k: i32) -> f32 {
        self.voxel_i64(i as i64, j as i64, k as i64)
    }

    #[inline]
    fn voxel_i64(&self, i: i64, j: i64, k: i64) -> f32 {
        match self.entry_at(i, j, k) {
            Some(entry) => {
                let local = (i & 7) as usize + 8 * (j & 7) as usize + 64 * (k & 7) as usize;
                self.entry_value(entry, local)
            }
            None => self.background,
        }
    }

    /// `true` when index point `p` is far enough outside the cell box that every voxel a
    /// sampler could read is background. Also `true` for NaN coordinates (every comparison
    /// fails), so lookups at NaN return the background instead of indexing with garbage.
    #[inline]
    fn all_background_near(&self, p: DVec3) -> bool {
        let (lo, hi) = self.index_box_i64();
        // Trilinear reads floor(p) and floor(p) + 1; nearest reads round(p). Both lie
        // in [lo, hi) only if p is in [lo - 1, hi).
        !(p.x >= (lo[0] - 1) as f64
            && p.x < hi[0] as f64
            && p.y >= (lo[1] - 1) as f64
            && p.y < hi[1] as f64
            && p.z >= (lo[2] - 1) as f64
            && p.z < hi[2] as f64)
    }

    /// Nearest-voxel lookup at index point `p`, as OpenVDB's `PointSampler`: the voxel
    /// `round(p)` per axis, halves away from zero. Outside the cell box, and at NaN coordinates, the
    /// background.
    #[inline]
    pub fn sample_nearest(&self, p: DVec3) -> f32 {
        if self.all_background_near(p) {
            return self.background;
        }
        // `f64::round` rounds halves away from zero, as the C `::round` in OpenVDB's
        // `PointSampler` (not `floor(p + 0.5)`: they differ at negative halves).
        let r = p.round();
        self.voxel_i64(r.x as i64, r.y as i64, r.z as i64)
    }

    /// Trilinear reconstruction at index point `p`, as OpenVDB's `BoxSampler`: the eight
    /// voxels `floor(p) + {0,1}^3`, blended along z, then y, then x. Outside the cell box,
    /// and at NaN coordinates, the background.
    #[inline]
    pub fn sample_trilinear(&self, p: DVec3) -> f32 {
        if self.all_background_near(p) {
            return self.background;
        }
        let (i, j, k) = (floor_i64(p.x), floor_i64(p.y), floor_i64(p.z));
        // Exact: p and floor(p) are close doubles (Sterbenz), as in OpenVDB's `inCoord - inIdx`.
        let f = p - DVec3::new(i as f64, j as f64, k as f64);
        // Fast path: all eight voxels in one cell (local coordinate 7 on no axis), which holds
        // for (7/8)^3 = 67 % of uniformly spread points and more in constant regions.
        if (i & 7) != 7 && (j & 7) != 7 && (k & 7) != 7 {
            if let Some(entry) = self.entry_at(i, j, k) {
                if entry & CONSTANT_BIT != 0 {
                    // A blend of equal values is that value exactly (b - a = 0).
                    return self.constants[(entry & !CONSTANT_BIT) as usize];
                }
                let base = entry as usize * BRICK_VOXELS;
                // One bounds check for the whole brick; the masked offsets below are then
                // provably inside the array and compile without checks.
                let brick: &[f32; BRICK_VOXELS] =
                    self.bricks[base..base + BRICK_VOXELS].try_into().unwrap();
                let o = (i & 7) as usize + 8 * (j & 7) as usize + 64 * (k & 7) as usize;
                let at = |dx: usize, dy: usize, dz: usize| {
                    brick[(o + dx + 8 * dy + 64 * dz) & (BRICK_VOXELS - 1)]
                };
                let v = [
                    [[at(0, 0, 0), at(0, 0, 1)], [at(0, 1, 0), at(0, 1, 1)]],
                    [[at(1, 0, 0), at(1, 0, 1)], [at(1, 1, 0), at(1, 1, 1)]],
                ];
                return trilinear_vdb(&v, f);
            }
        }
        let at = |dx: i64, dy: i64, dz: i64| self.voxel_i64(i + dx, j + dy, k + dz);
        let v = [
            [[at(0, 0, 0), at(0, 0, 1)], [at(0, 1, 0), at(0, 1, 1)]],
            [[at(1, 0, 0), at(1, 0, 1)], [at(1, 1, 0), at(1, 1, 1)]],
        ];
        trilinear_vdb(&v, f)
    }

    /// The trilinear blend of `f` of the eight voxels around index point `p` (the voxels and
    /// weights [`sample_trilinear`](Self::sample_trilinear) blends): what a renderer that
    /// reads one voxel at random with the trilinear weights, as Cycles does, averages to.
    /// Outside the cell box, and at NaN coordinates, `f` of the background.
    pub fn sample_trilinear_of(&self, p: DVec3, f: impl Fn(f32) -> glam::Vec3) -> glam::Vec3 {
        if self.all_background_near(p) {
            return f(self.background);
        }
        let (i, j, k) = (floor_i64(p.x), floor_i64(p.y), floor_i64(p.z));
        let w = p - DVec3::new(i as f64, j as f64, k as f64);
        let mut sum = glam::DVec3::ZERO;
        for (dx, dy, dz) in (0..8).map(|c| (c & 1, (c >> 1) & 1, c >> 2)) {
            let weight = |d: i64, f: f64| if d == 1 { f } else { 1.0 - f };
            let wt = weight(dx, w.x) * weight(dy, w.y) * weight(dz, w.z);
            if wt > 0.0 {
                sum += f(self.voxel_i64(i + dx, j + dy, k + dz)).as_dvec3() * wt;
            }
        }
        sum.as_vec3()
    }

    /// [`sample_trilinear`](Self::sample_trilinear) over a batch (for benchmarks and bulk
    /// comparisons). `out` must be as long as `points`.
    pub fn sample_trilinear_batch(&self, points: &[[f64; 3]], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "one output per point");
        for (p, o) in points.iter().zip(out.iter_mut()) {
            *o = self.sample_trilinear(DVec3::from_array(*p));
        }
    }

    /// [`sample_nearest`](Self::sample_nearest) over a batch. `out` must be as long as
    /// `points`.
    pub fn sample_nearest_batch(&self, points: &[[f64; 3]], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "one output per point");
        for (p, o) in points.iter().zip(out.iter_mut()) {
            *o = self.sample_nearest(DVec3::from_array(*p));
        }
    }

    /// Memory use and constant-cell fractions.
    pub fn stats(&self) -> GridStats {
        let n = self.cells.len().max(1) as f64;
        let constant = self
            .cells
            .iter()
            .filter(|&&e| e & CONSTANT_BIT != 0)
            .count();
        let empty = self.cells.iter().filter(|&&e| e == CONSTANT_BIT).count();
        GridStats {
            cell_count: self.cells.len() as u64,
            brick_count: self.brick_count() as u64,
            constant_count: self.constants.len() as u64,
            cell_bytes: (self.cells.len() * 4) as u64,
            brick_bytes: (self.bricks.len() * 4) as u64,
            constant_bytes: (self.constants.len() * 4) as u64,
            constant_fraction: constant as f64 / n,
            empty_fraction: empty as f64 / n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blend of `f` of the voxels is `sample_trilinear` for a linear `f`, and for a
    /// nonlinear one the weights' blend of the voxels' values, not `f` of the blend.
    #[test]
    fn the_voxels_blend_of_a_function_takes_the_trilinear_weights() {
        let dims = [5usize, 4, 6];
        let values: Vec<f32> = (0..dims.iter().product::<usize>())
            .map(|i| ((i * 7919) % 23) as f32 * 0.25)
            .collect();
        let (grid, _) = SparseGrid::from_dense(dims, [-2, 1, 3], &values, 0.0).unwrap();
        let linear = |v: f32| glam::Vec3::new(v, 2.0 * v, -v);
        for p in [
            DVec3::new(-1.3, 2.6, 4.1),
            DVec3::new(0.5, 1.5, 5.5),
            DVec3::new(1.99, 3.01, 7.5),
            DVec3::new(40.0, 0.0, 0.0),
        ] {
            let (blend, lin) = (
                grid.sample_trilinear_of(p, linear),
                grid.sample_trilinear(p),
            );
            assert!((blend - linear(lin)).abs().max_element() < 1e-5 * (1.0 + lin.abs()));
        }
        // Halfway between two voxels along x, on their y and z: the mean of the fourth powers.
        let p = DVec3::new(0.5, 2.0, 4.0);
        let (a, b) = (grid.voxel(0, 2, 4), grid.voxel(1, 2, 4));
        let quartic = |v: f32| glam::Vec3::splat(v.powi(4));
        let expected = 0.5 * (a.powi(4) + b.powi(4));
        assert!(
            (grid.sample_trilinear_of(p, quartic).x - expected).abs() < 1e-4 * expected.max(1.0)
        );
    }

    #[test]
    fn widening_the_cell_box_changes_no_value() {
        let dims = [11usize, 9, 13];
        let values: Vec<f32> = (0..dims.iter().product::<usize>())
            .map(|i| ((i * 7919) % 23) as f32 * 0.25)
            .collect();
        let (grid, _) = SparseGrid::from_dense(dims, [-5, 3, 17], &values, 0.0).unwrap();
        let mut wide = grid.clone();
        let origin = [0, 1, 2].map(|a| grid.cell_origin[a] - 1 - a as i32);
        let grown = [0, 1, 2].map(|a| grid.dims[a] + 3 + a as u32);
        wide.widen_to(origin, grown);
        assert_eq!((wide.cell_origin, wide.dims), (origin, grown));
        let (w, g) = (wide.index_bounds(), grid.index_bounds());
        assert!(w.min.cmple(g.min).all() && w.max.cmpge(g.max).all());
        // Every voxel of the widened box, the old one's included, and trilinear points
        // across its faces.
        for k in origin[2] * 8..(origin[2] + grown[2] as i32) * 8 {
            for j in origin[1] * 8..(origin[1] + grown[1] as i32) * 8 {
                for i in origin[0] * 8..(origin[0] + grown[0] as i32) * 8 {
                    assert_eq!(
                        wide.voxel(i, j, k),
                        grid.voxel(i, j, k),
                        "voxel {i} {j} {k}"
                    );
                    let p = DVec3::new(i as f64 + 0.37, j as f64 + 0.61, k as f64 + 0.19);
                    assert_eq!(wide.sample_trilinear(p), grid.sample_trilinear(p));
                }
            }
        }
    }

    #[test]
    fn lerp_vdb_hits_its_ends() {
        assert_eq!(lerp_vdb(0.3, 0.7, 0.0), 0.3);
        assert_eq!(lerp_vdb(0.3, 0.7, 1.0), 0.7);
        assert_eq!(lerp_vdb(2.5, 2.5, 0.123), 2.5);
    }
}
