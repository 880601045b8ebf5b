//! A slow, obviously correct sampler that reads [`FloatGridData`] directly (leaf, then tile,
//! then background), against which [`SparseGrid`](super::SparseGrid)'s fast lookups are
//! tested. It applies the same clamp of negatives to 0 as the conversion policy, so the two
//! should agree bit for bit on any grid the conversion accepts.
use std::collections::HashMap;

use brume_ffi::{FloatGridData, Leaf};

use crate::math::DVec3;

pub struct VdbReference<'a> {
    data: &'a FloatGridData,
    /// Leaf origin to its position in `data.leaves`.
    leaves: HashMap<[i32; 3], usize>,
}

/// One linear blend as OpenVDB's `BoxSampler` computes it for floats.
fn lerp(a: f32, b: f32, w: f64) -> f32 {
    let scaled = (b - a) as f64 * w;
    a + scaled as f32
}

impl<'a> VdbReference<'a> {
    pub fn new(data: &'a FloatGridData) -> Self {
        let leaves = data
            .leaves
            .iter()
            .enumerate()
            .map(|(n, l)| (l.origin, n))
            .collect();
        Self { data, leaves }
    }

    /// The raw value OpenVDB would return for voxel `ijk`, clamped at 0.
    pub fn voxel(&self, ijk: [i64; 3]) -> f32 {
        self.raw_voxel(ijk).max(0.0)
    }

    fn raw_voxel(&self, ijk: [i64; 3]) -> f32 {
        let outside_i32 = ijk
            .iter()
            .any(|&c| c < i32::MIN as i64 || c > i32::MAX as i64);
        if outside_i32 {
            return self.data.background;
        }
        let ijk = ijk.map(|c| c as i32);
        let leaf_origin = ijk.map(|c| c.div_euclid(8) * 8);
        if let Some(&n) = self.leaves.get(&leaf_origin) {
            let local = [0, 1, 2].map(|a| (ijk[a] - leaf_origin[a]) as usize);
            return self.data.leaves[n].values[Leaf::offset(local[0], local[1], local[2])];
        }
        for tile in &self.data.tiles {
            let inside = (0..3).all(|a| {
                let rel = ijk[a] as i64 - tile.origin[a] as i64;
                rel >= 0 && rel < tile.dim as i64
            });
            if inside {
                return tile.value;
            }
        }
        self.data.background
    }

    /// OpenVDB's `PointSampler`: the voxel at `round(p)`, halves away from zero (C `::round`).
    pub fn sample_nearest(&self, p: DVec3) -> f32 {
        let r = p.round();
        self.voxel([r.x as i64, r.y as i64, r.z as i64])
    }

    /// OpenVDB's `BoxSampler`: blend the voxels `floor(p) + {0,1}^3` along z, then y, then x.
    pub fn sample_trilinear(&self, p: DVec3) -> f32 {
        let i0 = p.floor();
        let w = p - i0;
        let base = [i0.x as i64, i0.y as i64, i0.z as i64];
        let v = |i: i64, j: i64, k: i64| self.voxel([base[0] + i, base[1] + j, base[2] + k]);
        let x0 = lerp(
            lerp(v(0, 0, 0), v(0, 0, 1), w.z),
            lerp(v(0, 1, 0), v(0, 1, 1), w.z),
            w.y,
        );
        let x1 = lerp(
            lerp(v(1, 0, 0), v(1, 0, 1), w.z),
            lerp(v(1, 1, 0), v(1, 1, 1), w.z),
            w.y,
        );
        lerp(x0, x1, w.x)
    }
}
