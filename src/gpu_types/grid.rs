//! The sparse grid's header, rays and majorant segments as the tracking kernels read them.
use bytemuck::{Pod, Zeroable};
use std::mem::size_of;

/// A [`SparseGrid`](crate::volume::SparseGrid) header: everything a shader needs besides the
/// flat `cells`, `bricks`, `constants` and per-cell bounds buffers.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGridInfo {
    /// Cell counts `[nx, ny, nz]` of the dense cell index (leaf resolution, 8 voxels a cell).
    pub dims: [u32; 3],
    /// Number of 512-float bricks in the `bricks` buffer.
    pub brick_count: u32,
    /// Cell coordinate (voxel coordinate / 8, floored) of `cells[0]`.
    pub cell_origin: [i32; 3],
    /// Number of entries in the `constants` buffer (entry 0 is the background).
    pub constant_count: u32,
    /// Rows of the 3x4 affine map from world space to index space (voxel centres at integer
    /// points): `index = (dot(row0, (w, 1)), dot(row1, (w, 1)), dot(row2, (w, 1)))`.
    pub index_from_world: [[f32; 4]; 3],
    /// Value outside the cell box.
    pub background: f32,
    /// Extinction per unit of grid value: `sigma_t = density_scale * value` (per unit `t`
    /// of an index-space ray).
    pub density_scale: f32,
    /// Index of the global [`crate::volume::bounds::CellBounds`] in the bounds buffer: it follows the per-cell
    /// bounds, so this equals the cell count.
    pub global_bounds_index: u32,
    /// First entry of this grid in the cells buffer: 0 for the density grid; the emission
    /// grids of a wavefront render follow it in the same buffers (their brick and constant
    /// indices already offset), so one set of bindings serves every grid.
    pub cell_offset: u32,
}
const _: () = assert!(size_of::<GpuGridInfo>() == 96);

/// A ray `o + t d` with its parameter interval (index space for the tracking kernels).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRay {
    /// Origin.
    pub o: [f32; 3],
    /// Start of the parameter interval.
    pub t_min: f32,
    /// Direction (not necessarily unit length; `t` is measured in its units).
    pub d: [f32; 3],
    /// End of the parameter interval (may be `f32::INFINITY`).
    pub t_max: f32,
}
const _: () = assert!(size_of::<GpuRay>() == 32);

/// Mirror of [`MajorantSegment`](crate::volume::MajorantSegment).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMajorantSegment {
    /// Start of the segment (ray parameter).
    pub t_min: f32,
    /// End of the segment (ray parameter).
    pub t_max: f32,
    /// Upper bound of `sigma_t` over the segment, per unit `t`.
    pub sigma_maj: f32,
    /// Lower bound of `sigma_t` over the segment, per unit `t`.
    pub sigma_min: f32,
}
const _: () = assert!(size_of::<GpuMajorantSegment>() == 16);

impl From<crate::volume::MajorantSegment> for GpuMajorantSegment {
    fn from(s: crate::volume::MajorantSegment) -> Self {
        GpuMajorantSegment {
            t_min: s.t_min,
            t_max: s.t_max,
            sigma_maj: s.sigma_maj,
            sigma_min: s.sigma_min,
        }
    }
}

/// The rows of the 3x4 affine map `m`, rounded to f32 (the layout of
/// [`GpuGridInfo::index_from_world`]).
pub fn daffine_rows(m: crate::math::DAffine3) -> [[f32; 4]; 3] {
    let (a, t) = (m.matrix3, m.translation);
    let row = |r: usize| {
        [
            a.col(0)[r] as f32,
            a.col(1)[r] as f32,
            a.col(2)[r] as f32,
            t[r] as f32,
        ]
    };
    [row(0), row(1), row(2)]
}

impl GpuGridInfo {
    /// The header of `grid` with `sigma_t = density_scale * value`.
    pub fn new(grid: &crate::volume::SparseGrid, density_scale: f32) -> GpuGridInfo {
        GpuGridInfo {
            dims: grid.dims,
            brick_count: grid.brick_count() as u32,
            cell_origin: grid.cell_origin,
            constant_count: grid.constants.len() as u32,
            index_from_world: daffine_rows(grid.index_from_world),
            background: grid.background,
            density_scale,
            global_bounds_index: grid.cells.len() as u32,
            cell_offset: 0,
        }
    }
}
