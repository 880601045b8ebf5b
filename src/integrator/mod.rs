//! Integrators: the CPU reference path tracer and the pieces every integrator shares
//! (prepared media and lights, BSDFs, the specialisation on scene features).
pub mod blackbody;
pub mod bsdf;
pub mod emission;
pub mod emission_bounds;
pub mod envmap;
pub mod homogeneous;
pub mod lights;
pub mod media;
pub mod mixture;
pub mod nested;
pub mod path;
pub mod prepare;
pub mod settings;
pub mod stack;
pub mod tile;
pub mod views;

pub use prepare::{FeatureFlags, RenderScene};
pub use settings::{
    Absorption, Estimator, LightSelection, MajorantMode, RenderSettings, SamplerKind,
    ShadowEstimator,
};
