//! OpenVDB for Brume, behind a narrow C ABI.
//!
//! `shim/brume_vdb.cpp` is a small C++17 layer over Debian's `libopenvdb-dev` with opaque
//! handles and integer statuses; [`sys`] holds its bindgen bindings; this module is the safe
//! wrapper. It owns the handles (`Drop`) and converts grids at once into the plain Rust types of
//! [`types`], so no OpenVDB type escapes this crate.
pub mod sys;
pub mod types;
mod vec3;
mod wrapper;

pub use types::*;
pub use vec3::*;
pub use wrapper::*;
