use std::ffi::{c_char, CStr, CString};
use std::fmt;
use std::path::{Path, PathBuf};
use std::ptr;

use crate::sys;
use crate::types::*;

/// What went wrong, by the shim's status code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VdbErrorKind {
    Io,
    Format,
    NotFound,
    Type,
    InvalidArgument,
    OutOfMemory,
    Internal,
    /// OpenVDB's reader crashed or ran past its time limit on the file (in a child process).
    ReaderCrashed,
}

/// An OpenVDB failure, always naming the file it concerns.
#[derive(Clone, Debug)]
pub struct VdbError {
    pub path: PathBuf,
    pub kind: VdbErrorKind,
    pub message: String,
}

impl fmt::Display for VdbError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.message)
    }
}

impl std::error::Error for VdbError {}

impl VdbError {
    pub(crate) fn new(path: &Path, kind: VdbErrorKind, message: impl Into<String>) -> Self {
        Self {
            path: path.to_path_buf(),
            kind,
            message: message.into(),
        }
    }
}

/// Takes ownership of a shim-allocated string.
///
/// # Safety
/// `s` must be null or a string allocated by the shim and not yet freed.
unsafe fn take_string(s: *mut c_char) -> String {
    if s.is_null() {
        return String::new();
    }
    let out = CStr::from_ptr(s).to_string_lossy().into_owned();
    sys::brume_vdb_string_free(s);
    out
}

/// Runs one shim call with an error slot and converts its status.
pub(crate) fn call(path: &Path, f: impl FnOnce(*mut *mut c_char) -> i32) -> Result<(), VdbError> {
    let mut error: *mut c_char = ptr::null_mut();
    let status = f(&mut error);
    // SAFETY: the shim either leaves `error` null or stores an owned string in it.
    let message = unsafe { take_string(error) };
    let kind = match status as u32 {
        sys::BRUME_VDB_OK => return Ok(()),
        sys::BRUME_VDB_IO_ERROR => VdbErrorKind::Io,
        sys::BRUME_VDB_FORMAT_ERROR => VdbErrorKind::Format,
        sys::BRUME_VDB_NOT_FOUND => VdbErrorKind::NotFound,
        sys::BRUME_VDB_TYPE_ERROR => VdbErrorKind::Type,
        sys::BRUME_VDB_INVALID_ARGUMENT => VdbErrorKind::InvalidArgument,
        sys::BRUME_VDB_OUT_OF_MEMORY => VdbErrorKind::OutOfMemory,
        sys::BRUME_VDB_READER_CRASHED => VdbErrorKind::ReaderCrashed,
        _ => VdbErrorKind::Internal,
    };
    let message = if message.is_empty() {
        format!("OpenVDB call failed with status {status}")
    } else {
        message
    };
    Err(VdbError::new(path, kind, message))
}

pub(crate) fn c_string(path: &Path, s: &str) -> Result<CString, VdbError> {
    CString::new(s).map_err(|_| {
        VdbError::new(
            path,
            VdbErrorKind::InvalidArgument,
            "name contains a NUL byte",
        )
    })
}

fn c_path(path: &Path) -> Result<CString, VdbError> {
    use std::os::unix::ffi::OsStrExt;
    CString::new(path.as_os_str().as_bytes()).map_err(|_| {
        VdbError::new(
            path,
            VdbErrorKind::InvalidArgument,
            "path contains a NUL byte",
        )
    })
}

