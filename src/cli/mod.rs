pub mod bench;
pub mod cycles;
pub mod info;
pub mod render;
