//! A [`SparseGrid`] as Mitsuba 3's `.vol` grid (the file its `gridvolume` texture reads), so
//! that Mitsuba renders exactly the density Brume reconstructs, for reference comparisons
//! (`brume mitsuba`).
//!
//! # Alignment
//! OpenVDB (and Brume) centre voxel `i` at index point `i` and reconstruct trilinearly between
//! voxel centres, with the background (0 for a density) beyond the stored voxels. Mitsuba's
//! `gridvolume` is a texture over a bounding box: with `n` texels along an axis, texel `i` is
//! centred at `bbox_min + (i + 1/2) * (bbox_max - bbox_min) / n`, trilinear between texel
//! centres, clamped to the edge texels outside them. So we write the voxels of the index box
//! `[lo - 1, hi + 1]`, where `[lo, hi]` bounds every non-zero voxel and the extra layer is
//! zeros, with the box from `lo - 1.5` to `hi + 1.5` in index space: texel `t` is then centred
//! at index point `lo - 1 + t`, the voxel it holds, and outside the written centres both
//! renderers read 0. The box stays in index space, in exact half-integers; the index-to-world
//! transform goes to Mitsuba separately. Mitsuba 3.9 takes the texture's box from its
//! `to_world` (which maps the unit cube), not from the header (measured: a header box of
//! [10, 13] x [0, 2]^2 loads as the unit cube), so the caller passes
//! `world_from_index * translate(bbox_min) * scale(bbox_max - bbox_min)`; the header carries
//! the same box for other readers.
//!
//! # Format (Mitsuba's `gridvolume` documentation)
//! Bytes `VOL`, version byte 3, then little-endian: `i32` encoding (1 = float32), `i32` x, y, z
//! counts, `i32` channels, six `f32` for the box (min xyz, max xyz), then `f32` values with the
//! channel fastest, then x, then y, then z.
use std::io::Write;
use std::path::Path;

use super::grid::{SparseGrid, BRICK_DIM, BRICK_VOXELS, CONSTANT_BIT};
use crate::math::IndexBox;

/// A dense grid ready to be written as a `.vol` file.
#[derive(Clone, Debug, PartialEq)]
pub struct VolGrid {
    /// Texel counts along x, y, z.
    pub dims: [usize; 3],
    /// Values per texel.
    pub channels: usize,
    /// Texel box in the grid's index space (half a voxel outside the outermost centres).
    pub bbox_min: [f32; 3],
    pub bbox_max: [f32; 3],
    /// `values[c + channels * (x + nx * (y + ny * z))]`.
    pub values: Vec<f32>,
}

/// Why a grid cannot be written for Mitsuba.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum VolError {
    /// Padding with zeros reproduces Brume's lookups only when the grid reads 0 beyond its
    /// stored voxels.
    #[error("background value {0} is not 0: Mitsuba's grid would not read it outside the box")]
    NonZeroBackground(f32),
    #[error("the grid has no non-zero voxel")]
    Empty,
    #[error("{0} texels are too many for a dense .vol file (limit {1})")]
    TooLarge(u64, u64),
}

/// Largest dense `.vol` written: 2^28 floats (1 GiB) per channel.
pub const MAX_TEXELS: u64 = 1 << 28;

/// Inclusive index box `[lo, hi]` of the voxels whose stored value is not 0, or `None`.
/// Brume reads stored values whether OpenVDB marks them active or not, so the box comes from
/// the values, not from the active-voxel box.
pub fn nonzero_index_box(grid: &SparseGrid) -> Option<([i64; 3], [i64; 3])> {
    let mut voxels = IndexBox::EMPTY;
    let [nx, ny, nz] = grid.dims;
    for cz in 0..nz {
        for cy in 0..ny {
            for cx in 0..nx {
                let entry = grid.cells[grid.cell_index(cx, cy, cz)];
                let cell = [cx, cy, cz];
                let base =
                    [0, 1, 2].map(|a| (cell[a] as i64 + grid.cell_origin[a] as i64) * BRICK_DIM);
                if entry & CONSTANT_BIT != 0 {
                    if grid.constants[(entry & !CONSTANT_BIT) as usize] != 0.0 {
                        voxels.include(base, base.map(|b| b + BRICK_DIM - 1));
                    }
                    continue;
                }
                let brick = &grid.bricks[entry as usize * BRICK_VOXELS..][..BRICK_VOXELS];
                for (local, &v) in brick.iter().enumerate() {
                    if v != 0.0 {
                        let l = [local % 8, local / 8 % 8, local / 64].map(|x| x as i64);
                        let p = [base[0] + l[0], base[1] + l[1], base[2] + l[2]];
                        voxels.include(p, p);
                    }
                }
            }
        }
    }
    voxels.corners()
}