/// Copies a shim grid-info struct into Rust and frees it.
///
/// # Safety
/// `raw` must have been filled by a successful shim call and not yet freed.
pub(crate) unsafe fn take_info(raw: &mut sys::BrumeVdbGridInfo) -> GridInfo {
    let mut m = [[0.0; 4]; 4];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = raw.world_from_index[r * 4 + c];
        }
    }
    let mut metadata = Vec::with_capacity(raw.metadata_count);
    for i in 0..raw.metadata_count {
        let s = |k: usize| {
            let p = *raw.metadata.add(3 * i + k);
            if p.is_null() {
                String::new()
            } else {
                CStr::from_ptr(p).to_string_lossy().into_owned()
            }
        };
        metadata.push((s(0), s(1), s(2)));
    }
    let cstr = |p: *mut c_char| {
        if p.is_null() {
            String::new()
        } else {
            CStr::from_ptr(p).to_string_lossy().into_owned()
        }
    };
    let info = GridInfo {
        name: cstr(raw.name),
        value_type: cstr(raw.value_type),
        class: match raw.grid_class as u32 {
            sys::BRUME_VDB_CLASS_LEVEL_SET => GridClass::LevelSet,
            sys::BRUME_VDB_CLASS_FOG_VOLUME => GridClass::FogVolume,
            sys::BRUME_VDB_CLASS_STAGGERED => GridClass::Staggered,
            _ => GridClass::Unknown,
        },
        voxel_size: raw.voxel_size,
        world_from_index: m,
        is_affine: raw.is_affine != 0,
        active_bbox: (raw.has_active_bbox != 0)
            .then_some((raw.active_bbox_min, raw.active_bbox_max)),
        active_voxel_count: raw.active_voxel_count,
        leaf_count: raw.leaf_count,
        tile_count: raw.tile_count,
        background: (raw.has_background != 0).then_some(raw.background),
        metadata,
    };
    sys::brume_vdb_grid_info_free(raw);
    info
}

/// An open `.vdb` file with all its grids read into memory.
pub struct VdbFile {
    path: PathBuf,
    pub(crate) raw: *mut sys::BrumeVdbFile,
    grids: Vec<GridInfo>,
    metadata: Vec<(String, String, String)>,
}

// SAFETY: the handle is immutable after `open`; the shim's const entry points only read it
// (OpenVDB grids are safe to read concurrently, each call makes its own accessor).
unsafe impl Send for VdbFile {}
unsafe impl Sync for VdbFile {}

/// Seconds the child process may take to read a file of `bytes` bytes: a minute, plus the time
/// a slow disk and OpenVDB's decompression need at 4 MB/s. `BRUME_VDB_READ_TIMEOUT` (seconds,
/// 0 for none) overrides it.
pub fn read_timeout(bytes: u64) -> f64 {
    if let Some(s) = std::env::var("BRUME_VDB_READ_TIMEOUT")
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
    {
        return s;
    }
    60.0 + bytes as f64 / 4.0e6
}

impl Drop for VdbFile {
    fn drop(&mut self) {
        // SAFETY: `raw` came from brume_vdb_open and is freed exactly once.
        unsafe { sys::brume_vdb_file_free(self.raw) }
    }
}

/// The environment variable that makes [`VdbFile::open`] read in this process (profiling).
pub const IN_PROCESS_ENV: &str = "BRUME_VDB_IN_PROCESS";

