//! Helpers shared by the integration tests: synthetic grids and statistics.
#![allow(dead_code, unused_imports)]
pub mod boxes;
pub mod cli;
pub mod culled;
pub mod farm;
pub mod gpu;
pub mod grids;
pub mod overlap;
pub mod reference;
pub mod render;
pub mod scratch;
pub mod stats;
pub mod stress;
pub use grids::*;
pub use stats::*;
