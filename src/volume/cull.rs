//! Culling of a coarse walk's tentative collisions by the per-leaf bounds: what lets
//! `--majorant culled` (and an adaptive hierarchy built as
//! [`AdaptiveShape::Culled`](super::AdaptiveShape)) walk the grid as ONE segment with the
//! global bound and still look up the density only about as often as per-leaf bounds do.
//!
//! The free-flight loop (`tracking::sample_free_flight`) samples tentative collisions at the
//! global rate `G` and keeps each one with probability `r = max(cell at p) / G`, where `cell
//! at p` is the leaf cell containing the collision's index-space point `p`
//! ([`LeafCulling::ratio`]). The kept collisions form a Poisson process of rate `max(cell at
//! p)`, the rate per-leaf bounds would sample; a culled one is a null collision decided
//! without a lookup. The cell is found from the very point the lookup would read (not from a
//! walk), so the bound holds there by construction: [`LeafBounds`] bound every reconstructed
//! value within a voxel of the cell, and a point rounded a hair outside the cell box is
//! clamped into its nearest cell.
//!
//! Sound only where the estimators' majorant is the bound itself, scaled: the segment's
//! control (its minorant, under local modes) must be 0, so a residual majorant
//! `b max(bound - c, c - min)` is `b bound` over the segment and over the cell alike.
//! [`LeafCulling::new`] therefore requires the global minimum to be exactly 0 (every cell's
//! minimum then lies in `[0, max]`).
use super::bounds::{CellBounds, LeafBounds};
use super::dda::cell_of;
use crate::math::{floor_i32, Vec3};
use glam::Vec4;

/// The per-leaf bounds of one grid, as the culling of a walk over its global bound reads them.
#[derive(Clone, Copy, Debug)]
pub struct LeafCulling<'a> {
    bounds: &'a LeafBounds,
    /// Index-space minimum corner of the cell box (and 0 in the padding lane).
    lo: Vec4,
    /// The last cell's coordinates, `dims - 1`, as floats (and 0 in the padding lane).
    last: Vec4,
    /// The global bound the walk samples with (unscaled): `bounds.global.max`.
    global_max: f32,
}

impl<'a> LeafCulling<'a> {
    /// The culling of `bounds`' global walk, or `None` where it would not be sound or could
    /// not help: a global minimum other than 0 (the segment's control would not vanish), a
    /// global maximum that is not positive, or no cells.
    pub fn new(bounds: &'a LeafBounds) -> Option<Self> {
        Self::accepts(bounds).then(|| Self::accepted(bounds))
    }

    /// Whether [`Self::new`] gives a culling for `bounds` (the checks on its docs).
    pub fn accepts(bounds: &LeafBounds) -> bool {
        !bounds.cells.is_empty() && Self::is_sound(bounds.global)
    }

    /// [`Self::new`] for bounds it accepts, unchecked: the walk's set-up, which runs for
    /// every flight, skips the checks whose answer the caller keeps (`VdbMedium`).
    #[inline(always)]
    pub fn accepted(bounds: &'a LeafBounds) -> Self {
        debug_assert!(Self::accepts(bounds));
        let [nx, ny, nz] = bounds.dims.map(|n| n as f32 - 1.0);
        LeafCulling {
            bounds,
            lo: bounds.cell_lo().extend(0.0),
            last: Vec4::new(nx, ny, nz, 0.0),
            global_max: bounds.global.max,
        }
    }

    /// Whether culling a walk over the global bounds `g` is sound and can cull: `g.min` is
    /// exactly 0 and `g.max` positive and finite.
    pub fn is_sound(g: CellBounds) -> bool {
        g.min == 0.0 && g.max > 0.0 && g.max.is_finite()
    }

    /// `max(cell containing p) / global max`, in `[0, 1]`, for index-space point `p`: 1
    /// exactly where the cell holds the global maximum (no uniform is then drawn).
    #[inline(always)]
    pub fn ratio(&self, p: Vec3) -> f32 {
        let m = self.bound_at(p);
        if m >= self.global_max {
            1.0
        } else {
            m / self.global_max
        }
    }

    /// The per-leaf bound (unscaled maximum) of the cell containing index-space point `p`,
    /// clamped into the cell box.
    #[inline(always)]
    pub fn bound_at(&self, p: Vec3) -> f32 {
        // The DDA's entry cell search, four lanes at a time (NaN maps to cell 0).
        let c = cell_of(p.extend(0.0), self.lo, self.last).1;
        let [nx, ny, _] = self.bounds.dims.map(|n| n as usize);
        self.bounds.cells[c[0] as usize + nx * (c[1] as usize + ny * c[2] as usize)].max
    }
}

/// The second stage of culling: the per-voxel bounds of `LeafBounds::voxel_q`, applied to
/// the collisions a walk keeps after its first stage (the per-leaf DDA's segments, or the
/// culled global walk's cell test). At a tentative collision at index-space point `p` with
/// raw majorant `bound` (the segment's `sigma_maj` times the first stage's ratio, before the
/// estimator's scale `b`), the voxel `v = floor(p)` gives
///
/// ```text
/// fine = ((q(v) * (1/255)) * cell_max(v)) * scale     // >= sigma_t at p (voxel_bounds)
/// q(v) = max(voxel_q(v), voxel_floor(cell of v))        // the floor where bounds raise it
/// r    = fine >= bound ? 1 : fine / bound
/// ```
///
/// and the walk keeps the collision with probability `r` (thinning, as the first stage):
/// the kept ones form a Poisson process of rate `fine(p)`, so lookups fall towards the real
/// collisions at no extra step. Sound for any `bound` at least the density there (the ratio
/// is taken against the bound the collision was sampled with, never assumed), wherever the
/// estimator's control is 0 (the caller checks) and no value is negative (the global minimum
/// is 0, as for [`LeafCulling`]). A point whose voxel lies outside the grid's cells, or in a
/// constant cell, is not thinned (`r = 1`, no uniform).
#[derive(Clone, Copy, Debug)]
pub struct VoxelCulling<'a> {
    bounds: &'a LeafBounds,
    /// The grid's dense cell index (brick index, or `CONSTANT_BIT` and a constant's).
    entries: &'a [u32],
    /// `sigma_t` per unit of grid value.
    scale: f32,
}

