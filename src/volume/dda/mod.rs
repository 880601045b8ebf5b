//! The majorant DDA: walks a ray through the cell grid of [`LeafBounds`] and yields one
//! [`MajorantSegment`] per cell crossed.
//!
//! This is the 3D-DDA of Amanatides and Woo, "A Fast Voxel Traversal Algorithm for Ray
//! Tracing" (Eurographics 1987), as pbrt-v4's `DDAMajorantIterator` uses it, with two changes
//! for robustness:
//! * each plane crossing is computed afresh from the plane's position, `(plane - o) * (1 / d)`,
//!   rather than by accumulating `1 / d` steps, so errors do not grow along long rays;
//! * segment ends are clamped to be non-decreasing and zero-length segments are skipped, so
//!   the segments tile the ray's overlap with the cell box exactly: the first `t_min` is the
//!   box entry, each `t_max` is bit-for-bit the next `t_min`, the last `t_max` is the box exit.
//!
//! Where rounding puts a sample point slightly outside the cell the walk assigns it to, the
//! one-voxel apron of [`LeafBounds`] still bounds it.
mod lanes;
pub(crate) use lanes::cell_of;

use super::bounds::{CellBounds, LeafBounds, CELL_WIDTH};
use super::segment::MajorantSegment;
use crate::math::{Aabb, Ray, Vec3};

/// Where a ray enters a box of `dims` cells of size `width` from `lo`, clipped to `[t0, t1]`:
/// the entry cell and the overlap. Shared by the per-leaf DDA and
/// the adaptive walk, so both start the same way bit for bit.
pub(crate) struct BoxEntry {
    pub cell: [i32; 3],
    pub t_enter: f32,
    pub t_exit: f32,
}

/// The box a walk goes through: `dims` cells of edge `width` from `lo` (index space), walked
/// only inside `clip`, the bounds' walk box ([`LeafBounds::walk_box`]: outside it every value
/// is 0, so the walk never starts before it nor runs past it). The per-leaf DDA, the global
/// bound (one cell over the whole box) and the adaptive walk each describe theirs once per
/// flight and enter it with the ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellBox {
    pub lo: Vec3,
    pub width: Vec3,
    pub dims: [i32; 3],
    pub clip: (Vec3, Vec3),
}

impl CellBox {
    /// The per-leaf cells of `bounds`.
    #[inline]
    pub fn leaf_cells(bounds: &LeafBounds) -> Self {
        Self {
            lo: bounds.cell_lo(),
            width: Vec3::splat(CELL_WIDTH),
            dims: bounds.dims.map(|d| d as i32),
            clip: bounds.walk_box(),
        }
    }

    /// One cell over the whole cell box of `bounds` (none when it has no cells): the global
    /// bound's walk.
    #[inline]
    pub fn whole(bounds: &LeafBounds) -> Self {
        Self {
            lo: bounds.cell_lo(),
            width: Vec3::from_array(bounds.dims.map(|d| d as f32 * CELL_WIDTH)),
            dims: if bounds.cells.is_empty() {
                [0; 3]
            } else {
                [1; 3]
            },
            clip: bounds.walk_box(),
        }
    }
}

