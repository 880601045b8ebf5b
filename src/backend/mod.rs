//! Execution backends. `gpu`: wgpu compute shaders (Vulkan; Mesa lavapipe in CI).
pub mod gpu;
