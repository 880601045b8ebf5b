pub mod bench;
pub mod bench_gpu;
pub mod cycles;
pub mod compare;
pub mod info;
pub mod render;
pub mod study;
