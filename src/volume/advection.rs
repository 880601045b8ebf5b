//! Velocity motion blur's lookups: the point whose density reaches index point `p` at a time
//! offset, found by advecting back along a velocity grid.
//!
//! The scheme is Cycles' (`volume_shader_motion_blur`, after Kim and Ko 2007, "Eulerian
//! Motion Blur"): a first-order semi-Lagrangian step `phi(x, T) = phi(x - (T - t) u(x, T), t)`,
//! with the velocity at `T` itself estimated by one more such step, so two velocity lookups:
//!
//! ```text
//! p1 = p - k * u(p)
//! q  = p - k * u(p1)          // density, emission and temperature are read at q
//! ```
//!
//! where `k` is the sample's time offset from the frame times the scene's velocity factor.
//! Velocity values are vectors in the grid file's world space (the medium node's object space)
//! per unit of time, as Blender and Cycles read them.
use std::sync::Arc;

use super::{SpeedBounds, VectorGrid};
use crate::math::{DAffine3, DVec3};

/// A velocity grid as seen from a density grid's index space.
#[derive(Clone, Debug)]
pub struct Advection {
    pub velocity: Arc<VectorGrid>,
    /// Maps the density's index space to the velocity grid's.
    pub velocity_from_density: DAffine3,
    /// Maps a velocity value to a displacement in the density's index space (the linear part
    /// of the density's `index_from_world`, both grids sharing the file's world space).
    pub index_from_value: DAffine3,
}

impl Advection {
    /// The advection of a density grid whose file-space `world_from_index` is
    /// `density_world_from_index` along `velocity` (read in the same file space).
    pub fn new(velocity: Arc<VectorGrid>, density_world_from_index: DAffine3) -> Self {
        let velocity_from_density =
            velocity.components[0].index_from_world * density_world_from_index;
        let index_from_value = DAffine3::from_mat3(density_world_from_index.matrix3.inverse());
        Advection {
            velocity,
            velocity_from_density,
            index_from_value,
        }
    }

    /// The velocity at density index point `p`, as a density-index displacement per unit of
    /// the factor `k`.
    #[inline]
    pub fn velocity_at(&self, p: DVec3) -> DVec3 {
        let v = self
            .velocity
            .sample(self.velocity_from_density.transform_point3(p));
        self.index_from_value.transform_vector3(v)
    }

    /// The density index point read for `p` at factor `k` (time offset times velocity
    /// factor): the two-step scheme of the module docs; `p` itself at `k == 0`.
    #[inline]
    pub fn source(&self, p: DVec3, k: f64) -> DVec3 {
        if k == 0.0 {
            return p;
        }
        let p1 = p - k * self.velocity_at(p);
        p - k * self.velocity_at(p1)
    }

    /// A bound on the density-index speed `|index_from_value v|` of every velocity lookup
    /// made at density index points in the box `[lo, hi]`: the largest of the speed bounds of
    /// the velocity cells the box's image meets (and the background's where it leaves the
    /// velocity grid's cell box).
    pub fn speed_bound(&self, lo: DVec3, hi: DVec3) -> f64 {
        let speed = &self.velocity.speed;
        // The box's image in the velocity's index space, through its eight corners.
        let (mut vlo, mut vhi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for corner in 0..8 {
            let pick = |a: usize| if corner >> a & 1 == 0 { lo[a] } else { hi[a] };
            let q =
                self.velocity_from_density
                    .transform_point3(DVec3::new(pick(0), pick(1), pick(2)));
            vlo = vlo.min(q);
            vhi = vhi.max(q);
        }
        if !vlo.is_finite() || !vhi.is_finite() {
            return f64::INFINITY;
        }
        let cell_lo =
            [0, 1, 2].map(|a| (vlo[a] / 8.0).floor() as i64 - speed.cell_origin[a] as i64);
        let cell_hi =
            [0, 1, 2].map(|a| (vhi[a] / 8.0).floor() as i64 - speed.cell_origin[a] as i64);
        let index_speed = |m: [f32; 3]| SpeedBounds::index_speed(m, &self.index_from_value);
        let dims = speed.dims.map(|d| d as i64);
        let leaves = (0..3).any(|a| cell_lo[a] < 0 || cell_hi[a] >= dims[a]);
        let mut s: f64 = if leaves {
            index_speed(speed.outside_component_max)
        } else {
            0.0
        };
        if dims.contains(&0) {
            return s;
        }
        let lo_c = [0, 1, 2].map(|a| cell_lo[a].clamp(0, dims[a] - 1));
        let hi_c = [0, 1, 2].map(|a| cell_hi[a].clamp(-1, dims[a] - 1));
        for z in lo_c[2]..=hi_c[2] {
            for y in lo_c[1]..=hi_c[1] {
                for x in lo_c[0]..=hi_c[0] {
                    let i = (x + dims[0] * (y + dims[1] * z)) as usize;
                    s = s.max(index_speed(speed.component_max[i]));
                }
            }
        }
        s
    }

    /// The largest density-index speed any velocity lookup can return.
    pub fn max_speed(&self) -> f64 {
        self.velocity.speed.max_index_speed(&self.index_from_value)
    }

    /// The longest displacement `|q - p|` of [`Self::source`] for `|k| <= k_max` and `p` in the
    /// density index box `[lo, hi]`: `k_max` times the speed bound over the box grown by the
    /// first step's longest displacement (where the second lookup is made).
    pub fn radius(&self, lo: DVec3, hi: DVec3, k_max: f64) -> f64 {
        if !(k_max > 0.0) {
            return if k_max == 0.0 { 0.0 } else { f64::INFINITY };
        }
        let r1 = k_max * self.speed_bound(lo, hi);
        if !r1.is_finite() {
            return f64::INFINITY;
        }
        let r = k_max * self.speed_bound(lo - DVec3::splat(r1), hi + DVec3::splat(r1));
        // Rounding of the lookups' own arithmetic (a few ulps of the coordinates).
        r * (1.0 + 1e-9) + 1e-9 * (1.0 + lo.abs().max(hi.abs()).max_element())
    }
}