/// [`BoxEntry`] of `ray` (with `inv_d = 1 / d` per axis) into the part of `cb` inside its
/// walk box, or `None` when the overlap is empty (or the box is).
#[inline(always)]
pub(crate) fn enter_box(
    cb: &CellBox,
    ray: &Ray,
    inv_d: [f32; 3],
    t0: f32,
    t1: f32,
) -> Option<BoxEntry> {
    let CellBox {
        lo,
        width,
        dims,
        clip,
    } = *cb;
    if dims.iter().any(|&n| n <= 0) {
        return None;
    }
    let hi = lo + width * Vec3::from_array(dims.map(|n| n as f32));
    // The same slab test a renderer would use for the box, so the tiling is exact; the walk
    // box lies inside the cell box, and the max/min keep it there whatever `clip` says.
    let (t_enter, t_exit) =
        Aabb::new(lo.max(clip.0), hi.min(clip.1)).intersect_inv(ray.o, inv_d, t0, t1)?;
    // Written positively so NaN parameters are rejected too; an empty overlap yields nothing.
    if !(t_enter < t_exit) {
        return None;
    }
    let p = ray.at(t_enter);
    let mut cell = [0; 3];
    for a in 0..3 {
        // On an axis the ray does not move along, `t_enter` may be infinite and `t * 0`
        // NaN: the coordinate is simply the origin's.
        let x = if ray.d[a] == 0.0 { ray.o[a] } else { p[a] };
        // Rounding can put the entry point a hair outside the box: clamp into it. The
        // saturating cast truncates, which equals `floor` wherever the clamp keeps the
        // value (negatives all clamp to 0) and maps NaN to 0: no libm `floorf` call. A
        // one-cell box (the global bound) needs no cell at all; every other box is a grid of
        // 8-voxel cells, where `x * (1 / 8) == x / 8` exactly: no division.
        debug_assert!(dims[a] == 1 || width[a] == CELL_WIDTH);
        cell[a] = if dims[a] == 1 {
            0
        } else {
            (((x - lo[a]) * (1.0 / CELL_WIDTH)) as i32).clamp(0, dims[a] - 1)
        };
    }
    Some(BoxEntry {
        cell,
        t_enter,
        t_exit,
    })
}

/// `1 / d` per axis and the step direction: -1, 0 or +1. An axis steps only when `1 / d` is
/// finite: `d == ±0.0` (including `-0.0`, which compares equal to `0.0`) and subnormal `d`
/// (whose reciprocal overflows) never step, so no crossing is ever `0 * inf`. A subnormal
/// component moves the ray less than a voxel over any finite parameter range, which the
/// bounds' one-voxel apron covers.
#[inline]
pub(crate) fn reciprocal_and_step(d: f32) -> (f32, i32) {
    let inv = 1.0 / d;
    let step = if !inv.is_finite() {
        0
    } else if d > 0.0 {
        1
    } else {
        -1
    };
    (inv, step)
}

/// The state of one walk through a grid of cells: the per-leaf DDA's, and the adaptive walk's
/// inside level-0 regions ([`crate::volume::AdaptiveMajorantIterator`] holds one).
///
/// Each step is incremental: the cell is a flat index moved by a per-axis stride, the plane
/// the ray meets next along an axis moves by one cell width (exact: cell planes are integer
/// multiples of 8 well below 2^24), and its crossing is `(plane - o) * (1 / d)`: one multiply,
/// no division, and no error carried from step to step.
#[derive(Clone, Debug)]
pub(crate) struct DdaState {
    pub dims: [i32; 3],
    /// Index-space minimum corner of the cell box and the cell edge per axis.
    pub lo: [f32; 3],
    width: [f32; 3],
    pub o: [f32; 3],
    pub d: [f32; 3],
    /// `1 / d` and the step direction per axis ([`reciprocal_and_step`]).
    pub inv_d: [f32; 3],
    pub step: [i32; 3],
    /// Flat index of the current cell, `x + nx (y + ny z)`.
    pub index: usize,
    /// Change of `index` when the walk steps along each axis (0 on an axis it never steps).
    stride: [isize; 3],
    /// Cells left to step into along each axis before the box ends (0 on a non-stepping axis).
    left: [i32; 3],
    /// The current cell on the axes the walk never steps along.
    fixed: [i32; 3],
    /// Index-space position of the plane the ray crosses next along each axis, and the signed
    /// cell width it moves by per step.
    plane: [f32; 3],
    plane_step: [f32; 3],
    /// Ray parameter at which the ray crosses `plane` along each axis (infinite when it does
    /// not step along it).
    next_crossing: [f32; 3],
    /// Start of the next segment, and where the ray leaves the box.
    pub t: f32,
    pub t_exit: f32,
    pub done: bool,
}

