//! [`VectorGrid`]: a Vec3 grid (a fluid cache's velocity) in Brume's sparse brick layout, one
//! [`SparseGrid`] per component over one shared cell box, with OpenVDB's trilinear lookups
//! (cell-centred or staggered) and per-leaf-cell speed bounds ([`SpeedBounds`]).
use brume_ffi::{FloatGridData, GridClass, Leaf, Tile, Vec3GridData, LEAF_VOXELS};

use super::convert::leaf_voxel;
use super::error::NonFiniteTally;
use super::speed_bounds::SpeedBounds;
use super::{ConversionPolicy, GridStats, SparseGrid, VolumeError};
use crate::math::{DAffine3, DVec3};

/// Axis names for messages.
const AXES: [&str; 3] = ["x", "y", "z"];

/// A vector grid: component `a` of the vector at voxel `(i, j, k)` is `components[a].voxel(i,
/// j, k)`. All three components share `cell_origin` and `dims`, so a leaf cell means the same
/// voxels in each.
#[derive(Clone, Debug)]
pub struct VectorGrid {
    /// The x, y and z components, each a signed [`SparseGrid`] (no clamping).
    pub components: [SparseGrid; 3],
    /// OpenVDB's `GRID_STAGGERED` (MAC): component `a` of voxel `ijk` sits on its lower face
    /// along `a`, at index point `ijk - 0.5 e_a`; otherwise every component sits at the centre.
    pub staggered: bool,
    /// The vector everywhere outside the cell box.
    pub background: [f32; 3],
    /// Per-leaf-cell bounds on the speed that [`sample`](Self::sample) can return.
    pub speed: SpeedBounds,
}

impl VectorGrid {
    /// Converts a Vec3 grid read from OpenVDB. NaN or Inf in any component of any value a
    /// lookup can read (leaf voxels, tiles, the background) is refused with their count and the
    /// first one's place; otherwise values are kept exactly, negatives included.
    pub fn from_vdb(data: &Vec3GridData, policy: ConversionPolicy) -> Result<Self, VolumeError> {
        check_finite(data)?;
        // One component at a time, so only one split copy of the values is alive.
        let [x, y, z] = [0, 1, 2].map(|a| SparseGrid::from_vdb_signed(&component(data, a), policy));
        let mut components = [x?, y?, z?];
        share_cell_box(&mut components);
        let staggered = data.info.class == GridClass::Staggered;
        let speed = SpeedBounds::build(&components, staggered);
        Ok(Self {
            components,
            staggered,
            background: data.background,
            speed,
        })
    }

    /// The vector at index point `p` as OpenVDB reconstructs it: `BoxSampler` (trilinear, z
    /// then y then x) on each component for a cell-centred grid, `StaggeredBoxSampler` (the
    /// same, component `a` read at `p + 0.5 e_a`) for a staggered one; the results agree with
    /// OpenVDB bit for bit. Outside the cell box, and at NaN coordinates, the background.
    #[inline]
    pub fn sample(&self, p: DVec3) -> DVec3 {
        let [x, y, z] = &self.components;
        if self.staggered {
            // `p + Vec3R(0.5, 0, 0)` as OpenVDB writes it, so the floors and fractions match.
            DVec3::new(
                x.sample_trilinear(p + DVec3::new(0.5, 0.0, 0.0)) as f64,
                y.sample_trilinear(p + DVec3::new(0.0, 0.5, 0.0)) as f64,
                z.sample_trilinear(p + DVec3::new(0.0, 0.0, 0.5)) as f64,
            )
        } else {
            DVec3::new(
                x.sample_trilinear(p) as f64,
                y.sample_trilinear(p) as f64,
                z.sample_trilinear(p) as f64,
            )
        }
    }

    /// The stored vector of voxel `(i, j, k)` (its components' own places: see `staggered`).
    pub fn voxel(&self, i: i32, j: i32, k: i32) -> [f32; 3] {
        self.components.each_ref().map(|c| c.voxel(i, j, k))
    }

    /// Maps index space (voxel centres at integer points) to world space.
    pub fn world_from_index(&self) -> DAffine3 {
        self.components[0].world_from_index
    }

