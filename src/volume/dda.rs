//! The majorant DDA: walks a ray through the cell grid of [`LeafBounds`] and yields one
//! [`MajorantSegment`] per cell crossed.
//!
//! This is the 3D-DDA of Amanatides and Woo, "A Fast Voxel Traversal Algorithm for Ray
//! Tracing" (Eurographics 1987), as pbrt-v4's `DDAMajorantIterator` uses it, with two changes
//! for robustness:
//! * each plane crossing is computed afresh from the plane's position, `(plane - o) / d`,
//!   rather than by accumulating `1 / d` steps, so errors do not grow along long rays;
//! * segment ends are clamped to be non-decreasing and zero-length segments are skipped, so
//!   the segments tile the ray's overlap with the cell box exactly: the first `t_min` is the
//!   box entry, each `t_max` is bit-for-bit the next `t_min`, the last `t_max` is the box exit.
//!
//! Where rounding puts a sample point slightly outside the cell the walk assigns it to, the
//! one-voxel apron of [`LeafBounds`] still bounds it.
use super::bounds::{CellBounds, LeafBounds};
use super::segment::MajorantSegment;
use crate::math::{Aabb, Ray, Vec3};

/// Edge of one bounds cell in index units.
const CELL_WIDTH: f32 = 8.0;

/// Where a ray enters a box of `dims` cells of size `width` from `lo`, clipped to `[t0, t1]`:
/// the entry cell, the step direction per axis and the overlap. Shared by the per-leaf DDA and
/// the adaptive walk, so both start the same way bit for bit.
pub(crate) struct BoxEntry {
    pub cell: [i32; 3],
    /// -1, 0 or +1: the direction the cell index moves along each axis. 0 for `d == ±0.0`,
    /// so an axis-parallel ray never steps on that axis.
    pub step: [i32; 3],
    pub t_enter: f32,
    pub t_exit: f32,
}

/// [`BoxEntry`] of `ray`, or `None` when the overlap is empty (or the box is).
pub(crate) fn enter_box(
    lo: Vec3,
    width: Vec3,
    dims: [i32; 3],
    ray: &Ray,
    t0: f32,
    t1: f32,
) -> Option<BoxEntry> {
    if dims.iter().any(|&n| n <= 0) {
        return None;
    }
    let hi = lo + width * Vec3::from_array(dims.map(|n| n as f32));
    // The same slab test a renderer would use for the box, so the tiling is exact.
    let (t_enter, t_exit) = Aabb::new(lo, hi).intersect(ray, t0, t1)?;
    // Written positively so NaN parameters are rejected too; an empty overlap yields nothing.
    if !(t_enter < t_exit) {
        return None;
    }
    let p = ray.at(t_enter);
    let mut cell = [0; 3];
    let mut step = [0; 3];
    for a in 0..3 {
        // On an axis the ray does not move along, `t_enter` may be infinite and `t * 0`
        // NaN: the coordinate is simply the origin's.
        let x = if ray.d[a] == 0.0 { ray.o[a] } else { p[a] };
        let g = ((x - lo[a]) / width[a]).floor();
        // Rounding can put the entry point a hair outside the box: clamp into it.
        cell[a] = if g.is_nan() {
            0
        } else {
            (g as i32).clamp(0, dims[a] - 1)
        };
        // `-0.0 > 0.0` and `-0.0 < 0.0` are both false: no step, as for `+0.0`.
        step[a] = if ray.d[a] > 0.0 {
            1
        } else if ray.d[a] < 0.0 {
            -1
        } else {
            0
        };
    }
    Some(BoxEntry {
        cell,
        step,
        t_enter,
        t_exit,
    })
}

/// Lazily yields the majorant segments of a ray in index space. Allocates nothing; the
/// tracking loop pulls segments until it collides or runs out.
#[derive(Clone, Debug)]
pub struct DdaMajorantIterator<'a> {
    bounds: &'a [CellBounds],
    dims: [i32; 3],
    ray: Ray,
    /// Index-space minimum corner of the cell box.
    lo: Vec3,
    /// Cell edge per axis (8 for the leaf grid, the whole box for the global bound).
    width: Vec3,
    /// Ray density scale applied to the bounds (`sigma = scale * value`).
    scale: f32,
    cell: [i32; 3],
    /// -1, 0 or +1: the direction the cell index moves along each axis. 0 for `d == ±0.0`,
    /// so an axis-parallel ray never steps on that axis.
    step: [i32; 3],
    /// Ray parameter at which the ray crosses into the next cell along each axis.
    next_crossing: [f32; 3],
    /// Start of the next segment.
    t: f32,
    t_exit: f32,
    done: bool,
}

