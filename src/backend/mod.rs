//! Where renders run: the CPU (rayon over tiles) and the GPU (wgpu compute shaders; Mesa
//! lavapipe in CI when there is no GPU).
pub mod cpu;
pub mod gpu;
