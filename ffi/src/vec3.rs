//! Vec3 grids (fluid velocities) through the shim: open by name with errors that list the
//! file's grids and their types, copy out into [`Vec3GridData`], and OpenVDB's own samplers.
use std::path::PathBuf;
use std::ptr;

use crate::sys;
use crate::types::*;
use crate::wrapper::{c_string, call, take_info, VdbError, VdbErrorKind, VdbFile};

/// Value types [`VdbFile::open_vec3_grid`] accepts.
pub const VEC3_VALUE_TYPES: [&str; 2] = ["vec3s", "vec3d"];

impl VdbFile {
    /// The file's grids with their value types, for error messages:
    /// `'density' (float), 'vel' (vec3s)`, or `no grids`.
    pub fn grid_list(&self) -> String {
        if self.grids().is_empty() {
            return "no grids".to_string();
        }
        let names: Vec<_> = self
            .grids()
            .iter()
            .map(|g| format!("'{}' ({})", g.name, g.value_type))
            .collect();
        names.join(", ")
    }

    /// Opens the Vec3 grid `name` (`vec3s`, or `vec3d` rounded to single precision) as an
    /// OpenVDB-side handle. A missing name, or a grid of another type, is an error that names
    /// the file, says what the grid holds and lists the file's grids with their types.
    pub fn open_vec3_grid(&self, name: &str) -> Result<OpenVdbVec3Grid, VdbError> {
        let Some(info) = self.grids().iter().find(|g| g.name == name) else {
            return Err(VdbError::new(
                self.path(),
                VdbErrorKind::NotFound,
                format!("no grid named '{name}' (the file has {})", self.grid_list()),
            ));
        };
        if !VEC3_VALUE_TYPES.contains(&info.value_type.as_str()) {
            return Err(VdbError::new(
                self.path(),
                VdbErrorKind::Type,
                format!(
                    "grid '{name}' is a {} grid, not a Vec3 grid (vec3s or vec3d); the file has {}",
                    info.value_type,
                    self.grid_list()
                ),
            ));
        }
        let c = c_string(self.path(), name)?;
        let mut raw = ptr::null_mut();
        // SAFETY: live file handle, valid C string, out pointer.
        call(self.path(), |e| unsafe {
            sys::brume_vdb_vec3_grid_open(self.raw, c.as_ptr(), &mut raw, e)
        })?;
        Ok(OpenVdbVec3Grid {
            path: self.path().to_path_buf(),
            raw,
        })
    }

    /// Reads a Vec3 grid completely (every leaf, every tile, the background) into Rust.
    pub fn read_vec3_grid(&self, name: &str) -> Result<Vec3GridData, VdbError> {
        self.open_vec3_grid(name)?.read()
    }
}

/// Which of OpenVDB's samplers [`OpenVdbVec3Grid::sample`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Vec3Sampler {
    /// `PointSampler`: the voxel at `round(p)`.
    Point = sys::BRUME_VDB_SAMPLE_POINT as isize,
    /// `BoxSampler`: trilinear, every component at `p` (cell-centred vectors).
    Box = sys::BRUME_VDB_SAMPLE_BOX as isize,
    /// `StaggeredPointSampler`: component `a` from the voxel at `round(p + 0.5 e_a)`.
    StaggeredPoint = sys::BRUME_VDB_SAMPLE_STAGGERED_POINT as isize,
    /// `StaggeredBoxSampler`: component `a` trilinear at `p + 0.5 e_a` (MAC grids).
    StaggeredBox = sys::BRUME_VDB_SAMPLE_STAGGERED_BOX as isize,
}

impl Vec3Sampler {
    /// The trilinear sampler OpenVDB meant for a grid of this class.
    pub fn trilinear_for(class: GridClass) -> Self {
        if class == GridClass::Staggered {
            Self::StaggeredBox
        } else {
            Self::Box
        }
    }
}

/// A Vec3 grid held by OpenVDB (in single precision), for reading out and for OpenVDB's own
/// samplers.
pub struct OpenVdbVec3Grid {
    path: PathBuf,
    raw: *mut sys::BrumeVdbVec3Grid,
}

// SAFETY: the grid is never mutated after open; every shim call on it only reads, with its own
// accessor.
unsafe impl Send for OpenVdbVec3Grid {}
unsafe impl Sync for OpenVdbVec3Grid {}

