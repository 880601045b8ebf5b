//! What a render is, whichever backend runs it: the scene prepared for rendering
//! ([`RenderScene`]: media ready to track, lights ready to sample, surface kinds and the
//! feature flags that select specialised code), the render's settings, its lights and
//! environment, the media's emission and its bounds, and the stack of nested media. The CPU
//! path tracer (`crate::integrator`) and the GPU wavefront (`crate::backend::gpu`) both read
//! it; neither is read by it.
pub mod blackbody;
pub mod cell_tree;
pub mod emission;
pub mod emission_bounds;
pub mod envmap;
pub mod light_groups;
pub mod lights;
pub mod media;
pub mod media_lights;
pub mod prepare;
pub mod settings;
pub mod stack;

pub use prepare::{FeatureFlags, RenderScene};
pub use settings::{
    Absorption, BlackbodyModel, Estimator, LightSelection, MajorantMode, RenderSettings,
    SamplerKind, ShadowEstimator, VolumeSampling,
};
