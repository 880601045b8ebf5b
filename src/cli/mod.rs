pub mod compare;
pub mod info;
pub mod merge;
pub mod passes;
pub mod render;
pub mod render_report;
pub mod study;
pub mod viewer;
