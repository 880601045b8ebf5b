//! Emitting VDB media as lights for next-event estimation.
//!
//! Without it a flame is found only by the paths that happen to collide inside it, and the
//! ground under a small fire is lit by the few that wander in. Every leaf cell of an emitting
//! medium has an upper bound `Le_c` of its emission's largest channel
//! ([`emission_bound`](super::emission_bounds::emission_bound)), and a mean `m_c` of it taken
//! at 4 x 4 x 4 points inside the cell when the render is prepared. A cell's power is
//! `e_c V_c`, `e_c = m_c + Le_c / 100` (`V_c` the cell's world volume; the share of the bound
//! keeps every cell that may emit reachable, so the estimate stays unbiased whatever the 64
//! points missed). From shading point `x` a light tree over the cells
//! ([`CellTree`](super::cell_tree::CellTree)) chooses cell `c` with probability `P(c | x)`,
//! about its power over its squared distance, so a point on the ground beside a fire draws the
//! flames near it more often than the far side; a point `y` is drawn uniformly inside the
//! cell, so the volume density of `y` is
//!
//! ```text
//! p_V(y | x) = P(c | x) / V_c
//! ```
//!
//! and `y` is kept with probability `P_keep = min(1, lum(Le(y)) / e_c)` (stochastic rejection:
//! a point at least as bright as its cell's mean is always traced, a dimmer one in proportion,
//! so shadow rays go where the light is, and the estimate divides by that probability). From
//! a shading point `x` with scattering factor `f` (phase function or BSDF times cosine):
//!
//! ```text
//! <L> = w_L f(wi) T^(x, y) Le(y) / (p_V(y) |y - x|^2 P_keep(y))
//! ```
//!
//! with the transmittance `T^` ratio tracked through every medium. The flights' own emission
//! estimate (each tentative collision adds `beta w Le / sigma_maj`) finds the same light along
//! the continuation ray; the two are weighed by the power heuristic in the measure of solid
//! angle times distance, with the continuation's density taken as the direction's pdf times
//! the walk's majorant in the cell (the rate of its collisions there):
//!
//! ```text
//! p_L = p_V(y | x) |y - x|^2,    p_C = pdf(wi) sigma_maj,c,    w_L = p_L^2 / (p_L^2 + p_C^2)
//! ```
//!
//! and a collision's emission after a scattering event is weighted by `w_C = 1 - w_L` at its
//! point (after the camera or a smooth dielectric, by 1). Moving or blurred media are left to
//! the flights (their emission's place depends on the sample's time).
use std::cell::Cell;

use glam::{Affine3A, Vec3};
use rayon::prelude::*;

use super::cell_tree::CellTree;
use super::emission_bounds::emission_bound;
use super::lights::power_heuristic;
use super::media::{Emission, VdbMedium};
use crate::math::Aabb;
use crate::scene::NO_INDEX;
use crate::volume::bounds::CELL_WIDTH;

/// One emitting medium's cells as a light.
pub struct EmitterMedium {
    /// Its index in `RenderScene::vdb`.
    pub vdb: u32,
    /// Per cell of the density's cell grid (x fastest): `e_c` of the module doc (0 where the
    /// cell cannot emit).
    pub(crate) weight: Vec<f32>,
    /// Per cell: the walk's majorant `sigma_maj,c` (m^-1).
    pub(crate) sigma_maj: Vec<f32>,
    /// Per cell: its item in the light tree, `NO_INDEX` where it cannot emit.
    pub(crate) entry: Vec<u32>,
    /// `V_c`, a cell's world volume (m^3).
    pub(crate) volume: f32,
    pub(crate) dims: [u32; 3],
    pub(crate) cell_origin: [i32; 3],
    pub(crate) world_from_index: Affine3A,
}

impl EmitterMedium {
    /// The cell holding index-space point `q`, if inside the grid.
    #[inline]
    fn cell(&self, q: Vec3) -> Option<usize> {
        let mut index = 0usize;
        let mut stride = 1usize;
        for a in 0..3 {
            let c = (q[a] / CELL_WIDTH).floor() as i64 - self.cell_origin[a] as i64;
            if !(0..self.dims[a] as i64).contains(&c) {
                return None;
            }
            index += c as usize * stride;
            stride *= self.dims[a] as usize;
        }
        Some(index)
    }
}

