//! Emitting VDB media as lights for next-event estimation.
//!
//! Without it a flame is found only by the paths that happen to collide inside it, and the
//! ground under a small fire is lit by the few that wander in. Every leaf cell of an emitting
//! medium has an upper bound `Le_c` of its emission's largest channel
//! ([`emission_bound`](super::emission_bounds::emission_bound)); the cells are chosen in
//! proportion to `Le_c V_c` (`V_c` the cell's world volume), a point `y` uniformly inside the
//! chosen cell, so the volume density of `y` is
//!
//! ```text
//! p_V(y) = Le_c / W,    W = sum_c Le_c V_c
//! ```
//!
//! and `y` is kept with probability `lum(Le(y)) / Le_c` (stochastic rejection against the
//! bound: the shadow ray is traced only for kept points, which are distributed like the
//! emission itself, and the estimate divides by that probability). From a shading point `x`
//! with scattering factor `f` (phase function or BSDF times cosine):
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
//! p_L = p_V(y) |y - x|^2,    p_C = pdf(wi) sigma_maj,c,    w_L = p_L^2 / (p_L^2 + p_C^2)
//! ```
//!
//! and a collision's emission after a scattering event is weighted by `w_C = 1 - w_L` at its
//! point (after the camera or a smooth dielectric, by 1). Moving or blurred media are left to
//! the flights (their emission's place depends on the sample's time).
use glam::{Affine3A, Vec3};

use super::emission_bounds::emission_bound;
use super::lights::power_heuristic;
use super::media::VdbMedium;
use crate::volume::bounds::CELL_WIDTH;

/// One emitting medium's cells as a light.
pub struct EmitterMedium {
    /// Its index in `RenderScene::vdb`.
    pub vdb: u32,
    /// Per cell of the density's cell grid (x fastest): the emission bound `Le_c`.
    bound: Vec<f32>,
    /// Per cell: the walk's majorant `sigma_maj,c` (m^-1).
    sigma_maj: Vec<f32>,
    dims: [u32; 3],
    cell_origin: [i32; 3],
    world_from_index: Affine3A,
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
    /// `(medium slot, cell)` of every cell that may emit, and the normalised cumulative
    /// `Le_c V_c` over them.
    entries: Vec<(u32, u32)>,
    cdf: Vec<f32>,
    /// `W`: the sum of `Le_c V_c`.
    total: f32,
}

/// A point sampled on the emitting media.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    /// Slot in [`MediaLights::media`].
    pub slot: u32,
    /// World position.
    pub y: Vec3,
    /// `p_V(y)`, per cubic metre.
    pub pdf_volume: f32,
    /// `sigma_maj,c` of its cell.
    pub sigma_maj: f32,
    /// `Le_c` of its cell.
    pub bound: f32,
}

impl MediaLights {
    /// The light of `vdb`'s emitting media that stand still during the shutter; `None` where
    /// none emits. Sets each such medium's [`VdbMedium::emitter`].
    pub fn build(vdb: &mut [VdbMedium]) -> Option<MediaLights> {
        let mut media = Vec::new();
        let mut entries = Vec::new();
        let mut weights = Vec::new();
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
            let slot = media.len() as u32;
            let mut any = false;
            for (c, &b) in bound.iter().enumerate() {
                // A cell the walk never collides in is left to nothing: it cannot emit.
                if b > 0.0 && b.is_finite() && sigma_maj[c] > 0.0 {
                    entries.push((slot, c as u32));
                    weights.push(b as f64 * volume as f64);
                    any = true;
                }
            }
            if !any {
                continue;
            }
            let (dims, cell_origin) = (walk.dims, walk.cell_origin);
            m.emitter = Some(slot);
            media.push(EmitterMedium {
                vdb: k as u32,
                bound,
                sigma_maj,
                dims,
                cell_origin,
                world_from_index,
            });
        }
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            for m in vdb.iter_mut() {
                m.emitter = None;
            }
            return None;
        }
        let mut acc = 0.0;
        let cdf = weights
            .iter()
            .map(|w| {
                acc += w / total;
                acc as f32
            })
            .collect();
        Some(MediaLights {
            media,
            entries,
            cdf,
            total: total as f32,
        })
    }

    /// A point drawn by `u_select` (the cell) and `u` (the point in it).
    pub fn sample(&self, u_select: f32, u: Vec3) -> Option<EmitterSample> {
        let i = self
            .cdf
            .partition_point(|&c| c <= u_select)
            .min(self.cdf.len() - 1);
        let (slot, c) = self.entries[i];
        let m = &self.media[slot as usize];
        let c = c as usize;
        let [nx, ny, _] = m.dims.map(|d| d as usize);
        let cell = [c % nx, c / nx % ny, c / (nx * ny)];
        let lo = Vec3::from_array(std::array::from_fn(|a| {
            (m.cell_origin[a] + cell[a] as i32) as f32 * CELL_WIDTH
        }));
        let q = lo + u * CELL_WIDTH;
        Some(EmitterSample {
            slot,
            y: m.world_from_index.transform_point3(q),
            pdf_volume: m.bound[c] / self.total,
            sigma_maj: m.sigma_maj[c],
            bound: m.bound[c],
        })
    }

    /// The weight of a flight's emission at index-space point `q` of medium `slot`, a
    /// distance `dist` from the event the ray left in a direction of pdf `pdf_dir`:
    /// `w_C` of the module doc (1 where the light cannot draw the point).
    #[inline]
    pub fn collision_weight(&self, slot: u32, q: Vec3, dist: f32, pdf_dir: f32) -> f32 {
        let m = &self.media[slot as usize];
        let Some(c) = m.cell(q) else {
            return 1.0;
        };
        let (b, s) = (m.bound[c], m.sigma_maj[c]);
        if !(b > 0.0 && s > 0.0) {
            return 1.0;
        }
        power_heuristic(pdf_dir * s, b / self.total * dist * dist)
    }

    /// `W`, the sum of every cell's bound times its volume.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// The number of cells that may emit.
    pub fn cells(&self) -> usize {
        self.entries.len()
    }
}
