//! OpenVDB for Brume, behind a narrow C ABI.
pub mod types;
pub use types::*;