/// Every emitting medium's cells as one light ([module doc](self)).
pub struct MediaLights {
    pub media: Vec<EmitterMedium>,
    /// `(medium slot, cell)` of every cell that may emit: the light tree's items.
    pub(crate) entries: Vec<(u32, u32)>,
    /// The tree over them, each with power `e_c V_c` and the cell's world box.
    pub(crate) tree: CellTree,
    /// World boxes of the media they light: each emitting medium's cells that hold density,
    /// and every other still medium's that overlaps one of those (`integrator::lit_media`).
    pub lit: Vec<Aabb>,
}

/// A point sampled on the emitting media.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    /// Slot in [`MediaLights::media`].
    pub slot: u32,
    /// World position.
    pub y: Vec3,
    /// `p_V(y | x)`, per cubic metre.
    pub pdf_volume: f32,
    /// `sigma_maj,c` of its cell.
    pub sigma_maj: f32,
    /// `e_c` of its cell (what `P_keep` compares the point's emission with).
    pub weight: f32,
}

impl MediaLights {
    /// The light of `vdb`'s emitting media that stand still during the shutter; `None` where
    /// none emits. Sets each such medium's [`VdbMedium::emitter`].
    pub fn build(vdb: &mut [VdbMedium]) -> Option<MediaLights> {
        let mut media = Vec::new();
        let mut entries = Vec::new();
        let mut powers = Vec::new();
        let mut boxes = Vec::new();
        for (k, m) in vdb.iter_mut().enumerate() {
            let Some(e) = &m.emission else { continue };
            if m.blur.is_some() || m.motion.is_some() {
                continue;
            }
            let bound = emission_bound(&m.density, e);
            let walk = m.bounds();
            if walk.cells.len() != bound.len() {
                continue;
            }
            let sigma_maj: Vec<f32> = walk.cells.iter().map(|c| c.max * m.sigma_t_bound).collect();
            let world_from_index = m.density.index_from_world.inverse();
            let volume = world_from_index.matrix3.determinant().abs() * CELL_WIDTH.powi(3);
            let (dims, cell_origin) = (walk.dims, walk.cell_origin);
            // Only cells the walks collide in: the flights gather no emission anywhere else.
            let weight: Vec<f32> = (0..bound.len())
                .into_par_iter()
                .map(|c| {
                    let b = bound[c];
                    if !(b > 0.0 && b.is_finite() && sigma_maj[c] > 0.0) {
                        return 0.0;
                    }
                    let lo = cell_lo(dims, cell_origin, c);
                    cell_mean(e, world_from_index, lo) + b * BOUND_SHARE
                })
                .collect();
            let slot = media.len() as u32;
            let mut entry = vec![NO_INDEX; weight.len()];
            for (c, &w) in weight.iter().enumerate() {
                let p = w * volume;
                if p > 0.0 && p.is_finite() {
                    entry[c] = entries.len() as u32;
                    entries.push((slot, c as u32));
                    powers.push(p);
                    boxes.push(world_box(world_from_index, cell_lo(dims, cell_origin, c)));
                }
            }
            if entry.iter().all(|&e| e == NO_INDEX) {
                continue;
            }
            m.emitter = Some(slot);
            media.push(EmitterMedium {
                vdb: k as u32,
                weight,
                sigma_maj,
                entry,
                volume,
                dims,
                cell_origin,
                world_from_index,
            });
        }
        let tree = CellTree::build(&boxes, &powers).filter(|t| t.nodes[0].power.is_finite());
        let Some(tree) = tree else {
            for m in vdb.iter_mut() {
                m.emitter = None;
            }
            return None;
        };
        let lit = lit_boxes(vdb, &media);
        Some(MediaLights {
            media,
            entries,
            tree,
            lit,
        })
    }

    /// A point drawn for shading point `x` by `u_select` (the cell) and `u` (the point in it).
    pub fn sample(&self, x: Vec3, u_select: f32, u: Vec3) -> Option<EmitterSample> {
        let (i, pmf) = self.tree.sample(x, u_select)?;
        let (slot, c) = self.entries[i as usize];
        let m = &self.media[slot as usize];
        let c = c as usize;
        let q = cell_lo(m.dims, m.cell_origin, c) + u * CELL_WIDTH;
        Some(EmitterSample {
            slot,
            y: m.world_from_index.transform_point3(q),
            pdf_volume: pmf / m.volume,
            sigma_maj: m.sigma_maj[c],
            weight: m.weight[c],
        })
    }