impl<'a> DdaMajorantIterator<'a> {
    /// Segments of `ray` (in index space) over `[t0, t1]`, one per cell of `bounds`, with
    /// `sigma_maj = scale * max` and `sigma_min = scale * min`. `scale` must be non-negative.
    pub fn new(bounds: &'a LeafBounds, ray: &Ray, t0: f32, t1: f32, scale: f32) -> Self {
        let lo = Vec3::from_array(bounds.cell_origin.map(|c| c as f32 * CELL_WIDTH));
        let dims = bounds.dims.map(|d| d as i32);
        Self::walk(
            &bounds.cells,
            dims,
            lo,
            Vec3::splat(CELL_WIDTH),
            ray,
            t0,
            t1,
            scale,
        )
    }

    /// A single segment over the ray's overlap with the cell box, carrying the global bounds:
    /// the baseline that per-cell majorants are measured against.
    pub fn global(bounds: &'a LeafBounds, ray: &Ray, t0: f32, t1: f32, scale: f32) -> Self {
        let lo = Vec3::from_array(bounds.cell_origin.map(|c| c as f32 * CELL_WIDTH));
        let extent = Vec3::from_array(bounds.dims.map(|d| d as f32 * CELL_WIDTH));
        let dims = if bounds.cells.is_empty() {
            [0; 3]
        } else {
            [1; 3]
        };
        Self::walk(
            std::slice::from_ref(&bounds.global),
            dims,
            lo,
            extent,
            ray,
            t0,
            t1,
            scale,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn walk(
        bounds: &'a [CellBounds],
        dims: [i32; 3],
        lo: Vec3,
        width: Vec3,
        ray: &Ray,
        t0: f32,
        t1: f32,
        scale: f32,
    ) -> Self {
        debug_assert!(
            scale >= 0.0,
            "a negative density scale would swap the bounds"
        );
        let mut it = Self {
            bounds,
            dims,
            ray: *ray,
            lo,
            width,
            scale,
            cell: [0; 3],
            step: [0; 3],
            next_crossing: [f32::INFINITY; 3],
            t: 0.0,
            t_exit: 0.0,
            done: true,
        };
        let Some(e) = enter_box(lo, width, dims, ray, t0, t1) else {
            return it;
        };
        it.cell = e.cell;
        it.step = e.step;
        for a in 0..3 {
            it.next_crossing[a] = it.crossing(a);
        }
        let (t_enter, t_exit) = (e.t_enter, e.t_exit);
        it.t = t_enter;
        it.t_exit = t_exit;
        it.done = false;
        it
    }

    /// Ray parameter where the ray leaves the current cell along `axis` (infinite when it
    /// does not move along it).
    #[inline]
    fn crossing(&self, axis: usize) -> f32 {
        let plane_cell = match self.step[axis] {
            0 => return f32::INFINITY,
            1 => self.cell[axis] + 1,
            _ => self.cell[axis],
        };
        let plane = self.lo[axis] + plane_cell as f32 * self.width[axis];
        (plane - self.ray.o[axis]) / self.ray.d[axis]
    }

    #[inline]
    fn cell_bounds(&self) -> CellBounds {
        let [x, y, z] = self.cell.map(|c| c as usize);
        self.bounds[x + self.dims[0] as usize * (y + self.dims[1] as usize * z)]
    }
}

impl Iterator for DdaMajorantIterator<'_> {
    type Item = MajorantSegment;

    fn next(&mut self) -> Option<MajorantSegment> {
        while !self.done {
            // The axis whose cell boundary the ray meets first.
            let c = &self.next_crossing;
            let axis = if c[0] <= c[1] && c[0] <= c[2] {
                0
            } else if c[1] <= c[2] {
                1
            } else {
                2
            };
            let next_cell = self.cell[axis] + self.step[axis];
            // The last segment always ends exactly at the box exit, even if rounding puts the
            // final plane crossing a hair before it.
            let leaving = self.next_crossing[axis] >= self.t_exit
                || next_cell < 0
                || next_cell >= self.dims[axis];
            let t_min = self.t;
            // Never move backwards, and keep t_min's own bits when the crossing merely equals
            // it (`-0.0 == 0.0`), so consecutive segments share their ends bit for bit.
            let crossing = self.next_crossing[axis];
            let t_max = if leaving {
                self.t_exit
            } else if crossing > t_min {
                crossing
            } else {
                t_min
            };
            let b = self.cell_bounds();
            if leaving {
                self.done = true;
            } else {
                self.cell[axis] = next_cell;
                self.next_crossing[axis] = self.crossing(axis);
                self.t = t_max;
            }
            // Crossing an edge or corner visits cells for zero length; they carry nothing.
            if t_max > t_min {
                return Some(MajorantSegment {
                    t_min,
                    t_max,
                    sigma_maj: self.scale * b.max,
                    sigma_min: self.scale * b.min,
                });
            }
        }
        None
    }
}

impl std::iter::FusedIterator for DdaMajorantIterator<'_> {}
