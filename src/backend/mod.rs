//! Where renders run: the CPU (rayon over tiles) and, later, the GPU (wgpu wavefront).
pub mod cpu;