impl VdbFile {
    /// Opens and reads the whole file. Errors (missing file, a directory, an empty or
    /// truncated file, random bytes) name the file and the problem.
    ///
    /// OpenVDB parses the bytes in a child process (see `brume_vdb_open_isolated`): OpenVDB
    /// 10's reader trusts some lengths in the file and overflows the heap on a corrupt one, so
    /// a crash there must not take the renderer down. The child's time limit is
    /// [`read_timeout`] for the file's size.
    ///
    /// With the environment variable [`IN_PROCESS_ENV`] set (to anything), it reads as
    /// [`VdbFile::open_trusted`] instead: a profiler that runs the renderer on a simulated CPU
    /// (valgrind's callgrind, as `tools/bench/callgrind-majorants.sh` does) cannot follow the
    /// re-executed reader, so the file must be read in the process it watches. Only for files
    /// you trust.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, VdbError> {
        let path = path.as_ref();
        if std::env::var_os(IN_PROCESS_ENV).is_some() {
            return Self::open_trusted(path);
        }
        let c = c_path(path)?;
        let timeout = std::fs::metadata(path)
            .map(|m| read_timeout(m.len()))
            .unwrap_or(0.0);
        let mut raw = ptr::null_mut();
        // SAFETY: valid C string and out pointer; the shim catches every exception.
        call(path, |e| unsafe {
            sys::brume_vdb_open_isolated(c.as_ptr(), timeout, &mut raw, e)
        })?;
        Self::from_raw(path, raw)
    }

    /// Like [`VdbFile::open`], but OpenVDB parses the file in this process: faster by one copy
    /// of the grids, and only for files you trust (written by Brume or OpenVDB's own tools).
    pub fn open_trusted(path: impl AsRef<Path>) -> Result<Self, VdbError> {
        let path = path.as_ref();
        let c = c_path(path)?;
        let mut raw = ptr::null_mut();
        // SAFETY: valid C string and out pointer; the shim catches every exception.
        call(path, |e| unsafe {
            sys::brume_vdb_open(c.as_ptr(), &mut raw, e)
        })?;
        Self::from_raw(path, raw)
    }

    fn from_raw(path: &Path, raw: *mut sys::BrumeVdbFile) -> Result<Self, VdbError> {
        let mut file = VdbFile {
            path: path.to_path_buf(),
            raw,
            grids: Vec::new(),
            metadata: Vec::new(),
        };
        let mut count = 0usize;
        // SAFETY: `raw` is a live handle.
        call(path, |e| unsafe {
            sys::brume_vdb_grid_count(file.raw, &mut count, e)
        })?;
        for i in 0..count {
            // SAFETY: zeroed is a valid "empty" info struct; the shim fills it on success.
            let mut info: sys::BrumeVdbGridInfo = unsafe { std::mem::zeroed() };
            call(path, |e| unsafe {
                sys::brume_vdb_grid_info(file.raw, i, &mut info, e)
            })?;
            // SAFETY: filled by a successful call.
            file.grids.push(unsafe { take_info(&mut info) });
        }
        let mut n = 0usize;
        let mut triples: *mut *mut c_char = ptr::null_mut();
        call(path, |e| unsafe {
            sys::brume_vdb_file_metadata(file.raw, &mut n, &mut triples, e)
        })?;
        for i in 0..n {
            // SAFETY: the shim returned 3 * n valid strings.
            let s = |k: usize| unsafe {
                CStr::from_ptr(*triples.add(3 * i + k))
                    .to_string_lossy()
                    .into_owned()
            };
            file.metadata.push((s(0), s(1), s(2)));
        }
        // SAFETY: frees exactly what the shim allocated.
        unsafe { sys::brume_vdb_strings_free(triples, 3 * n) };
        Ok(file)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Facts about every grid in the file, in file order.
    pub fn grids(&self) -> &[GridInfo] {
        &self.grids
    }

    /// File-level metadata as `(name, type, value)`.
    pub fn metadata(&self) -> &[(String, String, String)] {
        &self.metadata
    }

    /// Opens a float grid by name as an OpenVDB-side handle (for OpenVDB's own samplers);
    /// most callers want [`VdbFile::read_float_grid`]. A missing grid name lists the grids
    /// the file does have.
    pub fn open_float_grid(
        &self,
        name: &str,
        options: ReadOptions,
    ) -> Result<OpenVdbFloatGrid, VdbError> {
        if !self.grids.iter().any(|g| g.name == name) {
            let names: Vec<_> = self.grids.iter().map(|g| format!("'{}'", g.name)).collect();
            return Err(VdbError::new(
                &self.path,
                VdbErrorKind::NotFound,
                format!(
                    "no grid named '{name}' (the file has {})",
                    if names.is_empty() {
                        "no grids".into()
                    } else {
                        names.join(", ")
                    }
                ),
            ));
        }
        let c = c_string(&self.path, name)?;
        let flags = if options.level_set_to_fog {
            sys::BRUME_VDB_LEVEL_SET_TO_FOG
        } else {
            0
        };
        let mut raw = ptr::null_mut();
        // SAFETY: live file handle, valid C string, out pointer.
        call(&self.path, |e| unsafe {
            sys::brume_vdb_float_grid_open(self.raw, c.as_ptr(), flags, &mut raw, e)
        })?;
        Ok(OpenVdbFloatGrid {
            path: self.path.clone(),
            raw,
        })
    }

    /// Reads a float grid completely (every leaf, every tile, the background) into Rust.
    pub fn read_float_grid(
        &self,
        name: &str,
        options: ReadOptions,
    ) -> Result<FloatGridData, VdbError> {
        self.open_float_grid(name, options)?.read()
    }
}

