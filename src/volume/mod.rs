//! Brume's sparse volume layout, per-leaf bounds and the majorant DDA.
//!
//! The path from an OpenVDB file to the tracking loop:
//! [`FloatGridData`](brume_ffi::FloatGridData) --[`SparseGrid::from_vdb`]--> [`SparseGrid`]
//! --[`LeafBounds::build`]--> [`LeafBounds`] --[`DdaMajorantIterator`]--> [`MajorantSegment`]s.
pub mod adaptive;
pub mod advection;
pub mod bounds;
pub mod check;
pub mod convert;
pub mod cost;
pub mod cull;
pub mod dda;
pub mod error;
pub mod grid;
pub mod merge;
pub mod motion;
pub mod phase;
pub mod phases;
pub mod reference;
pub mod segment;
pub mod speed_bounds;
pub mod tracking;
pub mod vector;
pub mod voxel_bounds;

pub use adaptive::{AdaptiveMajorantIterator, AdaptiveMajorants, AdaptiveShape, AdaptiveStats};
pub use advection::Advection;
pub use bounds::{BoundsStats, CellBounds, LeafBounds};
pub use convert::{dense_to_vdb, synthetic_info, ConversionPolicy, ConversionReport};
pub use cost::CostModel;
pub use cull::{LeafCulling, VoxelCulling};
pub use dda::DdaMajorantIterator;
pub use error::VolumeError;
pub use grid::{GridStats, SparseGrid, CONSTANT_BIT, DEFAULT_MAX_CELLS};
pub use reference::VdbReference;
pub use segment::MajorantSegment;
pub use speed_bounds::SpeedBounds;
pub use vector::VectorGrid;
pub mod load;
pub mod mitsuba_vol;
pub use load::{
    load_grid, load_grid_from, load_scene_grid, load_scene_vector_grid, load_vector_grid_from,
    GridLoadError, LoadError, LoadedGrid,
};
