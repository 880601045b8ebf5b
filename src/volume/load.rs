//! From a `.vdb` path and a grid name to Brume's layout and bounds, with one error type that
//! always names the file. Every user of OpenVDB data (scenes, `brume info`, tests) comes
//! through here, so the load policy is stated once:
//! - the grid must hold `float` values (others are refused, naming their type);
//! - a level set is converted to a fog volume by OpenVDB's `sdfToFogVolume` (0 outside, 1
//!   deep inside) and a warning says so, because a signed distance read as density is
//!   negative inside and meaningless;
//! - NaN or Inf values are refused; negative densities are clamped to 0 with a warning
//!   ([`SparseGrid::from_vdb`]);
//! - non-affine (frustum) transforms are refused; any affine map, non-uniform scale and shear
//!   included, is supported because rays are walked in index space.
//!
//! Vector grids (a fluid cache's velocity) load through [`load_vector_grid_from`]: `vec3s` or
//! `vec3d` values, kept signed; NaN or Inf refused; a wrong type or a missing name lists the
//! file's grids with their types.
use std::path::{Path, PathBuf};

use brume_ffi::{GridClass, GridInfo, ReadOptions, VdbError, VdbFile};

use super::{ConversionPolicy, ConversionReport, LeafBounds, SparseGrid, VectorGrid, VolumeError};

/// A grid converted for rendering, with what conversion noticed.
pub struct LoadedGrid {
    pub grid: SparseGrid,
    pub bounds: LeafBounds,
    /// The grid's facts as OpenVDB reported them (before any level-set conversion).
    pub info: GridInfo,
    pub report: ConversionReport,
    /// Human-readable warnings (level-set conversion, clamped values).
    pub warnings: Vec<String>,
}

#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("{0}")]
    Vdb(#[from] VdbError),
    #[error("{path}: grid '{grid}': {source}")]
    Volume {
        path: PathBuf,
        grid: String,
        source: VolumeError,
    },
}

/// Opens `path` and converts the float grid `grid_name`.
pub fn load_grid(
    path: &Path,
    grid_name: &str,
    policy: ConversionPolicy,
) -> Result<LoadedGrid, LoadError> {
    let file = VdbFile::open(path)?;
    load_grid_from(&file, grid_name, policy)
}

/// As [`load_grid`], from a file already open (several grids of one file).
pub fn load_grid_from(
    file: &VdbFile,
    grid_name: &str,
    policy: ConversionPolicy,
) -> Result<LoadedGrid, LoadError> {
    let data = file.read_float_grid(
        grid_name,
        ReadOptions {
            level_set_to_fog: true,
        },
    )?;
    let info = file
        .grids()
        .iter()
        .find(|g| g.name == grid_name)
        .cloned()
        .unwrap_or_else(|| data.info.clone());
    let mut warnings = Vec::new();
    if info.class == GridClass::LevelSet {
        warnings.push(format!(
            "{}: grid '{grid_name}' is a level set; converted to a fog volume (0 outside, 1 inside)",
            file.path().display()
        ));
    }
    let (grid, report) =
        SparseGrid::from_vdb(&data, policy).map_err(|source| LoadError::Volume {
            path: file.path().to_path_buf(),
            grid: grid_name.to_string(),
            source,
        })?;
    warnings.extend(
        report
            .warnings
            .iter()
            .map(|w| format!("{}: grid '{grid_name}': {w}", file.path().display())),
    );
    let bounds = LeafBounds::build(&grid);
    Ok(LoadedGrid {
        grid,
        bounds,
        info,
        report,
        warnings,
    })
}

/// Converts the Vec3 grid `grid_name` (a velocity) of an open file.
pub fn load_vector_grid_from(
    file: &VdbFile,
    grid_name: &str,
    policy: ConversionPolicy,
) -> Result<VectorGrid, LoadError> {
    let data = file.read_vec3_grid(grid_name)?;
    VectorGrid::from_vdb(&data, policy).map_err(|source| LoadError::Volume {
        path: file.path().to_path_buf(),
        grid: grid_name.to_string(),
        source,
    })
}

/// Why a scene's grid could not be loaded: the file itself (missing, truncated, not a VDB),
/// or the named grid inside it (absent, not `float`, NaN/Inf values, ...). The scene loader
/// blames a different glTF field for each (`uri` or the grid's name field).
#[derive(Clone, Debug, PartialEq)]
pub enum GridLoadError {
    File(String),
    Grid(String),
}

/// Opens `path` and converts grid `grid_name` under the default load policy, classifying a
/// failure as the file's or the grid's. This is how the scene loader reads grids: OpenVDB's
/// types stay in this module.
pub fn load_scene_grid(path: &Path, grid_name: &str) -> Result<LoadedGrid, GridLoadError> {
    let file = VdbFile::open(path).map_err(|e| GridLoadError::File(e.message))?;
    load_grid_from(&file, grid_name, ConversionPolicy::default()).map_err(|e| match e {
        LoadError::Vdb(e) => GridLoadError::Grid(e.message),
        LoadError::Volume { source, .. } => GridLoadError::Grid(source.to_string()),
    })
}

/// As [`load_scene_grid`] for a Vec3 grid (a medium's velocity).
pub fn load_scene_vector_grid(path: &Path, grid_name: &str) -> Result<VectorGrid, GridLoadError> {
    let file = VdbFile::open(path).map_err(|e| GridLoadError::File(e.message))?;
    load_vector_grid_from(&file, grid_name, ConversionPolicy::default()).map_err(|e| match e {
        LoadError::Vdb(e) => GridLoadError::Grid(e.message),
        LoadError::Volume { source, .. } => GridLoadError::Grid(source.to_string()),
    })
}
