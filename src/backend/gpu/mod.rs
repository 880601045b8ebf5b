//! The wgpu backend: device set-up and buffer helpers ([`device`]) and WGSL module assembly
//! ([`shader`]). The WGSL mirrors of the CPU physics live in `shaders/common/`, one file per
//! concept, each opening with a comment naming the Rust code it mirrors; the shared structs are
//! declared once in [`crate::gpu_types`].
//!
//! The wavefront integrator, one concept per module: the stage graph and its WGSL variants
//! ([`graph`]), the scene as the GPU reads it (`upload`,
//! `geometry`), every buffer and the kernels bound
//! to them (`buffers`), the per-batch scheduler (`dispatch`), the render loop over passes
//! and batches ([`render`]) and what it renders as the CPU would (`support`).
pub mod device;
pub mod shader;

pub use device::{GpuContext, GpuGrid, GpuUnavailable};
pub use shader::{Module, ShaderFile, Spec};
mod buffers;
mod dispatch;
mod error;
mod geometry;
pub mod graph;
mod media_lights;
mod params;
pub mod render;
mod support;
mod upload;

pub use render::{render, supports, supports_with, GpuRenderError, Stage};
