//! Brume: an offline volumetric renderer for OpenVDB media in glTF scenes.
pub mod film;
pub mod math;
pub mod volume;