    /// Voxel edge lengths along the index axes, in world units.
    pub fn voxel_size(&self) -> DVec3 {
        self.components[0].voxel_size
    }

    /// The largest speed a lookup can return in voxels per unit time, the values read as
    /// world-space vectors ([`SpeedBounds::index_speed`]).
    pub fn max_index_speed(&self) -> f64 {
        self.speed
            .max_index_speed(&self.components[0].index_from_world)
    }

    /// Cell counts of the shared cell box.
    pub fn dims(&self) -> [u32; 3] {
        self.components[0].dims
    }

    /// Bricks over the three components.
    pub fn brick_count(&self) -> usize {
        self.components.iter().map(SparseGrid::brick_count).sum()
    }

    /// Bytes of the three components' layouts plus the speed bounds.
    pub fn memory_bytes(&self) -> u64 {
        let layout: u64 = self
            .components
            .iter()
            .map(|c| GridStats::total_bytes(&c.stats()))
            .sum();
        layout + self.speed.memory_bytes()
    }
}

/// Rejects NaN and Inf in any component of anything a lookup can read, counting components.
fn check_finite(data: &Vec3GridData) -> Result<(), VolumeError> {
    let mut tally = NonFiniteTally::default();
    let mut note = |v: [f32; 3], at: [i32; 3], what: [&'static str; 3]| {
        for a in 0..3 {
            tally.note(v[a], at, what[a]);
        }
    };
    note(
        data.background,
        [0; 3],
        [
            "background, x component",
            "background, y component",
            "background, z component",
        ],
    );
    for leaf in &data.leaves {
        for (offset, v) in leaf.values.iter().enumerate() {
            let at = leaf_voxel(leaf.origin, offset);
            note(
                *v,
                at,
                [
                    "leaf voxel, x component",
                    "leaf voxel, y component",
                    "leaf voxel, z component",
                ],
            );
        }
    }
    for tile in &data.tiles {
        note(
            tile.value,
            tile.origin,
            [
                "tile, x component",
                "tile, y component",
                "tile, z component",
            ],
        );
    }
    tally.finish()
}

/// Component `a` of a Vec3 grid as a float grid (same leaves, tiles and transform).
fn component(data: &Vec3GridData, a: usize) -> FloatGridData {
    let mut info = data.info.clone();
    info.name = format!("{}.{}", data.info.name, AXES[a]);
    info.background = Some(data.background[a] as f64);
    let leaves = data
        .leaves
        .iter()
        .map(|l| {
            let mut values = Box::new([0f32; LEAF_VOXELS]);
            for (out, v) in values.iter_mut().zip(l.values.iter()) {
                *out = v[a];
            }
            Leaf {
                origin: l.origin,
                values,
                active: l.active,
            }
        })
        .collect();
    let tiles = data
        .tiles
        .iter()
        .map(|t| Tile {
            origin: t.origin,
            dim: t.dim,
            value: t.value[a],
            active: t.active,
        })
        .collect();
    FloatGridData {
        info,
        background: data.background[a],
        leaves,
        tiles,
    }
}

/// Widens every component to the union of their cell boxes (a tile can differ from the
/// background in one component only), which changes no value.
fn share_cell_box(components: &mut [SparseGrid; 3]) {
    let boxes: Vec<([i64; 3], [i64; 3])> = components
        .iter()
        .filter(|c| !c.cells.is_empty())
        .map(|c| {
            let lo = c.cell_origin.map(i64::from);
            (lo, [0, 1, 2].map(|a| lo[a] + c.dims[a] as i64))
        })
        .collect();
    let Some(&(mut lo, mut hi)) = boxes.first() else {
        return;
    };
    for (l, h) in &boxes {
        for a in 0..3 {
            lo[a] = lo[a].min(l[a]);
            hi[a] = hi[a].max(h[a]);
        }
    }
    let origin = lo.map(|c| c as i32);
    let dims = [0, 1, 2].map(|a| (hi[a] - lo[a]) as u32);
    for c in components.iter_mut() {
        if c.cells.is_empty() || c.cell_origin != origin || c.dims != dims {
            c.widen_to(origin, dims);
        }
    }
}