/// The grid's values at voxel centres over its non-zero box and one voxel of zeros around
/// it, each multiplied by `channel_scales` (one channel per scale). A voxel centre is where
/// Brume's trilinear lookup equals the stored voxel exactly (all weights 0 or 1), so these
/// are Brume's own reconstructed values.
pub fn vol_from_grid(grid: &SparseGrid, channel_scales: &[f32]) -> Result<VolGrid, VolError> {
    if grid.background != 0.0 {
        return Err(VolError::NonZeroBackground(grid.background));
    }
    let (lo, hi) = nonzero_index_box(grid).ok_or(VolError::Empty)?;
    // One zero voxel each side.
    let first = lo.map(|l| l - 1);
    let dims = [0, 1, 2].map(|a| (hi[a] - lo[a] + 3) as usize);
    let texels = dims.iter().map(|&d| d as u64).product::<u64>();
    if texels > MAX_TEXELS {
        return Err(VolError::TooLarge(texels, MAX_TEXELS));
    }
    let channels = channel_scales.len();
    let mut values = Vec::with_capacity(texels as usize * channels);
    for z in 0..dims[2] as i64 {
        for y in 0..dims[1] as i64 {
            for x in 0..dims[0] as i64 {
                let (i, j, k) = (first[0] + x, first[1] + y, first[2] + z);
                let d = grid.voxel(i as i32, j as i32, k as i32);
                values.extend(channel_scales.iter().map(|s| d * s));
            }
        }
    }
    Ok(VolGrid {
        dims,
        channels,
        // Half a voxel outside the outermost written centres (`first` and `hi + 1`).
        bbox_min: first.map(|f| f as f32 - 0.5),
        bbox_max: [0, 1, 2].map(|a| (hi[a] + 1) as f32 + 0.5),
        values,
    })
}

