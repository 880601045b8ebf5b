//! Brume: an offline volumetric renderer for OpenVDB media in glTF scenes.
pub mod accel;
pub mod backend;
pub mod film;
pub mod gpu_types;
pub mod integrator;
pub mod math;
pub mod sampling;
pub mod scene;
pub mod study;
pub mod volume;