/// How to read a grid.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReadOptions {
    /// Convert a level set into a fog volume (OpenVDB's `sdfToFogVolume`: 0 outside, rising
    /// linearly to 1 across the inner half of the narrow band, 1 inside).
    pub level_set_to_fog: bool,
}

/// A float grid held by OpenVDB, for reading out and for OpenVDB's own samplers.
pub struct OpenVdbFloatGrid {
    path: PathBuf,
    raw: *mut sys::BrumeVdbFloatGrid,
}

// SAFETY: the grid is never mutated after open; every shim call on it only reads, with its own
// accessor.
unsafe impl Send for OpenVdbFloatGrid {}
unsafe impl Sync for OpenVdbFloatGrid {}

impl Drop for OpenVdbFloatGrid {
    fn drop(&mut self) {
        // SAFETY: `raw` came from brume_vdb_float_grid_open and is freed exactly once.
        unsafe { sys::brume_vdb_float_grid_free(self.raw) }
    }
}

/// Which of OpenVDB's samplers to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleOrder {
    /// `openvdb::tools::PointSampler`: the voxel at `round(p)` (C `::round`, halves away from zero).
    Nearest = 0,
    /// `openvdb::tools::BoxSampler`: trilinear over the 8 voxels around `p`.
    Trilinear = 1,
}

impl OpenVdbFloatGrid {
    pub fn info(&self) -> Result<GridInfo, VdbError> {
        // SAFETY: zeroed is a valid empty info; filled on success.
        let mut info: sys::BrumeVdbGridInfo = unsafe { std::mem::zeroed() };
        call(&self.path, |e| unsafe {
            sys::brume_vdb_float_grid_info(self.raw, &mut info, e)
        })?;
        // SAFETY: filled by a successful call.
        Ok(unsafe { take_info(&mut info) })
    }

    /// Copies every leaf and tile out of OpenVDB.
    pub fn read(&self) -> Result<FloatGridData, VdbError> {
        let info = self.info()?;
        let (mut leaf_count, mut tile_count, mut background) = (0usize, 0usize, 0.0f32);
        // SAFETY: live handle and out pointers.
        call(&self.path, |e| unsafe {
            sys::brume_vdb_float_grid_counts(
                self.raw,
                &mut leaf_count,
                &mut tile_count,
                &mut background,
                e,
            )
        })?;
        let mut origins = vec![0i32; 3 * leaf_count];
        let mut values = vec![0f32; LEAF_VOXELS * leaf_count];
        let mut masks = vec![0u64; 8 * leaf_count];
        // SAFETY: buffers sized exactly as the shim requires (checked again on its side).
        call(&self.path, |e| unsafe {
            sys::brume_vdb_float_grid_copy_leaves(
                self.raw,
                origins.as_mut_ptr(),
                values.as_mut_ptr(),
                masks.as_mut_ptr(),
                leaf_count,
                e,
            )
        })?;
        let leaves = (0..leaf_count)
            .map(|i| {
                let mut v = Box::new([0f32; LEAF_VOXELS]);
                v.copy_from_slice(&values[i * LEAF_VOXELS..(i + 1) * LEAF_VOXELS]);
                let mut active = [0u64; 8];
                active.copy_from_slice(&masks[8 * i..8 * i + 8]);
                Leaf {
                    origin: [origins[3 * i], origins[3 * i + 1], origins[3 * i + 2]],
                    values: v,
                    active,
                }
            })
            .collect();
        let mut t_origins = vec![0i32; 3 * tile_count];
        let mut t_dims = vec![0u32; tile_count];
        let mut t_values = vec![0f32; tile_count];
        let mut t_active = vec![0u8; tile_count];
        // SAFETY: as above.
        call(&self.path, |e| unsafe {
            sys::brume_vdb_float_grid_copy_tiles(
                self.raw,
                t_origins.as_mut_ptr(),
                t_dims.as_mut_ptr(),
                t_values.as_mut_ptr(),
                t_active.as_mut_ptr(),
                tile_count,
                e,
            )
        })?;
        let tiles = (0..tile_count)
            .map(|i| Tile {
                origin: [t_origins[3 * i], t_origins[3 * i + 1], t_origins[3 * i + 2]],
                dim: t_dims[i],
                value: t_values[i],
                active: t_active[i] != 0,
            })
            .collect();
        Ok(FloatGridData {
            info,
            background,
            leaves,
            tiles,
        })
    }