impl DdaState {
    /// The walk of `ray` over `[t0, t1]` through the cells of `cb`, clipped to its walk box
    /// (`done` when the ray misses it). A box of several cells (of edge [`CELL_WIDTH`]) is set
    /// up four lanes at a time ([`lanes::enter_cells`]), bit for bit as [`Self::enter_scalar`].
    #[inline]
    pub fn enter(cb: &CellBox, ray: &Ray, t0: f32, t1: f32) -> Self {
        if cb.dims == [1; 3] || cb.dims.iter().any(|&n| n <= 0) {
            return Self::enter_scalar(cb, ray, t0, t1);
        }
        debug_assert_eq!(cb.width, Vec3::splat(CELL_WIDTH));
        lanes::enter_cells(cb, ray, t0, t1)
    }

    /// [`Self::enter`] one axis at a time: the one-cell walk's and an empty box's set-up, and
    /// the reference the four-lane set-up is tested against.
    #[inline]
    pub fn enter_scalar(cb: &CellBox, ray: &Ray, t0: f32, t1: f32) -> Self {
        let CellBox {
            lo, width, dims, ..
        } = *cb;
        let mut it = Self {
            dims,
            lo: lo.to_array(),
            width: width.to_array(),
            o: ray.o.to_array(),
            d: ray.d.to_array(),
            inv_d: [0.0; 3],
            step: [0; 3],
            index: 0,
            stride: [0; 3],
            left: [0; 3],
            fixed: [0; 3],
            plane: [0.0; 3],
            plane_step: [0.0; 3],
            next_crossing: [f32::INFINITY; 3],
            t: 0.0,
            t_exit: 0.0,
            done: true,
        };
        if dims == [1; 3] {
            // One cell (the global bound, the culled walk): the walk is one segment from the
            // entry to the exit, which `step` emits at once because no axis has a cell left
            // (`left` 0). It needs neither steps nor planes, and the crossings stay infinite,
            // so the per-axis set-up below (about a tenth of a global-bound shadow ray's
            // instructions in callgrind) is skipped; `1 / d` is still needed, by the box's
            // slab test.
            it.inv_d = ray.d.to_array().map(|d| reciprocal_and_step(d).0);
            if let Some(e) = enter_box(cb, ray, it.inv_d, t0, t1) {
                (it.index, it.t, it.t_exit, it.done) = (0, e.t_enter, e.t_exit, false);
            }
            return it;
        }
        let flat = [
            1isize,
            dims[0] as isize,
            dims[0] as isize * dims[1] as isize,
        ];
        for a in 0..3 {
            let (inv, step) = reciprocal_and_step(ray.d[a]);
            it.inv_d[a] = inv;
            it.step[a] = step;
            it.stride[a] = step as isize * flat[a];
            it.plane_step[a] = step as f32 * width[a];
        }
        let Some(e) = enter_box(cb, ray, it.inv_d, t0, t1) else {
            return it;
        };
        it.set_cell(e.cell);
        it.t = e.t_enter;
        it.t_exit = e.t_exit;
        it.done = false;
        it
    }

    /// Puts the walk in `cell` (inside the box): its flat index, the cells left per axis, and
    /// the next plane and its crossing on each stepping axis.
    #[inline(always)]
    pub fn set_cell(&mut self, cell: [i32; 3]) {
        let [nx, ny, _] = self.dims.map(|n| n as usize);
        self.index = cell[0] as usize + nx * (cell[1] as usize + ny * cell[2] as usize);
        self.fixed = cell;
        for (a, &c) in cell.iter().enumerate() {
            let s = self.step[a];
            if s == 0 {
                continue;
            }
            self.left[a] = if s > 0 { self.dims[a] - 1 - c } else { c };
            let plane_cell = c + (s > 0) as i32;
            self.plane[a] = self.lo[a] + plane_cell as f32 * self.width[a];
            self.next_crossing[a] = (self.plane[a] - self.o[a]) * self.inv_d[a];
        }
    }

    /// The current cell's coordinates.
    #[inline(always)]
    pub fn cell(&self) -> [i32; 3] {
        [0, 1, 2].map(|a| match self.step[a] {
            0 => self.fixed[a],
            1 => self.dims[a] - 1 - self.left[a],
            _ => self.left[a],
        })
    }