    /// The weight of a flight's emission at index-space point `q` of medium `slot`, a
    /// distance `dist` from the event `x` the ray left in a direction of pdf `pdf_dir`:
    /// `w_C` of the module doc (1 where the light cannot draw the point).
    #[inline]
    pub fn collision_weight(&self, slot: u32, q: Vec3, x: Vec3, dist: f32, pdf_dir: f32) -> f32 {
        let m = &self.media[slot as usize];
        let Some(c) = m.cell(q) else {
            return 1.0;
        };
        let (item, s) = (m.entry[c], m.sigma_maj[c]);
        if item == NO_INDEX || !(s > 0.0) {
            return 1.0;
        }
        let p_v = self.tree.pmf(x, item) / m.volume;
        power_heuristic(pdf_dir * s, p_v * dist * dist)
    }

    /// The number of cells that may emit.
    pub fn cells(&self) -> usize {
        self.entries.len()
    }
}

/// The world boxes of the media the emitters `media` light ([`MediaLights::lit`]): the
/// emitting media first, then the other still media whose box meets one of theirs.
fn lit_boxes(vdb: &[VdbMedium], media: &[EmitterMedium]) -> Vec<Aabb> {
    let dense = |m: &VdbMedium| {
        let walk = m.bounds();
        let world_from_index = m.density.index_from_world.inverse();
        let mut b = Aabb::EMPTY;
        for (c, cell) in walk.cells.iter().enumerate() {
            if cell.max > 0.0 {
                let (lo, hi) = world_box(world_from_index, cell_lo(walk.dims, walk.cell_origin, c));
                b = b.union(&Aabb::new(lo, hi));
            }
        }
        b
    };
    let mut lit: Vec<Aabb> = media.iter().map(|e| dense(&vdb[e.vdb as usize])).collect();
    let emitting = lit.clone();
    let meets = |a: &Aabb, b: &Aabb| a.min.cmple(b.max).all() && b.min.cmple(a.max).all();
    for (k, m) in vdb.iter().enumerate() {
        let still = m.blur.is_none() && m.motion.is_none();
        if still && !media.iter().any(|e| e.vdb as usize == k) {
            let b = dense(m);
            if !b.is_empty() && emitting.iter().any(|e| meets(e, &b)) {
                lit.push(b);
            }
        }
    }
    lit.retain(|b| !b.is_empty());
    lit
}

/// The world box of the cell at index corner `lo`.
fn world_box(world_from_index: Affine3A, lo: Vec3) -> (Vec3, Vec3) {
    let (mut a, mut b) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for k in 0..8 {
        let corner = Vec3::new((k & 1) as f32, (k >> 1 & 1) as f32, (k >> 2) as f32);
        let w = world_from_index.transform_point3(lo + corner * CELL_WIDTH);
        a = a.min(w);
        b = b.max(w);
    }
    (a, b)
}

/// The share of a cell's emission bound its selection weight keeps beside its mean.
const BOUND_SHARE: f32 = 0.01;

/// The index-space corner of cell `c` of a `dims` grid of cells starting at `cell_origin`.
fn cell_lo(dims: [u32; 3], cell_origin: [i32; 3], c: usize) -> Vec3 {
    let [nx, ny, _] = dims.map(|d| d as usize);
    let cell = [c % nx, c / nx % ny, c / (nx * ny)];
    Vec3::from_array(std::array::from_fn(|a| {
        (cell_origin[a] + cell[a] as i32) as f32 * CELL_WIDTH
    }))
}

/// The mean of the emission's largest channel over 4 x 4 x 4 points of the cell at index
/// corner `lo`.
fn cell_mean(e: &Emission, world_from_index: Affine3A, lo: Vec3) -> f32 {
    const N: usize = 4;
    let lookups = Cell::new(0);
    let mut sum = 0.0;
    for k in 0..N * N * N {
        let f = Vec3::new((k % N) as f32, (k / N % N) as f32, (k / (N * N)) as f32);
        let q = lo + (f + 0.5) * (CELL_WIDTH / N as f32);
        sum += e
            .radiance(world_from_index.transform_point3(q), &lookups)
            .max_element();
    }
    sum / (N * N * N) as f32
}