    /// OpenVDB's own sampler at index-space points, one accessor for the whole batch.
    pub fn sample(&self, points: &[[f64; 3]], order: SampleOrder) -> Result<Vec<f32>, VdbError> {
        let mut out = vec![0f32; points.len()];
        self.sample_into(points, order, &mut out)?;
        Ok(out)
    }

    /// As [`Self::sample`], into a caller's buffer (`out.len() == points.len()`).
    pub fn sample_into(
        &self,
        points: &[[f64; 3]],
        order: SampleOrder,
        out: &mut [f32],
    ) -> Result<(), VdbError> {
        assert_eq!(
            points.len(),
            out.len(),
            "sample_into: output length must match"
        );
        // SAFETY: `[[f64; 3]]` is contiguous 3 * n doubles; `out` holds n floats.
        call(&self.path, |e| unsafe {
            sys::brume_vdb_float_grid_sample(
                self.raw,
                points.as_ptr() as *const f64,
                points.len(),
                order as i32,
                out.as_mut_ptr(),
                e,
            )
        })
    }
}

/// One grid to write with [`write_float_grids`]: sparse active voxels.
#[derive(Clone, Debug)]
pub struct GridSpec {
    pub name: String,
    pub class: GridClass,
    /// Write a `vec3s` grid with `(v, v, v)` instead of a float grid (for tests of type errors).
    pub as_vec3: bool,
    /// Row-major, column-vector convention, affine.
    pub world_from_index: [[f64; 4]; 4],
    pub background: f32,
    pub voxels: Vec<([i32; 3], f32)>,
    /// Collapse constant leaves into active tiles (`openvdb::tools::prune`).
    pub prune: bool,
    pub save_as_half: bool,
    /// A Vec3 grid of one vector a voxel: when set, written in place of `voxels`,
    /// `background` and `as_vec3`.
    pub vectors: Option<Vec3Voxels>,
}

/// The voxels of a Vec3 grid to write (fixtures for velocity grids).
#[derive(Clone, Debug, Default)]
pub struct Vec3Voxels {
    pub background: [f32; 3],
    pub voxels: Vec<([i32; 3], [f32; 3])>,
    /// Write `vec3d` (double) values instead of `vec3s`.
    pub double: bool,
}

impl GridSpec {
    /// A fog-volume float grid with a uniform voxel size and an index origin at world `origin`.
    pub fn fog(name: &str, voxel_size: f64, origin: [f64; 3]) -> Self {
        let v = voxel_size;
        Self {
            name: name.to_string(),
            class: GridClass::FogVolume,
            as_vec3: false,
            world_from_index: [
                [v, 0.0, 0.0, origin[0]],
                [0.0, v, 0.0, origin[1]],
                [0.0, 0.0, v, origin[2]],
                [0.0, 0.0, 0.0, 1.0],
            ],
            background: 0.0,
            voxels: Vec::new(),
            prune: true,
            save_as_half: false,
            vectors: None,
        }
    }

