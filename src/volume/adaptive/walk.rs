//! The walk through an [`AdaptiveMajorants`]: one segment per merged node crossed.
use super::{AdaptiveMajorants, MAX_LEVEL};
use crate::math::{Ray, Vec3};
use crate::volume::bounds::{CellBounds, CELL_WIDTH};
use crate::volume::dda::{first_axis, CellBox, DdaState};
use crate::volume::segment::MajorantSegment;

/// Lazily yields the segments of a ray (in index space) through an [`AdaptiveMajorants`]:
/// one per merged node crossed. See the module documentation for the walk.
///
/// Inside level-0 regions it takes the per-leaf DDA's incremental step ([`DdaState`]); a
/// merged node costs three plane crossings, the exit point's cell and a fresh DDA state.
#[derive(Clone, Debug)]
pub struct AdaptiveMajorantIterator<'a> {
    /// The tree's leaf levels and node bounds, held directly: the walk reads both at every
    /// segment, and a chain of dependent loads through the tree cost more than its arithmetic.
    node_level: &'a [u8],
    nodes: &'a [CellBounds],
    /// [`AdaptiveMajorants::level_index`].
    level_index: &'a [[u32; 3]; MAX_LEVEL as usize + 1],
    scale: f32,
    dda: DdaState,
}

impl<'a> AdaptiveMajorantIterator<'a> {
    /// Segments of `ray` over `[t0, t1]` with `sigma_maj = scale * max`,
    /// `sigma_min = scale * min` of each merged node crossed.
    pub fn new(tree: &'a AdaptiveMajorants, ray: &Ray, t0: f32, t1: f32, scale: f32) -> Self {
        // The tree's level-0 cells are the per-leaf bounds' cells.
        let cells = CellBox {
            lo: Vec3::from_array(tree.cell_origin.map(|c| c as f32 * CELL_WIDTH)),
            width: Vec3::splat(CELL_WIDTH),
            dims: tree.dims.map(|d| d as i32),
            clip: tree.walk_box,
        };
        Self {
            node_level: &tree.node_level,
            nodes: &tree.nodes,
            level_index: &tree.level_index,
            scale,
            dda: DdaState::enter(&cells, ray, t0, t1),
        }
    }

    /// Ray parameter where the ray leaves node `node` of level `l` along `axis`: the plane's
    /// position (exact: an integer multiple of 8) times `1 / d`, as the DDA computes it, so
    /// level 0 reproduces the DDA bit for bit.
    #[inline(always)]
    fn crossing(&self, axis: usize, node: i32, l: u32) -> f32 {
        let w = &self.dda;
        let s = w.step[axis];
        let plane_node = node + (s > 0) as i32;
        let plane = w.lo[axis] + (plane_node << l) as f32 * CELL_WIDTH;
        let c = (plane - w.o[axis]) * w.inv_d[axis];
        if s == 0 {
            f32::INFINITY
        } else {
            c
        }
    }

    /// One segment over the merged node of level `l > 0` holding the current cell, then into
    /// the leaf cell just across its exit plane.
    #[inline(never)]
    fn node_step(&mut self, l: u32) -> Option<MajorantSegment> {
        let cell = self.dda.cell();
        let node = [cell[0] >> l, cell[1] >> l, cell[2] >> l];
        // Written out: an array map here compiled to a call per segment.
        let c = [
            self.crossing(0, node[0], l),
            self.crossing(1, node[1], l),
            self.crossing(2, node[2], l),
        ];
        let axis = first_axis(c);
        let w = &mut self.dda;
        // The leaf cell just across the exit plane.
        let next_cell = if w.step[axis] > 0 {
            (node[axis] + 1) << l
        } else {
            (node[axis] << l) - 1
        };
        let leaving = c[axis] >= w.t_exit || next_cell < 0 || next_cell >= w.dims[axis];
        let t_min = w.t;
        let t_max = if leaving {
            w.t_exit
        } else if c[axis] > t_min {
            c[axis]
        } else {
            t_min
        };
        let [off, lx, lxy] = self.level_index[l as usize];
        let b = self.nodes
            [(off + node[0] as u32 + lx * node[1] as u32 + lxy * node[2] as u32) as usize];
        if leaving {
            w.done = true;
        } else {
            // The other axes: the cell of the exit point `o + t d`, kept inside the node just
            // left (so no axis ever moves backwards and rounding cannot skip a node).
            // `(x - lo) * 0.125` is `(x - lo) / 8` exactly, and the saturating cast equals
            // `floor` wherever the clamp keeps it (the node's first cell is never negative):
            // no libm call.
            let mut next = cell;
            for a in 0..3 {
                if a != axis && w.step[a] != 0 {
                    let p = w.o[a] + t_max * w.d[a];
                    let g = ((p - w.lo[a]) * (1.0 / CELL_WIDTH)) as i32;
                    let first = node[a] << l;
                    let last = (((node[a] + 1) << l) - 1).min(w.dims[a] - 1);
                    next[a] = g.clamp(first, last);
                }
            }
            next[axis] = next_cell;
            w.set_cell(next);
            w.t = t_max;
        }
        (t_max > t_min).then_some(MajorantSegment {
            t_min,
            t_max,
            sigma_maj: self.scale * b.max,
            sigma_min: self.scale * b.min,
        })
    }
}

impl Iterator for AdaptiveMajorantIterator<'_> {
    type Item = MajorantSegment;

    // Always inlined, also through `&mut` (the estimators walk through a reference): a call
    // per segment costs as much as the step.
    #[inline(always)]
    fn next(&mut self) -> Option<MajorantSegment> {
        while !self.dda.done {
            let l = self.node_level[self.dda.index] as u32;
            // Level 0 first: the per-leaf cells are the nodes' first entries.
            let seg = if l == 0 {
                self.dda.step(self.nodes, self.scale)
            } else {
                self.node_step(l)
            };
            if seg.is_some() {
                return seg;
            }
        }
        None
    }
}

impl std::iter::FusedIterator for AdaptiveMajorantIterator<'_> {}
