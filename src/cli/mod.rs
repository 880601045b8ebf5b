pub mod bench;
pub mod bench_gpu;
pub mod cycles;
pub mod info;
pub mod render;
