//! Why the GPU did not render, for every part of the wavefront to return.
/// Why the GPU did not render.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GpuRenderError {
    /// The scene needs a feature the GPU integrator does not have (one line, for the CPU
    /// fallback message).
    #[error("GPU backend: {0}")]
    Unsupported(String),
    /// The scene's data exceed the device's limits.
    #[error("GPU backend: {0}")]
    Limits(String),
    /// wgpu reported an error (validation, device).
    #[error("GPU backend: {0}")]
    Device(String),
}
