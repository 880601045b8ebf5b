pub mod bench;
pub mod bench_gpu;
pub mod bench_peers;
pub mod compare;
pub mod cycles;
pub mod info;
pub mod render;
pub mod study;