impl VolGrid {
    /// The `.vol` bytes (see the module documentation).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(48 + 4 * self.values.len());
        out.extend_from_slice(b"VOL");
        out.push(3);
        let ints = [
            1,
            self.dims[0] as i32,
            self.dims[1] as i32,
            self.dims[2] as i32,
            self.channels as i32,
        ];
        for v in ints {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in self
            .bbox_min
            .iter()
            .chain(&self.bbox_max)
            .chain(&self.values)
        {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
        f.write_all(&self.to_bytes())?;
        f.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::DVec3;

    fn le_i32(b: &[u8], at: usize) -> i32 {
        i32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }
    fn le_f32(b: &[u8], at: usize) -> f32 {
        f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    /// A 3 x 2 x 1 block at voxel (5, -2, 7): header, zero padding, half-voxel box, x fastest.
    #[test]
    fn header_padding_box_and_order() {
        let values = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let (grid, _) = SparseGrid::from_dense([3, 2, 1], [5, -2, 7], &values, 0.0).unwrap();
        let vol = vol_from_grid(&grid, &[2.0]).unwrap();
        assert_eq!(vol.dims, [5, 4, 3]);
        assert_eq!(vol.bbox_min, [3.5, -3.5, 5.5]);
        assert_eq!(vol.bbox_max, [8.5, 0.5, 8.5]);
        let b = vol.to_bytes();
        assert_eq!(&b[..4], b"VOL\x03");
        assert_eq!([4, 8, 12, 16, 20].map(|o| le_i32(&b, o)), [1, 5, 4, 3, 1]);
        assert_eq!(le_f32(&b, 24), 3.5);
        assert_eq!(le_f32(&b, 44), 8.5);
        assert_eq!(b.len(), 48 + 4 * 5 * 4 * 3);
        // Texel (x, y, z) holds voxel (4 + x, -3 + y, 6 + z), scaled by 2.
        let at = |x: usize, y: usize, z: usize| vol.values[x + 5 * (y + 4 * z)];
        assert_eq!(at(1, 1, 1), 2.0);
        assert_eq!(at(2, 1, 1), 4.0);
        assert_eq!(at(1, 2, 1), 8.0);
        assert_eq!(at(3, 2, 1), 12.0);
        // The padding layer is zero all round.
        for z in 0..3 {
            for y in 0..4 {
                for x in 0..5 {
                    let inside = (1..4).contains(&x) && (1..3).contains(&y) && z == 1;
                    if !inside {
                        assert_eq!(at(x, y, z), 0.0, "texel {x} {y} {z}");
                    }
                }
            }
        }
        assert_eq!(le_f32(&b, 48 + 4 * (1 + 5 * (1 + 4))), 2.0);
    }

    /// Mitsuba's texture lookup (texel centres spanning the box, trilinear, clamped), written
    /// out here, reproduces Brume's trilinear lookups everywhere, inside and outside.
    #[test]
    fn texel_centres_reproduce_brume_lookups() {
        let dims = [4, 3, 5];
        let values: Vec<f32> = (0..60)
            .map(|i| ((i * 37) % 11) as f32 * 0.1 + 0.05)
            .collect();
        let (grid, _) = SparseGrid::from_dense(dims, [-2, 6, 1], &values, 0.0).unwrap();
        let vol = vol_from_grid(&grid, &[1.0]).unwrap();
        let texture = |p: DVec3| -> f64 {
            let n = vol.dims;
            let mut idx = [0i64; 3];
            let mut f = [0f64; 3];
            for a in 0..3 {
                let u =
                    (p[a] - vol.bbox_min[a] as f64) / (vol.bbox_max[a] - vol.bbox_min[a]) as f64;
                let t = u * n[a] as f64 - 0.5;
                let t0 = t.floor();
                idx[a] = t0 as i64;
                f[a] = t - t0;
            }
            let clamp = |i: i64, a: usize| i.clamp(0, vol.dims[a] as i64 - 1) as usize;
            let mut sum = 0.0;
            for corner in 0..8 {
                let o = [corner & 1, corner >> 1 & 1, corner >> 2 & 1];
                let mut w = 1.0;
                let mut c = [0usize; 3];
                for a in 0..3 {
                    c[a] = clamp(idx[a] + o[a] as i64, a);
                    w *= if o[a] == 1 { f[a] } else { 1.0 - f[a] };
                }
                sum += w * vol.values[c[0] + n[0] * (c[1] + n[1] * c[2])] as f64;
            }
            sum
        };
        for s in 0..2000 {
            // A quasi-random walk over and around the box.
            let h = |k: u32| ((s * 2654435761u32.wrapping_add(k)) % 10007) as f64 / 10007.0;
            let p = DVec3::new(-5.0 + 10.0 * h(1), 3.0 + 9.0 * h(2), -2.0 + 11.0 * h(3));
            let brume = grid.sample_trilinear(p) as f64;
            assert!(
                (texture(p) - brume).abs() < 1e-5,
                "at {p}: {} vs {brume}",
                texture(p)
            );
        }
    }

    #[test]
    fn refuses_empty_and_nonzero_background() {
        let (grid, _) = SparseGrid::from_dense([2, 2, 2], [0, 0, 0], &[0.0; 8], 0.0).unwrap();
        assert_eq!(vol_from_grid(&grid, &[1.0]), Err(VolError::Empty));
        let (grid, _) = SparseGrid::from_dense([2, 2, 2], [0, 0, 0], &[1.0; 8], 0.5).unwrap();
        assert_eq!(
            vol_from_grid(&grid, &[1.0]),
            Err(VolError::NonZeroBackground(0.5))
        );
    }
}