    /// A Vec3 grid of class `class` (cell-centred `Unknown` or `Staggered`), empty, with a zero
    /// background, uniform voxels and the index origin at world `origin`; fill
    /// `vectors.voxels`.
    pub fn vec3(name: &str, class: GridClass, voxel_size: f64, origin: [f64; 3]) -> Self {
        Self {
            class,
            prune: false,
            vectors: Some(Vec3Voxels::default()),
            ..Self::fog(name, voxel_size, origin)
        }
    }
}

/// Writes grids to a `.vdb` file (Blosc-compressed when OpenVDB has Blosc), atomically.
pub fn write_float_grids(path: impl AsRef<Path>, grids: &[GridSpec]) -> Result<(), VdbError> {
    let path = path.as_ref();
    let c = c_path(path)?;
    let names: Vec<CString> = grids
        .iter()
        .map(|g| c_string(path, &g.name))
        .collect::<Result<_, _>>()?;
    let coords: Vec<Vec<i32>> = grids
        .iter()
        .map(|g| g.voxels.iter().flat_map(|(c, _)| *c).collect())
        .collect();
    let values: Vec<Vec<f32>> = grids
        .iter()
        .map(|g| g.voxels.iter().map(|(_, v)| *v).collect())
        .collect();
    let vectors: Vec<Vec<f32>> = grids
        .iter()
        .map(|g| {
            g.vectors
                .iter()
                .flat_map(|v| &v.voxels)
                .flat_map(|(_, v)| *v)
                .collect()
        })
        .collect();
    let vector_coords: Vec<Vec<i32>> = grids
        .iter()
        .map(|g| {
            g.vectors
                .iter()
                .flat_map(|v| &v.voxels)
                .flat_map(|(c, _)| *c)
                .collect()
        })
        .collect();
    let specs: Vec<sys::BrumeVdbGridSpec> = grids
        .iter()
        .enumerate()
        .map(|(i, g)| {
            let mut m = [0.0; 16];
            for r in 0..4 {
                for c in 0..4 {
                    m[r * 4 + c] = g.world_from_index[r][c];
                }
            }
            sys::BrumeVdbGridSpec {
                name: names[i].as_ptr(),
                grid_class: match g.class {
                    GridClass::LevelSet => sys::BRUME_VDB_CLASS_LEVEL_SET,
                    GridClass::FogVolume => sys::BRUME_VDB_CLASS_FOG_VOLUME,
                    GridClass::Staggered => sys::BRUME_VDB_CLASS_STAGGERED,
                    GridClass::Unknown => sys::BRUME_VDB_CLASS_UNKNOWN,
                } as i32,
                value_kind: match &g.vectors {
                    None => g.as_vec3 as i32,
                    Some(v) => 2 + v.double as i32,
                },
                world_from_index: m,
                background: g.background,
                count: g
                    .vectors
                    .as_ref()
                    .map_or(g.voxels.len(), |v| v.voxels.len()),
                coords: if g.vectors.is_some() {
                    vector_coords[i].as_ptr()
                } else {
                    coords[i].as_ptr()
                },
                values: values[i].as_ptr(),
                prune: g.prune as i32,
                save_as_half: g.save_as_half as i32,
                vectors: vectors[i].as_ptr(),
                vector_background: g.vectors.as_ref().map_or([0.0; 3], |v| v.background),
            }
        })
        .collect();
    // SAFETY: every pointer in `specs` borrows from vectors alive for the whole call.
    call(path, |e| unsafe {
        sys::brume_vdb_write_float_grids(c.as_ptr(), specs.as_ptr(), specs.len(), e)
    })
}
