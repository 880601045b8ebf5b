//! The wgpu backend: device set-up and buffer helpers ([`device`]) and WGSL module assembly
//! ([`shader`]). The WGSL mirrors of the CPU physics live in `shaders/common/`, one file per
//! concept, each opening with a comment naming the Rust code it mirrors; the shared structs are
//! declared once in [`crate::gpu_types`].
pub mod device;
pub mod shader;

pub use device::{GpuContext, GpuGrid, GpuUnavailable};
pub use shader::{Module, ShaderFile, Spec};
pub mod render;

pub use render::{render, supports, GpuRenderError, Stage};