impl Drop for OpenVdbVec3Grid {
    fn drop(&mut self) {
        // SAFETY: `raw` came from brume_vdb_vec3_grid_open and is freed exactly once.
        unsafe { sys::brume_vdb_vec3_grid_free(self.raw) }
    }
}

impl OpenVdbVec3Grid {
    /// The grid's facts as the file holds it (a `vec3d` grid reports `vec3d`).
    pub fn info(&self) -> Result<GridInfo, VdbError> {
        // SAFETY: zeroed is a valid empty info; filled on success.
        let mut info: sys::BrumeVdbGridInfo = unsafe { std::mem::zeroed() };
        call(&self.path, |e| unsafe {
            sys::brume_vdb_vec3_grid_info(self.raw, &mut info, e)
        })?;
        // SAFETY: filled by a successful call.
        Ok(unsafe { take_info(&mut info) })
    }

    /// Copies every leaf and tile out of OpenVDB.
    pub fn read(&self) -> Result<Vec3GridData, VdbError> {
        let info = self.info()?;
        let (mut leaf_count, mut tile_count, mut background) = (0usize, 0usize, [0f32; 3]);
        // SAFETY: live handle and out pointers (3 floats for the background).
        call(&self.path, |e| unsafe {
            sys::brume_vdb_vec3_grid_counts(
                self.raw,
                &mut leaf_count,
                &mut tile_count,
                background.as_mut_ptr(),
                e,
            )
        })?;
        Ok(Vec3GridData {
            info,
            background,
            leaves: self.leaves(leaf_count)?,
            tiles: self.tiles(tile_count)?,
        })
    }

    fn leaves(&self, count: usize) -> Result<Vec<Vec3Leaf>, VdbError> {
        let mut origins = vec![0i32; 3 * count];
        let mut values = vec![[0f32; 3]; LEAF_VOXELS * count];
        let mut masks = vec![0u64; 8 * count];
        // SAFETY: buffers sized exactly as the shim requires (checked again on its side);
        // `[[f32; 3]]` is contiguous floats.
        call(&self.path, |e| unsafe {
            sys::brume_vdb_vec3_grid_copy_leaves(
                self.raw,
                origins.as_mut_ptr(),
                values.as_mut_ptr() as *mut f32,
                masks.as_mut_ptr(),
                count,
                e,
            )
        })?;
        Ok((0..count)
            .map(|i| {
                let mut v = Box::new([[0f32; 3]; LEAF_VOXELS]);
                v.copy_from_slice(&values[i * LEAF_VOXELS..(i + 1) * LEAF_VOXELS]);
                let mut active = [0u64; 8];
                active.copy_from_slice(&masks[8 * i..8 * i + 8]);
                Vec3Leaf {
                    origin: [origins[3 * i], origins[3 * i + 1], origins[3 * i + 2]],
                    values: v,
                    active,
                }
            })
            .collect())
    }

    fn tiles(&self, count: usize) -> Result<Vec<Vec3Tile>, VdbError> {
        let mut origins = vec![0i32; 3 * count];
        let mut dims = vec![0u32; count];
        let mut values = vec![[0f32; 3]; count];
        let mut active = vec![0u8; count];
        // SAFETY: as for the leaves.
        call(&self.path, |e| unsafe {
            sys::brume_vdb_vec3_grid_copy_tiles(
                self.raw,
                origins.as_mut_ptr(),
                dims.as_mut_ptr(),
                values.as_mut_ptr() as *mut f32,
                active.as_mut_ptr(),
                count,
                e,
            )
        })?;
        Ok((0..count)
            .map(|i| Vec3Tile {
                origin: [origins[3 * i], origins[3 * i + 1], origins[3 * i + 2]],
                dim: dims[i],
                value: values[i],
                active: active[i] != 0,
            })
            .collect())
    }

    /// OpenVDB's own sampler at index-space points, one accessor for the whole batch.
    pub fn sample(
        &self,
        points: &[[f64; 3]],
        sampler: Vec3Sampler,
    ) -> Result<Vec<[f32; 3]>, VdbError> {
        let mut out = vec![[0f32; 3]; points.len()];
        // SAFETY: `[[f64; 3]]` is 3 * n contiguous doubles; `out` holds 3 * n floats.
        call(&self.path, |e| unsafe {
            sys::brume_vdb_vec3_grid_sample(
                self.raw,
                points.as_ptr() as *const f64,
                points.len(),
                sampler as i32,
                out.as_mut_ptr() as *mut f32,
                e,
            )
        })?;
        Ok(out)
    }
}
