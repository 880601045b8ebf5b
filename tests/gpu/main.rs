//! GPU parity: every WGSL mirror against the Rust it mirrors (bit for bit where the arithmetic
//! allows, to rounding elsewhere), the wavefront against the CPU path tracer by z-tests, GPU farm
//! parts merged with CPU ones, the light and data passes against the CPU's. Skipped, with a line saying
//! so, only where no adapter exists.
//!
//! One module per concern; `cargo test --release --test gpu MODULE::` runs one of them.
#[path = "../common/mod.rs"]
mod common;

mod dda;
mod distance;
mod equiangular;
mod farm;
mod grid;
mod math;
mod media_lights;
mod media_overlap;
mod motion_blur;
mod passes;
mod phase;
mod render;
mod rng;
mod sobol;
mod transmittance;
mod wgsl;
