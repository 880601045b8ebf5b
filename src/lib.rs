//! Brume: an offline volumetric renderer for OpenVDB media in glTF scenes.
pub mod accel;
pub mod film;
pub mod math;
pub mod sampling;
pub mod scene;
pub mod volume;