    /// One step: the segment over the current cell with `bounds[index]` times `scale` (`None`
    /// for the zero-length visits of edge and corner crossings), then into the next cell or
    /// out of the box (`done`).
    #[inline(always)]
    pub fn step(&mut self, bounds: &[CellBounds], scale: f32) -> Option<MajorantSegment> {
        let axis = first_axis(self.next_crossing);
        let crossing = self.next_crossing[axis];
        // The last segment always ends exactly at the box exit, even if rounding puts the
        // final plane crossing a hair before it.
        let leaving = crossing >= self.t_exit || self.left[axis] == 0;
        let t_min = self.t;
        // Never move backwards, and keep t_min's own bits when the crossing merely equals it
        // (`-0.0 == 0.0`), so consecutive segments share their ends bit for bit.
        let t_max = if leaving {
            self.t_exit
        } else if crossing > t_min {
            crossing
        } else {
            t_min
        };
        let b = bounds[self.index];
        if leaving {
            self.done = true;
        } else {
            self.index = self.index.wrapping_add_signed(self.stride[axis]);
            self.left[axis] -= 1;
            self.plane[axis] += self.plane_step[axis];
            self.next_crossing[axis] = (self.plane[axis] - self.o[axis]) * self.inv_d[axis];
            self.t = t_max;
        }
        (t_max > t_min).then_some(MajorantSegment {
            t_min,
            t_max,
            sigma_maj: scale * b.max,
            sigma_min: scale * b.min,
        })
    }
}

/// Lazily yields the majorant segments of a ray in index space, one per cell crossed
/// ([`DdaState`]). Allocates nothing; the tracking loop pulls segments until it collides or
/// runs out.
#[derive(Clone, Debug)]
pub struct DdaMajorantIterator<'a> {
    bounds: &'a [CellBounds],
    /// Ray density scale applied to the bounds (`sigma = scale * value`).
    scale: f32,
    state: DdaState,
}

impl<'a> DdaMajorantIterator<'a> {
    /// Segments of `ray` (in index space) over `[t0, t1]`, one per cell of `bounds`, with
    /// `sigma_maj = scale * max` and `sigma_min = scale * min`. `scale` must be non-negative.
    pub fn new(bounds: &'a LeafBounds, ray: &Ray, t0: f32, t1: f32, scale: f32) -> Self {
        Self::walk(
            &bounds.cells,
            &CellBox::leaf_cells(bounds),
            ray,
            t0,
            t1,
            scale,
        )
    }

    /// A single segment over the ray's overlap with the walk box, carrying the global bounds:
    /// the baseline that per-cell majorants are measured against.
    pub fn global(bounds: &'a LeafBounds, ray: &Ray, t0: f32, t1: f32, scale: f32) -> Self {
        Self::walk(
            std::slice::from_ref(&bounds.global),
            &CellBox::whole(bounds),
            ray,
            t0,
            t1,
            scale,
        )
    }

    fn walk(
        bounds: &'a [CellBounds],
        cb: &CellBox,
        ray: &Ray,
        t0: f32,
        t1: f32,
        scale: f32,
    ) -> Self {
        debug_assert!(
            scale >= 0.0,
            "a negative density scale would swap the bounds"
        );
        DdaMajorantIterator {
            bounds,
            scale,
            state: DdaState::enter(cb, ray, t0, t1),
        }
    }
}

/// The axis whose crossing comes first; ties go to the lower axis. Written as two selects so
/// it compiles without branches (the winning axis of a random ray is unpredictable).
#[inline(always)]
pub(crate) fn first_axis(c: [f32; 3]) -> usize {
    let (m01, a01) = if c[1] < c[0] { (c[1], 1) } else { (c[0], 0) };
    if c[2] < m01 {
        2
    } else {
        a01
    }
}

impl Iterator for DdaMajorantIterator<'_> {
    type Item = MajorantSegment;

    // Always inlined, also through `&mut` (the estimators walk through a reference): a call
    // per segment costs as much as the step.
    #[inline(always)]
    fn next(&mut self) -> Option<MajorantSegment> {
        while !self.state.done {
            if let Some(seg) = self.state.step(self.bounds, self.scale) {
                return Some(seg);
            }
        }
        None
    }
}

impl std::iter::FusedIterator for DdaMajorantIterator<'_> {}
