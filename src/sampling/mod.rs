//! Sampling building blocks: random streams the GPU reproduces, warps, discrete choices and the
//! chi-square harness that tests them.
pub mod chi2;
pub mod discrete;
pub mod piecewise;
pub mod rng;
pub mod sobol;
pub mod warp;

pub use discrete::{sample_discrete, DiscreteSample};
pub use rng::Rng;
pub use sobol::{Decision, Sampler, SamplerKind};
