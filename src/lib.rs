//! Brume: an offline volumetric renderer for OpenVDB media in glTF scenes.
pub mod backend;
pub mod gpu_types;
pub mod math;
pub mod sampling;
pub mod volume;