impl<'a> VoxelCulling<'a> {
    /// The voxel culling of a grid whose cells are `entries` and bounds `bounds`, at
    /// extinction `scale` per unit value; `None` where it would not be sound or has nothing
    /// to read (no voxel table, or [`LeafCulling::is_sound`] fails).
    pub fn new(bounds: &'a LeafBounds, entries: &'a [u32], scale: f32) -> Option<Self> {
        Self::accepts(bounds, entries, scale).then(|| Self::accepted(bounds, entries, scale))
    }

    /// Whether [`Self::new`] gives a culling for these arguments (the checks on its docs).
    pub fn accepts(bounds: &LeafBounds, entries: &[u32], scale: f32) -> bool {
        let built = !bounds.voxel_q.is_empty() && entries.len() == bounds.cells.len();
        built && LeafCulling::is_sound(bounds.global) && scale > 0.0 && scale.is_finite()
    }

    /// [`Self::new`] for arguments it accepts, unchecked (as [`LeafCulling::accepted`]).
    #[inline(always)]
    pub fn accepted(bounds: &'a LeafBounds, entries: &'a [u32], scale: f32) -> Self {
        debug_assert!(Self::accepts(bounds, entries, scale));
        VoxelCulling {
            bounds,
            entries,
            scale,
        }
    }

    /// `r` in `[0, 1]` for the collision at index-space point `p` sampled with raw majorant
    /// `bound` (see the type's docs).
    #[inline(always)]
    pub fn ratio(&self, p: Vec3, bound: f32) -> f32 {
        match self.bound_at(p) {
            Some(fine) if fine < bound => fine / bound,
            _ => 1.0,
        }
    }

    /// The per-voxel bound of `sigma_t` at index-space point `p` (`fine` in the type's docs),
    /// or `None` where there is none to thin by: outside the cell box (NaN included) or in a
    /// constant cell.
    #[inline(always)]
    pub fn bound_at(&self, p: Vec3) -> Option<f32> {
        let dims = self.bounds.dims;
        let mut index = 0usize;
        let mut local = 0usize;
        let mut stride = 1usize;
        for a in 0..3 {
            if p[a].is_nan() {
                return None;
            }
            // The cell box's faces are integers, so `p` lies in it exactly when `floor(p)`
            // does, and the voxel's cell is its index shifted: one integer range test. `v`
            // saturates far outside the box, and `v >> 3` minus an origin within `i32 >> 3`
            // cannot overflow.
            let v = floor_i32(p[a]);
            let c = (v >> 3) - self.bounds.cell_origin[a];
            if c as u32 >= dims[a] {
                return None;
            }
            index += c as usize * stride;
            local += ((v & 7) as usize) << (3 * a);
            stride *= dims[a] as usize;
        }
        let entry = self.entries[index];
        if entry & super::grid::CONSTANT_BIT != 0 {
            return None;
        }
        let mut q = self.bounds.voxel_q[entry as usize * super::grid::BRICK_VOXELS + local];
        if let Some(&f) = self.bounds.voxel_floor.get(index) {
            q = q.max(f);
        }
        Some(((q as f32 * (1.0 / 255.0)) * self.bounds.cells[index].max) * self.scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::volume::bounds::CELL_WIDTH;

    /// The four-lane cell search is the scalar one it replaced (saturating cast, then integer
    /// clamp) on points inside, outside and on the faces of the cell box, and on NaN.
    #[test]
    fn cell_search_matches_the_scalar_clamp() {
        let dims = [5u32, 3, 7];
        let origin = [-3, 2, -1];
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let cells = (0..n)
            .map(|i| CellBounds {
                min: 0.0,
                max: 1.0 + i as f32,
            })
            .collect();
        let bounds = LeafBounds::from_cells(cells, dims, origin);
        let culling = LeafCulling::new(&bounds).unwrap();
        let lo = origin.map(|c| c as f32 * CELL_WIDTH);
        let scalar = |p: Vec3| {
            let mut index = 0usize;
            let mut stride = 1usize;
            for a in 0..3 {
                let c = (((p[a] - lo[a]) * (1.0 / CELL_WIDTH)) as i32).clamp(0, dims[a] as i32 - 1);
                index += c as usize * stride;
                stride *= dims[a] as usize;
            }
            bounds.cells[index].max
        };
        let mut rng = Rng::new(3, 0, 5);
        let special = [
            f32::NAN,
            0.0,
            -0.0,
            1e30,
            -1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for i in 0..100_000 {
            let mut p = Vec3::new(
                lo[0] + (rng.uniform_f32() * 1.4 - 0.2) * 40.0,
                lo[1] + (rng.uniform_f32() * 1.4 - 0.2) * 24.0,
                lo[2] + (rng.uniform_f32() * 1.4 - 0.2) * 56.0,
            );
            if i % 5 == 0 {
                // On a cell face.
                p.y = lo[1] + 8.0 * (rng.uniform_f32() * 4.0).floor();
            }
            if i % 13 == 0 {
                p.z = special[i / 13 % special.len()];
            }
            assert_eq!(culling.bound_at(p), scalar(p), "p {p}");
        }
    }
}
