//! OpenVDB for Brume, behind a narrow C ABI.
//!
//! `shim/brume_vdb.cpp` is a small C++17 layer over Debian's `libopenvdb-dev` with opaque
//! handles and integer statuses; [`sys`] holds its bindgen bindings; this module is the safe
//! wrapper. It owns the handles (`Drop`) and converts grids at once into the plain Rust types of
//! [`types`], so no OpenVDB type escapes this crate.
//!
//! [`embree`] does the same for Intel Embree 3 (`shim/brume_embree.cpp`): triangle scenes and
//! single-ray queries.
pub mod embree;
pub mod sys;
pub mod types;
mod vec3;
mod wrapper;

pub use types::*;
pub use vec3::*;
pub use wrapper::*;
